// shapemap ball A -o OUT: ball-shaped volume-preserving parameterization of a tetrahedral
// mesh (isovolumetric-ball-parameterization.txt, Algorithm 1). A is a tet mesh, or a
// closed genus-0 surface that is tetrahedralized first. Writes OUT/ball.vtk (the input
// connectivity with the ball coordinates, per-tet D_V) and OUT/report.json.
#include "ball_common.h"
#include "figures.h"

namespace shapemap::cli {

Command register_ball(CLI::App& app, GlobalOptions& g) {
  Command c;
  c.app = app.add_subcommand("ball", "Ball-shaped volume-preserving parameterization of a tetrahedral mesh");
  struct Args {
    std::string A, out;
    int tets = 0;
    bool split_chords = false;
    BallParamOptions opt;
  };
  auto a = std::make_shared<Args>();
  c.app->add_option("A", a->A, "Tet mesh (.vtk .mesh .msh .node .ele) or closed surface (.obj .off .ply .stl)")
      ->required();
  c.app->add_option("-o,--output", a->out, "Output folder")->required();
  c.app->add_option("--tets", a->tets, "Approximate tet count when A is a surface (0: default)")
      ->check(in_range(0, kMaxTets));
  c.app->add_flag("--split-chords", a->split_chords,
                   "Split interior edges that join two boundary vertices (always done for surface inputs); "
                   "ball.vtk is then on the refined mesh, written as OUT/input.vtk");
  add_ball_options(c.app, a->opt);
  c.run = [a, &g] {
    StageTimer timer;
    auto progress = make_progress(g);
    OutputDir out(a->out);
    timer.start("read");
    const BallInput in = load_ball_input(a->A, a->tets, a->split_chords, progress, g);
    const TetMesh& mesh = in.mesh;
    timer.start("ball");
    const BallParamResult r = ball_parameterization(mesh, a->opt, progress, a->A);
    timer.start("metrics");
    const BallMetrics m = ball_metrics(mesh, r.f);
    const BallMetrics mv = ball_metrics(mesh, r.f_vsem);
    timer.start("write");
    TetMesh ball;
    ball.V = r.f;
    ball.T = mesh.T;
    const Eigen::VectorXd D_V = ball_volume_distortion(mesh.V, mesh.T, r.f);
    write_vtk(out.path("ball.vtk"), ball, {}, {{"D_V", D_V}});
    if (in.changed()) write_volume(out.path("input.vtk"), mesh);
    timer.stop();
    nlohmann::json j = report_header(g, "ball");
    j["inputs"] = {{"A", a->A}, {"A_vertices", mesh.num_vertices()}, {"A_tets", mesh.num_tets()}};
    j["inputs"]["repairs"] = in.repairs;
    j["tetrahedralized"] = in.tetrahedralized;
    j["boundary_chords"] = {{"split", in.chords_split}, {"left", in.chords_left}};
    j["parameters"] = ball_parameters_json(a->opt);
    j["parameters"]["split_chords"] = a->split_chords || in.tetrahedralized;  // always for surfaces
    j["metrics"] = ball_metrics_json(m);
    j["metrics_after_vsem"] = ball_metrics_json(mv);
    j["optimization"] = ball_result_json(r);
    timer.start("pictures");
    const auto figures = ball_figures(mesh, r.f);
    const ViewerData viewer = ball_viewer(mesh, r.f, D_V);
    timer.stop();
    j["timings"] = timer.json();
    write_reports(out, j, "shapemap ball", figures, &viewer, &g);
    out.commit();
    info(g, "ball: " + std::to_string(mesh.num_vertices()) + " vertices, " + std::to_string(mesh.num_tets()) +
                " tets; E_I " + std::to_string(r.energy_vsem) + " -> " + std::to_string(r.energy_final) +
                ", mean D_V " + std::to_string(m.dv_mean) + ", folded " + std::to_string(m.folded_tets) +
                " -> " + out.final_path() + "/ball.vtk");
    const std::string warning = ball_quality_warning("ball", m, r);
    if (!warning.empty()) info(g, warning);
    if (const std::string note = ball_overlap_note("ball", m, warning); !note.empty()) info(g, note);
    return 0;
  };
  return c;
}

}  // namespace shapemap::cli
