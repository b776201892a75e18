// shapemap surface-map: Map between two closed genus-0 surfaces (BIM, elastic refinement)
#include "common.h"

namespace shapemap::cli {

Command register_surface_map(CLI::App& app, GlobalOptions& g) {
  Command c;
  c.app = app.add_subcommand("surface-map", "Map between two closed genus-0 surfaces (BIM, elastic refinement)");
  c.run = [] { return not_built("'surface-map'"); };
  return c;
}

}  // namespace shapemap::cli
