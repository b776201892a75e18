// Registration through the ball (isovolumetric-ball-parameterization.txt, Sec. 7).
#include "shapemap/volume/register.h"
#include "shapemap/timing.h"
#include "shapemap/error.h"
#include "shapemap/geometry/procrustes.h"
#include "shapemap/volume/symmetric_map.h"
#include <Eigen/LU>
#include <algorithm>
#include <chrono>
#include <cmath>

namespace shapemap {

namespace {
// Locates the points P (source vertices carried into the target's ball) in the target's
// ball mesh (f_target, target.T): the map (clamped barycentrics) and its positions in the
// target; `source_boundary` (indices into P) tells boundary points from interior ones.
BallLocation compose_through_ball(const Eigen::MatrixXd& P, const Eigen::VectorXi& source_boundary,
                                  const Eigen::MatrixXd& f_target, const TetMesh& target,
                                  BarycentricMap& map, Eigen::MatrixXd& positions) {
  TetMesh ball;
  ball.V = f_target;
  ball.T = target.T;
  BallLocation loc;
  map = locate_in_tets(ball, P, {}, &loc.outside);
  positions = map_positions(map, target.V, target.T);
  // Snap distances: the located point in the ball against the query.
  const Eigen::MatrixXd located = map_positions(map, f_target, target.T);
  std::vector<char> on_boundary(P.rows(), 0);
  for (Eigen::Index k = 0; k < source_boundary.size(); ++k) on_boundary[source_boundary(k)] = 1;
  for (Eigen::Index i = 0; i < P.rows(); ++i) {
    const double d = (located.row(i) - P.row(i)).norm();
    loc.max_snap = std::max(loc.max_snap, d);
    if (on_boundary[i]) continue;
    loc.max_snap_interior = std::max(loc.max_snap_interior, d);
    if (d > 1e-10) ++loc.outside_interior;
  }
  return loc;
}
}  // namespace

Eigen::VectorXd vertex_volumes(const Eigen::MatrixXd& V, const Eigen::MatrixXi& T) {
  const Eigen::VectorXd vol = tet_volumes(V, T);
  Eigen::VectorXd w = Eigen::VectorXd::Zero(V.rows());
  for (Eigen::Index t = 0; t < T.rows(); ++t)
    for (int c = 0; c < 4; ++c) w(T(t, c)) += 0.25 * std::abs(vol(t));
  return w;
}

Eigen::Matrix3d ball_procrustes_rotation(const Eigen::MatrixXd& f, const Eigen::MatrixXd& V,
                                         const Eigen::VectorXd& w) {
  if (f.rows() != V.rows() || w.size() != V.rows() || f.cols() != 3 || V.cols() != 3)
    throw InputError("ball_procrustes_rotation: f, V must be n×3 and w of size n");
  // min sum w ||g f - v||^2: H^T = sum w v f^T is procrustes_rotation's C.
  Eigen::Matrix3d H = Eigen::Matrix3d::Zero();
  for (Eigen::Index i = 0; i < f.rows(); ++i)
    H += w(i) * f.row(i).transpose() * V.row(i);
  return procrustes_rotation(H.transpose());
}

Eigen::MatrixXd linear_homotopy_frame(const Eigen::MatrixXd& V, const Eigen::MatrixXd& phi, int k,
                                      int K) {
  if (K < 2) throw InputError("linear homotopy: need at least 2 frames");
  if (k < 0 || k >= K) throw InputError("linear homotopy: frame index out of range");
  if (V.rows() != phi.rows() || V.cols() != phi.cols())
    throw InputError("linear homotopy: V and phi must have the same size");
  const double t = double(k) / double(K - 1);
  return (1 - t) * V + t * phi;  // Eq. 46
}

RegisterResult register_through_ball(const TetMesh& A, const TetMesh& B, const RegisterOptions& opt,
                                     const ProgressCallback& progress, const std::string& nameA,
                                     const std::string& nameB) {
  const auto t0 = Clock::now();
  RegisterResult r;
  auto sub = [&](const std::string& which) -> ProgressCallback {
    if (!progress) return {};
    return [progress, which](const std::string& stage, double f) { progress(which + "/" + stage, f); };
  };
  r.ball_A = ball_parameterization(A, opt.ball, sub("A"), nameA);
  r.ball_B = ball_parameterization(B, opt.ball, sub("B"), nameB);

  // Optimal rotations g_s (volume-weighted Procrustes).
  auto rotation = [&](const TetMesh& M, const Eigen::MatrixXd& f) {
    const Eigen::VectorXd w = vertex_volumes(M.V, M.T);
    Eigen::MatrixXd V = M.V;
    if (opt.center) {
      const Eigen::RowVector3d c = (w.transpose() * M.V) / w.sum();
      V.rowwise() -= c;
    }
    return ball_procrustes_rotation(f, V, w);
  };
  r.g_A = rotation(A, r.ball_A.f);
  r.g_B = rotation(B, r.ball_B.f);
  r.h = r.g_B.transpose() * r.g_A;  // h = g_1^{-1} g_0

  // phi = f_1^{-1} o h o f_0: locate h f_0(v) in B's ball mesh; psi likewise with h^{-1}.
  const auto tl = Clock::now();
  r.located_AB = compose_through_ball(r.ball_A.f * r.h.transpose(), r.ball_A.boundary, r.ball_B.f, B,
                                      r.map_AB, r.A_on_B);
  r.located_BA = compose_through_ball(r.ball_B.f * r.h, r.ball_B.boundary, r.ball_A.f, A, r.map_BA,
                                      r.B_on_A);
  const int nA = A.num_vertices();
  r.seconds_locate = seconds_since(tl);

  // d(phi) (Sec. 7).
  const Eigen::VectorXd w = vertex_volumes(A.V, A.T);
  double s = 0;
  for (int i = 0; i < nA; ++i) s += (A.V.row(i) - r.A_on_B.row(i)).norm() * w(i);
  r.d_phi = s / w.sum();
  const double diag = bbox_diagonal(A.V);
  r.d_phi_relative = diag > 0 ? r.d_phi / diag : 0;
  r.seconds_total = seconds_since(t0);
  return r;
}

}  // namespace shapemap
