// shapemap evaluate: metrics of a map, against ground truth when given. One nested
// subcommand per kind of map; each lives in its own cli/eval_*.cpp.
#include "common.h"

namespace shapemap::cli {

Command register_evaluate_surface(CLI::App& evaluate, GlobalOptions& g);  // eval_surface.cpp
Command register_evaluate_volume(CLI::App& evaluate, GlobalOptions& g);   // eval_volume.cpp
Command register_evaluate_ball(CLI::App& evaluate, GlobalOptions& g);     // eval_ball.cpp

Command register_evaluate(CLI::App& app, GlobalOptions& g) {
  Command c;
  c.app = app.add_subcommand("evaluate", "Metrics of a map, against ground truth when given");
  c.app->require_subcommand(1);
  auto subs = std::make_shared<std::vector<Command>>();
  subs->push_back(register_evaluate_surface(*c.app, g));
  subs->push_back(register_evaluate_volume(*c.app, g));
  subs->push_back(register_evaluate_ball(*c.app, g));
  c.run = [subs] {
    for (auto& s : *subs)
      if (s.app->parsed()) return s.run();
    return 2;
  };
  return c;
}

}  // namespace shapemap::cli
