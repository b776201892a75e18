// shapemap register: Registration of two volumes through their ball parameterizations
#include "common.h"

namespace shapemap::cli {

Command register_register(CLI::App& app, GlobalOptions& g) {
  Command c;
  c.app = app.add_subcommand("register", "Registration of two volumes through their ball parameterizations");
  c.run = [] { return not_built("'register'"); };
  return c;
}

}  // namespace shapemap::cli
