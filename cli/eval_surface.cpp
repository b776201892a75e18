// shapemap evaluate surface: metrics of a surface map.
#include "common.h"

namespace shapemap::cli {

Command register_evaluate_surface(CLI::App& evaluate, GlobalOptions& g) {
  Command c;
  c.app = evaluate.add_subcommand("surface", "Metrics of a surface map");
  c.run = [] { return not_built("'evaluate surface'"); };
  return c;
}

}  // namespace shapemap::cli
