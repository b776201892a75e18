// shapemap register A B -o OUT [--via ball] [--frames K]: volume-preserving registration of
// two tet meshes through their ball parameterizations (isovolumetric-ball-parameterization
// .txt, Sec. 7). Writes map_AB.txt (vertex of A -> tet of B + barycentric), A_on_B.vtk (A's
// connectivity at phi(v)), the reverse map_BA.txt / B_on_A.vtk (psi = f_A^{-1} h^{-1} f_B),
// report.json (ball metrics of both, rotations, d(phi), volume-map metrics per direction)
// and, with --frames K, frames/frame_000.vtk ... frame_<K-1>.vtk of the linear homotopy (Eq. 46).
#include "shapemap/volume/volume_map_pipeline.h"
#include "ball_common.h"
#include "figures.h"
#include "shapemap/eval/volume_metrics.h"
#include "shapemap/maps.h"
#include "shapemap/volume/register.h"
#include <algorithm>
#include <cstdio>
#include <tuple>

namespace shapemap::cli {


namespace {
nlohmann::json location_json(const BallLocation& l) {
  return {{"outside_ball_mesh", l.outside},
          {"interior_outside_ball_mesh", l.outside_interior},
          {"max_snap_distance", l.max_snap},
          {"max_snap_distance_interior", l.max_snap_interior}};
}

nlohmann::json matrix_json(const Eigen::Matrix3d& M) {
  nlohmann::json j = nlohmann::json::array();
  for (int r = 0; r < 3; ++r) j.push_back({M(r, 0), M(r, 1), M(r, 2)});
  return j;
}
}  // namespace

namespace {

struct RegisterArgs {
  std::string A, B, out, via = "ball";
  int tets = 0, frames = 0;
  bool split_chords = false, no_center = false;
  RegisterOptions opt;
};

nlohmann::json register_report(const RegisterArgs& a, const GlobalOptions& g, const BallInput& inA,
                               const BallInput& inB, const RegisterResult& r, const BallMetrics& mA,
                               const BallMetrics& mB, const VolumeMapMetrics& vm, const VolumeMapMetrics& vm21) {
  const TetMesh &A = inA.mesh, &B = inB.mesh;
  nlohmann::json j = report_header(g, "register");
  j["inputs"] = {{"A", a.A}, {"A_vertices", A.num_vertices()}, {"A_tets", A.num_tets()},
                 {"B", a.B}, {"B_vertices", B.num_vertices()}, {"B_tets", B.num_tets()}};
  j["inputs"]["repairs"] = inA.repairs;
  for (const std::string& n : inB.repairs) j["inputs"]["repairs"].push_back(n);
  j["parameters"] = ball_parameters_json(a.opt.ball);
  j["parameters"]["via"] = a.via;
  j["parameters"]["frames"] = a.frames;
  j["parameters"]["split_chords"] = a.split_chords;
  j["parameters"]["center"] = a.opt.center;
  j["tetrahedralized"] = {{"A", inA.tetrahedralized}, {"B", inB.tetrahedralized}};
  j["boundary_chords"] = {{"A", {{"split", inA.chords_split}, {"left", inA.chords_left}}},
                          {"B", {{"split", inB.chords_split}, {"left", inB.chords_left}}}};
  j["ball_A"] = {{"metrics", ball_metrics_json(mA)}, {"optimization", ball_result_json(r.ball_A)}};
  j["ball_B"] = {{"metrics", ball_metrics_json(mB)}, {"optimization", ball_result_json(r.ball_B)}};
  j["g_A"] = matrix_json(r.g_A);
  j["g_B"] = matrix_json(r.g_B);
  j["h"] = matrix_json(r.h);
  j["d_phi"] = r.d_phi;
  j["d_phi_relative_to_bbox_diagonal"] = r.d_phi_relative;
  j["located_AB"] = location_json(r.located_AB);
  j["located_BA"] = location_json(r.located_BA);
  j["frames"] = a.frames;
  j["metrics"] = volume_metrics_json(vm);
  j["metrics_BA"] = volume_metrics_json(vm21);
  return j;
}

void register_notes(const GlobalOptions& g, const TetMesh& A, const TetMesh& B, const RegisterResult& r,
                    const BallMetrics& mA, const BallMetrics& mB, const VolumeMapMetrics& vm,
                    const VolumeMapMetrics& vm21) {
  if (vm.n_inv > 0 || vm21.n_inv > 0) {
    char line[320];
    std::snprintf(line, sizeof line,
                  "register: note: the composed maps invert %d of A's tets (%.1f%%) and %d of B's (%.1f%%): "
                  "the two ball maps differ by more than a rotation; volume-map A B --init ball repairs them",
                  vm.n_inv, 100.0 * vm.n_inv / std::max(1, A.num_tets()), vm21.n_inv,
                  100.0 * vm21.n_inv / std::max(1, B.num_tets()));
    info(g, line);
  }
  // phi is only as good as the two ball maps it composes.
  for (const auto& [w, mm, rr] : {std::tuple{std::string("register: A"), &mA, &r.ball_A},
                                  std::tuple{std::string("register: B"), &mB, &r.ball_B}}) {
    const std::string s = ball_quality_warning(w, *mm, *rr);
    if (!s.empty()) info(g, s);
    // A point of the other mesh that lands where this ball is covered twice has two
    // candidate images; the locator takes one of them.
    if (const std::string note = ball_overlap_note(w, *mm, s); !note.empty()) info(g, note);
  }
}

int run_register(RegisterArgs& a, const GlobalOptions& g) {
  if (a.frames == 1) throw InputError("--frames: need 0 or at least 2 frames");
  StageTimer timer;
  auto progress = make_progress(g);
  OutputDir out(a.out);
  timer.start("read");
  const BallInput inA = load_ball_input(a.A, a.tets, a.split_chords, progress, g);
  const BallInput inB = load_ball_input(a.B, a.tets, a.split_chords, progress, g);
  const TetMesh &A = inA.mesh, &B = inB.mesh;
  timer.start("register");
  a.opt.center = !a.no_center;
  const RegisterResult r = register_through_ball(A, B, a.opt, progress, a.A, a.B);
  timer.start("metrics");
  const BallMetrics mA = ball_metrics(A, r.ball_A.f), mB = ball_metrics(B, r.ball_B.f);
  const VolumeMapMetrics vm = volume_map_metrics(A, B, r.A_on_B, &r.map_AB, &r.B_on_A);
  const VolumeMapMetrics vm21 = volume_map_metrics(B, A, r.B_on_A, &r.map_BA, &r.A_on_B);
  timer.start("write");
  write_map(out.path("map_AB.txt"), r.map_AB);
  TetMesh AonB;
  AonB.V = r.A_on_B;
  AonB.T = A.T;
  write_volume(out.path("A_on_B.vtk"), AonB);
  write_map(out.path("map_BA.txt"), r.map_BA);
  write_volume(out.path("B_on_A.vtk"), TetMesh{r.B_on_A, B.T});
  if (inA.changed()) write_volume(out.path("A.vtk"), A);
  if (inB.changed()) write_volume(out.path("B.vtk"), B);
  for (int k = 0; k < a.frames; ++k) {  // one frame in memory at a time
    char name[64];
    std::snprintf(name, sizeof(name), "frames/frame_%03d.vtk", k);
    write_volume(out.path(name), TetMesh{linear_homotopy_frame(A.V, r.A_on_B, k, a.frames), A.T});
  }
  timer.stop();
  nlohmann::json j = register_report(a, g, inA, inB, r, mA, mB, vm, vm21);
  timer.start("pictures");
  auto figures = volume_map_figures(A, r.A_on_B, nullptr, nullptr);
  for (auto& f : ball_figures(B, r.ball_B.f)) figures.push_back({"ball_B.png", "Ball of B: " + f.caption, f.image});
  for (auto& f : ball_figures(A, r.ball_A.f)) figures.push_back({"ball_A.png", "Ball of A: " + f.caption, f.image});
  const ViewerData viewer = volume_map_viewer(A, r.A_on_B, &B, &r.B_on_A);
  timer.stop();
  j["timings"] = timer.json();
  write_reports(out, j, "shapemap register --via ball", figures, &viewer, &g);
  out.commit();
  info(g, "register: d(phi) = " + std::to_string(r.d_phi) + " (" + std::to_string(100 * r.d_phi_relative) +
              "% of A's bbox diagonal) -> " + out.final_path() + "/map_AB.txt");
  register_notes(g, A, B, r, mA, mB, vm, vm21);
  return 0;
}

CLI::App* add_register_command(CLI::App& parent, RegisterArgs& a) {
  CLI::App* app = parent.add_subcommand("register", "Registration of two volumes through their ball parameterizations");
  add_pair_options(app, a.A, a.B, a.out, "Source: tet mesh or closed surface", "Target: tet mesh or closed surface");
  app->add_option("--via", a.via, "Registration method (ball: Sec. 7 of the isovolumetric paper)")
      ->check(CLI::IsMember({"ball"}));
  app->add_option("--frames", a.frames, "Write K >= 2 linear-homotopy frames H(v, t) (Eq. 46)")
      ->check(in_range(0, 1000));
  app->add_option("--tets", a.tets, "Approximate tet count for surface inputs (0: default)")
      ->check(in_range(0, kMaxTets));
  app->add_flag("--split-chords", a.split_chords,
                "Split interior edges that join two boundary vertices (always done for surface inputs); "
                "the outputs are then on the refined meshes, written as OUT/A.vtk, OUT/B.vtk");
  app->add_flag("--no-center", a.no_center,
                "Procrustes rotations g_s against the raw coordinates v (Sec. 7) instead of the "
                "volume-centred ones");
  add_ball_options(app, a.opt.ball);
  return app;
}

}  // namespace

Command register_register(CLI::App& app, GlobalOptions& g) {
  return args_command<RegisterArgs>(app, g, add_register_command, run_register);
}

}  // namespace shapemap::cli
