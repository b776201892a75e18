// shapemap demo: The main job on built-in generated shapes
#include "common.h"

namespace shapemap::cli {

Command register_demo(CLI::App& app, GlobalOptions& g) {
  Command c;
  c.app = app.add_subcommand("demo", "The main job on built-in generated shapes");
  c.run = [] { return not_built("'demo'"); };
  return c;
}

}  // namespace shapemap::cli
