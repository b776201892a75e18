// The boundaries of the two landed maps made mutually inverse (reconcile_boundary.h).
#include "shapemap/volume/reconcile_boundary.h"
#include "shapemap/geometry/closest_point.h"

namespace shapemap {

void invert_boundary_map(const BoundaryMapSide& other, const Eigen::MatrixXd& Q, Eigen::MatrixXd& Y) {
  // The image surface g(dM): dM's triangles with their vertices at their images under g.
  const Eigen::MatrixXi& F = other.b.surface.F;
  Eigen::MatrixXd G(other.b.to_volume.size(), 3);
  for (Eigen::Index s = 0; s < G.rows(); ++s) G.row(s) = other.X.row(other.b.to_volume(s));
  const std::vector<ClosestPointResult> hit = ClosestPoint3(G, F).query(Q);
  Y.resize(Q.rows(), 3);
  for (Eigen::Index r = 0; r < Q.rows(); ++r) {
    const ClosestPointResult& h = hit[size_t(r)];
    Eigen::RowVector3d y = Eigen::RowVector3d::Zero();
    for (int c = 0; c < 3; ++c) y += h.bary(c) * other.V.row(other.b.to_volume(F(h.elem, c)));
    Y.row(r) = y;
  }
}

}  // namespace shapemap
