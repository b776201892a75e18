// shapemap evaluate volume: metrics of a volume map.
#include "common.h"

namespace shapemap::cli {

Command register_evaluate_volume(CLI::App& evaluate, GlobalOptions& g) {
  Command c;
  c.app = evaluate.add_subcommand("volume", "Metrics of a volume map");
  c.run = [] { return not_built("'evaluate volume'"); };
  return c;
}

}  // namespace shapemap::cli
