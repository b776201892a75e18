// shapemap volume-map: Symmetric volume map between two tetrahedral meshes
#include "common.h"

namespace shapemap::cli {

Command register_volume_map(CLI::App& app, GlobalOptions& g) {
  Command c;
  c.app = app.add_subcommand("volume-map", "Symmetric volume map between two tetrahedral meshes");
  c.run = [] { return not_built("'volume-map'"); };
  return c;
}

}  // namespace shapemap::cli
