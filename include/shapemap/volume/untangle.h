// Local untangling of a ball map's folded tets (post-step of the ball parameterization,
// not in the paper; docs/methods.md, "Post-step").
#pragma once
#include <Eigen/Core>

namespace shapemap {

// T: m×4 tets; f: n×3 map, rows < nI interior vertices (move freely), rows >= nI boundary
// vertices (move on the unit sphere only: tets with all four vertices on the boundary
// need them to move). Gauss-Seidel sweeps over the vertices of tets with non-positive
// volume: each is moved towards the mean of its neighbours (boundary vertices: of its
// boundary neighbours, re-normalized) at t = 1, 1/2, 1/4, 1/8 when that lowers the
// number of non-positive incident tets or raises their smallest volume, then climbs the
// volume gradient of its smallest incident tet (max-min ascent). Stops after max_rounds
// sweeps, when none is folded, or after two sweeps without fewer folds.
// Returns the number of tets with non-positive volume left.
int untangle_ball_map(const Eigen::MatrixXi& T, int nI, int max_rounds, Eigen::MatrixXd& f);

}  // namespace shapemap
