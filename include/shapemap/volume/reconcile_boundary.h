// The boundaries of the two landed maps made mutually inverse (ours, issue 19). After the
// landing, X_12 puts dM_1 on dM_2 and X_21 puts dM_2 on dM_1, each by its own projection; the
// round trip X_21(X_12(v)) of a boundary vertex then misses v by more than an interior
// vertex's does (cat -> lion: the boundary holds a quarter of the mass and 61-67% of the map
// files' E_R, Eq. 18). docs/methods.md, "Mutually inverse boundaries".
#pragma once
#include "shapemap/mesh.h"
#include <Eigen/Core>
#include <utility>
#include <vector>

namespace shapemap {

// One side of the pair: the source's rest positions V (its boundary b), the map X (rows of
// V's vertices, in the other side's frame), and which rows of X lie on the other side's
// boundary (on[v] != 0).
struct BoundaryMapSide {
  const Eigen::MatrixXd& V;
  const TetBoundary& b;
  const Eigen::MatrixXd& X;
  const std::vector<char>& on;
};

// The inverse of side `other`'s boundary map at points Q (k×3, in the frame its map maps
// into): per row, the point of other's own boundary (in other.V's frame) whose image is
// closest to it.
void invert_boundary_map(const BoundaryMapSide& other, const Eigen::MatrixXd& Q, Eigen::MatrixXd& Y);

// Moves proposed for both maps at once, from the maps as they are (so the step is symmetric
// in the two sides): f = X_12 on dM_1's vertices and g = X_21 on dM_2's, piecewise linear on
// the boundary triangles. For a boundary vertex v of M_1 with f(v) on dM_2, y = g^-1(V_1(v))
// is the point of dM_2 whose image under g is closest to V_1(v) (found on the surface
// g(dM_2)); v's image moves to the midpoint (f(v) + y) / 2, put on dM_2 by project_on_2 (the
// caller's closest point on dM_2). Likewise for M_2 with the roles exchanged. To first order
// the midpoints cancel the round-trip error of both maps (f = g^-1 + e: g_new o f_new =
// id + O(e^2)); the caller decides which moves to keep. moves12 / moves21 receive (row of X,
// new position).
template <class Project1, class Project2>
void reconcile_boundary_step(const BoundaryMapSide& s1, const BoundaryMapSide& s2, const Project1& project_on_1,
                             const Project2& project_on_2,
                             std::vector<std::pair<int, Eigen::RowVector3d>>& moves12,
                             std::vector<std::pair<int, Eigen::RowVector3d>>& moves21) {
  auto side = [&](const BoundaryMapSide& s, const BoundaryMapSide& other, const auto& project,
                  std::vector<std::pair<int, Eigen::RowVector3d>>& moves) {
    moves.clear();
    std::vector<int> rows;
    for (Eigen::Index b = 0; b < s.b.to_volume.size(); ++b)
      if (s.on[s.b.to_volume(b)]) rows.push_back(s.b.to_volume(b));
    Eigen::MatrixXd Q(rows.size(), 3), Y;
    for (size_t r = 0; r < rows.size(); ++r) Q.row(Eigen::Index(r)) = s.V.row(rows[r]);
    invert_boundary_map(other, Q, Y);
    for (size_t r = 0; r < rows.size(); ++r) {
      const Eigen::RowVector3d x = s.X.row(rows[r]), y = Y.row(Eigen::Index(r));
      moves.emplace_back(rows[r], project(Eigen::RowVector3d(0.5 * (x + y))));
    }
  };
  side(s1, s2, project_on_2, moves12);
  side(s2, s1, project_on_1, moves21);
}

}  // namespace shapemap
