// shapemap render: PNG pictures of meshes and maps
#include "common.h"

namespace shapemap::cli {

Command register_render(CLI::App& app, GlobalOptions& g) {
  Command c;
  c.app = app.add_subcommand("render", "PNG pictures of meshes and maps");
  c.run = [] { return not_built("'render'"); };
  return c;
}

}  // namespace shapemap::cli
