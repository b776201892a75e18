// shapemap tetrahedralize: Tetrahedralize a closed surface (CGAL Mesh_3)
#include "common.h"

namespace shapemap::cli {

Command register_tetrahedralize(CLI::App& app, GlobalOptions& g) {
  Command c;
  c.app = app.add_subcommand("tetrahedralize", "Tetrahedralize a closed surface (CGAL Mesh_3)");
  c.run = [] { return not_built("'tetrahedralize'"); };
  return c;
}

}  // namespace shapemap::cli
