// Boundary vertices back on the target's boundary (return_to_boundary.h).
#include "shapemap/volume/return_to_boundary.h"
#include <algorithm>
#include <cmath>

namespace shapemap {

void boundary_point_and_apex(const TetMesh& M, const TetBoundary& b, const ClosestPointResult& h, Eigen::RowVector3d& p,
                             Eigen::RowVector3d& apex) {
  int face[3];
  p.setZero();
  apex = M.V.row(M.T(b.face_tet(h.elem), 0));
  for (int c = 0; c < 3; ++c) {
    face[c] = b.to_volume(b.surface.F(h.elem, c));
    p += h.bary(c) * M.V.row(face[c]);
  }
  for (int q = 0; q < 4; ++q) {
    const int w = M.T(b.face_tet(h.elem), q);
    if (w != face[0] && w != face[1] && w != face[2]) apex = M.V.row(w);
  }
}

int return_to_boundary(Eigen::MatrixXd& X, const std::vector<int>& rows, const TetMesh& M, const TetBoundary& b,
                       const ClosestPoint3& surface, const std::vector<double>& insets, double tol,
                       const std::function<bool(int, const Eigen::RowVector3d&)>& try_move,
                       std::vector<int>& on_surface) {
  Eigen::MatrixXd Q(rows.size(), 3);
  for (size_t r = 0; r < rows.size(); ++r) Q.row(Eigen::Index(r)) = X.row(rows[r]);
  const std::vector<ClosestPointResult> hit = surface.query(Q);
  on_surface.clear();
  int moved = 0;
  for (size_t r = 0; r < rows.size(); ++r) {
    const int v = rows[r];
    const double depth = std::sqrt(std::max(0.0, hit[r].sqdist));
    if (depth <= tol) {
      on_surface.push_back(v);
      continue;
    }
    Eigen::RowVector3d p, a;
    boundary_point_and_apex(M, b, hit[r], p, a);
    for (double s : insets) {
      const Eigen::RowVector3d q = (1 - s) * p + s * a;
      if (!((q - p).norm() < depth)) break;  // no shallower than where the row is
      if (try_move(v, q)) {
        if (s == 0) on_surface.push_back(v);
        ++moved;
        break;
      }
    }
  }
  std::sort(on_surface.begin(), on_surface.end());
  return moved;
}

}  // namespace shapemap
