// The command-line application: global options, subcommand dispatch, exit codes.
#include "common.h"
#include "shapemap/error.h"
#include <iostream>

namespace shapemap::cli {

namespace {
// Errors are one line (the contract scripts rely on): line breaks inside a message, e.g. from
// a file name that contains one, are written as "\n".
std::string one_line(std::string msg) {
  std::string out;
  for (char ch : msg) {
    if (ch == '\n') out += "\\n";
    else if (ch == '\r') out += "\\r";
    else out += ch;
  }
  return out;
}
}  // namespace

int run(const std::vector<std::string>& all_args) {
  const std::vector<std::string> args = split_batch_arguments(all_args);
  CLI::App app{"shapemap: dense correspondences between 3D shapes (surfaces and volumes)"};
  app.require_subcommand(1);
  GlobalOptions g;
  app.add_flag("-q,--quiet", g.quiet, "No progress or messages on stderr");
  app.add_option("--threads", g.threads, "Worker threads (0 = all cores)")->check(in_range(0, 1024));
  app.add_flag("--strict", g.strict,
               "Refuse input surfaces with defects (non-manifold, duplicates, degenerate faces, "
               "floating pieces, small holes) instead of repairing them");
  app.add_option("--seed", g.seed, "Random seed: the same input and seed give the same output");
  app.set_version_flag("--version", std::string("shapemap ") + SHAPEMAP_VERSION);

  std::vector<Command> commands = {
      register_surface_map(app, g), register_volume_map(app, g), register_ball(app, g),
      register_register(app, g),    register_tetrahedralize(app, g), register_generate(app, g),
      register_evaluate(app, g),    register_render(app, g),     register_demo(app, g),
      register_check(app, g),       register_batch(app, g)};
  for (auto& c : commands) c.app->fallthrough();

  std::vector<std::string> rev(args.rbegin(), args.rend() - (args.empty() ? 0 : 1));
  if (!args.empty()) app.name(args[0]);
  try {
    app.parse(rev);
  } catch (const CLI::ParseError& e) {
    if (e.get_exit_code() == 0) return app.exit(e);  // --help, --version
    // One line, like every other input error.
    std::string msg = e.what();
    for (char& ch : msg)
      if (ch == '\n') ch = ' ';
    std::cerr << "shapemap: error: " << one_line(msg) << " (see --help)\n";
    return 2;
  }
  try {
    apply_threads(g);
    for (auto& c : commands)
      if (c.app->parsed()) return c.run();
    return 2;
  } catch (const InputError& e) {
    std::cerr << "shapemap: error: " << one_line(e.what()) << "\n";
    return 2;
  } catch (const std::bad_alloc&) {
    std::cerr << "shapemap: internal error: out of memory\n";
    return 1;
  } catch (const std::exception& e) {
    std::cerr << "shapemap: internal error: " << one_line(e.what()) << "\n";
    return 1;
  }
}

}  // namespace shapemap::cli
