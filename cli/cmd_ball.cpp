// shapemap ball: Ball-shaped volume-preserving parameterization of a tetrahedral mesh
#include "common.h"

namespace shapemap::cli {

Command register_ball(CLI::App& app, GlobalOptions& g) {
  Command c;
  c.app = app.add_subcommand("ball", "Ball-shaped volume-preserving parameterization of a tetrahedral mesh");
  c.run = [] { return not_built("'ball'"); };
  return c;
}

}  // namespace shapemap::cli
