// shapemap generate -o OUT [--seed S] [--shape creature|sphere|ellipsoid|torus|cube-sphere|pair]
//                   [--kind near-isometric|non-isometric] [--vertices N] [--tets] [--tet-count N]
//
// Single shapes: OUT is a file (surface extension: the surface; volume extension: the
// tetrahedralized shape) or a folder, which receives <shape>.obj (and <shape>.vtk
// with --tets).
// Pairs (--shape pair): OUT is a folder with A.obj, B.obj, truth_AB.txt, truth_BA.txt
// (map format, docs/formats.md), pair.json (seed, kind, sizes, how B was made); with
// --tets also A.vtk, B.vtk and truth_vol_AB.txt (each vertex of A's tet mesh deformed and
// located in B's tets; the closest tet when it falls outside).
// The same seed gives the same files. Everything is written under a temporary name and
// moved into place at the end.
#include "common.h"
#include "shapemap/error.h"
#include "shapemap/timing.h"
#include "shapemap/generate.h"
#include "shapemap/geometry/closest_point.h"
#include "shapemap/io.h"
#include "shapemap/maps.h"
#include "shapemap/volume/tetrahedralize.h"
#include <chrono>
#include <cstdio>
#include <filesystem>
#include <iostream>
#include <memory>

namespace shapemap::cli {

namespace {

struct GenArgs {
  std::string output;
  std::uint64_t seed = 1;
  CLI::Option* seed_opt = nullptr;
  std::string shape = "pair";
  std::string kind = "near-isometric";
  int vertices = 5000;
  bool tets = false;
  int tet_count = 20000;
};

TriMesh make_shape(const std::string& shape, std::uint64_t seed, int n) {
  if (shape == "creature") return make_creature(seed, n);
  if (shape == "sphere") return make_sphere(n);
  if (shape == "ellipsoid") return make_ellipsoid(n, Eigen::Vector3d(1.0, 0.7, 0.5));
  if (shape == "torus") return make_torus(n);
  if (shape == "cube-sphere") return make_cube_sphere(n);
  throw InputError("generate: unknown shape '" + shape + "'");
}

TetMesh tetrahedralize_generated(const TriMesh& s, int tets, std::uint64_t seed, const std::string& what) {
  TetrahedralizeOptions opt;
  opt.target_tets = tets;
  opt.seed = unsigned(seed);
  try {
    return tetrahedralize(s, opt);
  } catch (const InputError& e) {  // a generated surface is our responsibility
    throw Error(what + ": " + e.what());
  }
}

int run_single(const GenArgs& a, std::uint64_t seed, const GlobalOptions& g) {
  auto t0 = Clock::now();
  TriMesh s = make_shape(a.shape, seed, a.vertices);
  std::string msg;
  if (is_surface_path(a.output)) {
    write_surface(a.output, s);
    msg = a.output;
  } else if (is_volume_path(a.output)) {
    write_volume(a.output, tetrahedralize_generated(s, a.tet_count, seed, a.shape));
    msg = a.output;
  } else {
    OutputDir out(a.output);
    write_surface(out.path(a.shape + ".obj"), s);
    if (a.tets) write_volume(out.path(a.shape + ".vtk"), tetrahedralize_generated(s, a.tet_count, seed, a.shape));
    out.commit();
    msg = a.output + "/" + a.shape + ".obj";
  }
  if (!g.quiet) {
    char line[256];
    std::snprintf(line, sizeof line, "%s: %s, %d vertices, %d faces, %.2f s\n", msg.c_str(), a.shape.c_str(),
                  s.num_vertices(), s.num_faces(), seconds_since(t0));
    std::cout << line;
  }
  return 0;
}

int run_pair(const GenArgs& a, std::uint64_t seed, const GlobalOptions& g) {
  PairKind kind;
  if (a.kind == "near-isometric") kind = PairKind::NearIsometric;
  else if (a.kind == "non-isometric") kind = PairKind::NonIsometric;
  else throw InputError("generate: unknown kind '" + a.kind + "' (near-isometric or non-isometric)");
  if (is_surface_path(a.output) || is_volume_path(a.output))
    throw InputError(a.output + ": a pair is written to a folder, not a single file");
  OutputDir out(a.output);
  auto t0 = Clock::now();
  auto progress = make_progress(g);
  report(progress, "generate/pair", 0);
  GeneratedPair p = make_creature_pair(seed, kind, a.vertices);
  report(progress, "generate/pair", a.tets ? 0.5 : 1);
  write_surface(out.path("A.obj"), p.A);
  write_surface(out.path("B.obj"), p.B);
  write_map(out.path("truth_AB.txt"), p.truth_AB);
  write_map(out.path("truth_BA.txt"), p.truth_BA);
  nlohmann::json j;
  j["generator"] = "shapemap generate --shape pair";
  j["seed"] = seed;
  j["kind"] = a.kind;
  j["target_vertices"] = a.vertices;
  j["A"] = {{"vertices", p.A.num_vertices()}, {"faces", p.A.num_faces()}};
  j["B"] = {{"vertices", p.B.num_vertices()}, {"faces", p.B.num_faces()}};
  j["B_construction"] =
      "B = CGAL Mesh_3 surface remeshing of deform(A) (polyhedral domain); B's vertices lie on deform(A)";
  j["truth_AB"] = "each vertex of A, deformed, projected to its closest point on B (face of B + barycentric)";
  j["truth_BA"] = "each vertex of B, closest point on deform(A), as a face of A + barycentric";
  if (a.tets) {
    TetMesh TA = tetrahedralize_generated(p.A, a.tet_count, seed, "pair A");
    report(progress, "generate/pair", 0.7);
    TetMesh TB = tetrahedralize_generated(p.B, a.tet_count, seed + 1, "pair B");
    report(progress, "generate/pair", 0.9);
    Eigen::MatrixXd X(TA.num_vertices(), 3);
#pragma omp parallel for schedule(static)
    for (int i = 0; i < TA.num_vertices(); ++i)
      X.row(i) = p.deformation.apply(TA.V.row(i).transpose()).transpose();
    TetLocator loc(TB.V, TB.T);
    std::vector<ClosestPointResult> r = loc.locate(X);
    BarycentricMap vol;
    vol.elem.resize(X.rows());
    vol.bary.resize(X.rows(), 4);
    double max_outside = 0;
    for (Eigen::Index i = 0; i < X.rows(); ++i) {
      vol.elem(i) = r[i].elem;
      vol.bary.row(i) = r[i].bary.transpose();
      max_outside = std::max(max_outside, std::sqrt(r[i].sqdist));
    }
    write_volume(out.path("A.vtk"), TA);
    write_volume(out.path("B.vtk"), TB);
    write_map(out.path("truth_vol_AB.txt"), vol);
    j["A"]["tets"] = TA.num_tets();
    j["A"]["tet_vertices"] = TA.num_vertices();
    j["B"]["tets"] = TB.num_tets();
    j["B"]["tet_vertices"] = TB.num_vertices();
    j["truth_vol_AB"] =
        "each vertex of A.vtk, deformed, located in B.vtk's tets (closest tet if outside)";
    j["truth_vol_AB_max_outside_distance"] = max_outside;
  }
  write_json(out.path("pair.json"), j);
  out.commit();
  report(progress, "generate/pair", 1);
  if (!g.quiet) {
    char line[256];
    std::snprintf(line, sizeof line, "%s: A %d vertices, B %d vertices (%s, seed %llu), %.2f s\n",
                  a.output.c_str(), p.A.num_vertices(), p.B.num_vertices(), a.kind.c_str(),
                  (unsigned long long)seed, seconds_since(t0));
    std::cout << line;
  }
  return 0;
}

int run_generate(const GenArgs& a, const GlobalOptions& g) {
  std::uint64_t seed = a.seed_opt->count() ? a.seed : g.seed;
  return a.shape == "pair" ? run_pair(a, seed, g) : run_single(a, seed, g);
}

CLI::App* add_generate_command(CLI::App& parent, GenArgs& a) {
  CLI::App* app = parent.add_subcommand("generate", "Generate shapes and pairs with ground truth");
  app->add_option("-o,--output", a.output, "Output file (single shape) or folder")->required();
  a.seed_opt = app->add_option("--seed", a.seed, "Random seed (default: the global --seed)");
  app->add_option("--shape", a.shape, "creature|sphere|ellipsoid|torus|cube-sphere|pair (default pair)")
      ->check(CLI::IsMember({"creature", "sphere", "ellipsoid", "torus", "cube-sphere", "pair"}));
  app->add_option("--kind", a.kind, "Pair kind: near-isometric|non-isometric")
      ->check(CLI::IsMember({"near-isometric", "non-isometric"}));
  app->add_option("--vertices", a.vertices, "Approximate vertex count (default 5000)")
      ->check(CLI::Range(500, 200000));
  app->add_flag("--tets", a.tets, "Also tetrahedralize (pairs: A.vtk, B.vtk, truth_vol_AB.txt)");
  app->add_option("--tet-count", a.tet_count, "Approximate tets per volume with --tets (default 20000)")
      ->check(CLI::Range(100, 5000000));
  return app;
}

}  // namespace

Command register_generate(CLI::App& app, GlobalOptions& g) {
  return args_command<GenArgs>(app, g, add_generate_command, run_generate);
}

}  // namespace shapemap::cli
