// shapemap evaluate ball: metrics of a ball map.
#include "common.h"

namespace shapemap::cli {

Command register_evaluate_ball(CLI::App& evaluate, GlobalOptions& g) {
  Command c;
  c.app = evaluate.add_subcommand("ball", "Metrics of a ball map");
  c.run = [] { return not_built("'evaluate ball'"); };
  return c;
}

}  // namespace shapemap::cli
