// shapemap tetrahedralize IN -o OUT [--edge-length L | --tets N] [--no-optimize]
//                                   [--no-features] [--radius-edge R] [--split-chords]
// Tetrahedralizes a closed surface (.obj .off .ply .stl) with CGAL Mesh_3 and writes
// the tet mesh in the format named by OUT's extension (.vtk .mesh .msh .node/.ele),
// atomically. Prints tets / vertices / time on stdout unless --quiet. Exit 2 on bad
// input (one line naming the file and the problem).
#include "common.h"
#include "shapemap/boundary_chords.h"
#include "shapemap/timing.h"
#include "shapemap/error.h"
#include "shapemap/io.h"
#include "shapemap/volume/tetrahedralize.h"
#include <chrono>
#include <cstdio>
#include <iostream>
#include <memory>

namespace shapemap::cli {

namespace {

struct TetArgs {
  std::string input, output;
  double edge_length = 0;
  int tets = 0;
  bool no_optimize = false, no_odt = false, no_features = false, split_chords = false;
  double radius_edge = 3.0;
};

int run_tetrahedralize(const TetArgs& a, const GlobalOptions& g) {
  if (!is_volume_path(a.output))
    throw InputError(a.output + ": output must be a volume file (.vtk .mesh .msh .node .ele)");
  if (a.edge_length > 0 && a.tets > 0) throw InputError("tetrahedralize: give --edge-length or --tets, not both");
  // The safe repairs (notes on stderr; --strict refuses); tetrahedralize() checks the rest.
  const TriMesh surface = repair_input_surface(read_surface(a.input), a.input, g).mesh;
  TetrahedralizeOptions opt;
  opt.edge_length = a.edge_length;
  opt.target_tets = a.tets;
  opt.optimize = !a.no_optimize;
  opt.odt = !a.no_odt;
  opt.faithful_boundary = !a.no_features;
  opt.radius_edge_ratio = a.radius_edge;
  opt.seed = unsigned(g.seed);
  auto t0 = Clock::now();
  TetMesh mesh = tetrahedralize_input(surface, opt, make_progress(g), a.input, g.quiet);
  if (a.split_chords) split_boundary_chords(mesh);
  double secs = seconds_since(t0);
  write_volume(a.output, mesh);
  if (!g.quiet) {
    char line[256];
    std::snprintf(line, sizeof line, "%s: %d tets, %d vertices, %.2f s\n", a.output.c_str(),
                  mesh.num_tets(), mesh.num_vertices(), secs);
    std::cout << line;
  }
  return 0;
}

CLI::App* add_tetrahedralize_command(CLI::App& parent, TetArgs& a) {
  CLI::App* app = parent.add_subcommand("tetrahedralize", "Tetrahedralize a closed surface (CGAL Mesh_3)");
  app->add_option("IN", a.input, "Closed surface (.obj .off .ply .stl)")->required();
  app->add_option("-o,--output", a.output, "Tet mesh to write (.vtk .mesh .msh .node/.ele)")->required();
  auto* el = app->add_option("--edge-length", a.edge_length, "Target tet edge length")->check(positive());
  auto* nt = app->add_option("--tets", a.tets, "Approximate number of tets (default 30000)")
                 ->check(in_range(1, kMaxTets));
  el->excludes(nt);
  app->add_flag("--no-optimize", a.no_optimize, "Skip ODT smoothing, sliver perturbation and exudation");
  app->add_flag("--no-odt", a.no_odt, "Skip ODT smoothing (keep perturbation and exudation)");
  app->add_flag("--no-features", a.no_features, "Do not protect sharp creases of the input");
  app->add_flag("--split-chords", a.split_chords,
                "Split interior edges that join two boundary vertices (for ball maps; docs/methods.md)");
  app->add_option("--radius-edge", a.radius_edge, "Mesh_3 cell radius-edge ratio bound (default 3)")
      ->check(CLI::Range(2.0, 10.0));
  return app;
}

}  // namespace

Command register_tetrahedralize(CLI::App& app, GlobalOptions& g) {
  return args_command<TetArgs>(app, g, add_tetrahedralize_command, run_tetrahedralize);
}

}  // namespace shapemap::cli
