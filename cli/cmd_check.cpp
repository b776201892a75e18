// shapemap check: Validity report of a surface or tetrahedral mesh
#include "common.h"

namespace shapemap::cli {

Command register_check(CLI::App& app, GlobalOptions& g) {
  Command c;
  c.app = app.add_subcommand("check", "Validity report of a surface or tetrahedral mesh");
  c.run = [] { return not_built("'check'"); };
  return c;
}

}  // namespace shapemap::cli
