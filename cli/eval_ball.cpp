// shapemap evaluate ball A BALL [-o report.json]: metrics of a ball map
// (isovolumetric-ball-parameterization.txt Sec. 6): D_V (Eq. 45) mean/SD/percentiles,
// E_I (Eq. 2), folded tets, max | ||f(v)|| - 1 | over boundary vertices. A is the tet mesh,
// BALL a tet mesh with the same connectivity and the ball coordinates (OUT/ball.vtk of
// `shapemap ball`).
#include "ball_common.h"
#include "eval_output.h"
#include <iostream>

namespace shapemap::cli {

Command register_evaluate_ball(CLI::App& evaluate, GlobalOptions& g) {
  Command c;
  c.app = evaluate.add_subcommand("ball", "Metrics of a ball map");
  struct Args {
    std::string A, ball, out;
  };
  auto a = std::make_shared<Args>();
  c.app->add_option("A", a->A, "The tet mesh")->required();
  c.app->add_option("BALL", a->ball, "The ball map: same connectivity, ball coordinates (ball.vtk)")->required();
  c.app->add_option("-o,--output", a->out, "Write the metrics JSON here (default: stdout)");
  c.run = [a, &g]() -> int {
    if (!is_volume_path(a->A)) throw InputError(a->A + ": not a tet mesh (.mesh .vtk .msh .node .ele)");
    if (!is_volume_path(a->ball)) throw InputError(a->ball + ": not a tet mesh (.mesh .vtk .msh .node .ele)");
    const TetMesh A = read_volume(a->A);
    // D_V (Eq. 45) divides by |tau|: degenerate or inverted input tets are an input error.
    require_valid_volume(A, a->A, 0.0);
    const TetMesh F = read_volume(a->ball);
    if (F.num_vertices() != A.num_vertices() || F.num_tets() != A.num_tets())
      throw InputError(a->ball + ": " + std::to_string(F.num_vertices()) + " vertices / " +
                       std::to_string(F.num_tets()) + " tets, but " + a->A + " has " +
                       std::to_string(A.num_vertices()) + " / " + std::to_string(A.num_tets()));
    // read_volume may reorient an all-negative mesh; compare connectivity up to that.
    if ((F.T - A.T).cwiseAbs().maxCoeff() != 0) {
      Eigen::MatrixXi S = F.T;
      S.col(2).swap(S.col(3));
      Eigen::MatrixXi S2 = F.T;
      S2.col(0).swap(S2.col(1));
      if ((S - A.T).cwiseAbs().maxCoeff() != 0 && (S2 - A.T).cwiseAbs().maxCoeff() != 0)
        throw InputError(a->ball + ": connectivity differs from " + a->A);
    }
    // D_V normalizes by the image volume V(f): a map with none (all vertices at one point,
    // a flat image) has no metrics.
    if (!(tet_volumes(F.V, F.T).sum() != 0))
      throw InputError(a->ball + ": the map has zero total volume (a collapsed or flat image)");
    const BallMetrics m = ball_metrics(A, F.V);
    nlohmann::json j = report_header(g, "evaluate ball");
    j["inputs"] = {{"A", a->A}, {"ball", a->ball}};
    j["metrics"] = ball_metrics_json(m);
    emit_evaluation(a->out, j);
    return 0;
  };
  return c;
}

}  // namespace shapemap::cli
