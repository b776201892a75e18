// shapemap generate: Generate shapes and pairs with ground truth
#include "common.h"

namespace shapemap::cli {

Command register_generate(CLI::App& app, GlobalOptions& g) {
  Command c;
  c.app = app.add_subcommand("generate", "Generate shapes and pairs with ground truth");
  c.run = [] { return not_built("'generate'"); };
  return c;
}

}  // namespace shapemap::cli
