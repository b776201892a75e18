// The volume map landing's last step (ours, issue 19): boundary vertices of the source that
// the landing's repairs left inside the target go back to the target's boundary, or toward
// it, where the caller's rule allows (the landing: their tets stay positive). Each such
// vertex is a point of the map's boundary at a distance from dM_j, which d^ (Eqs. 27-28)
// counts. docs/methods.md, "Back to the boundary".
#pragma once
#include "shapemap/geometry/closest_point.h"
#include "shapemap/mesh.h"
#include <Eigen/Core>
#include <functional>
#include <vector>

namespace shapemap {

// The point of dM (a boundary face of M and barycentric coordinates, h) and the inner corner
// of the tet behind that face: the landing's insets run from one toward the other.
void boundary_point_and_apex(const TetMesh& M, const TetBoundary& b, const ClosestPointResult& h, Eigen::RowVector3d& p,
                             Eigen::RowVector3d& apex);

// Rows `rows` of X (positions in the target tet mesh M, whose boundary is `b` with closest
// points `surface`): a row more than `tol` from dM goes to its closest point p on dM, or to
// (1 - s) p + s a, a the inner corner of the tet behind p, for the first s of `insets`
// (ascending, 0 first) whose point is nearer to dM than the row is and that try_move(row, q)
// accepts (it puts X.row(row) at q, or leaves it and returns false). Returns the number of
// rows moved; on_surface receives, sorted, the rows on dM afterwards (within tol, or moved
// to s = 0).
int return_to_boundary(Eigen::MatrixXd& X, const std::vector<int>& rows, const TetMesh& M, const TetBoundary& b,
                       const ClosestPoint3& surface, const std::vector<double>& insets, double tol,
                       const std::function<bool(int, const Eigen::RowVector3d&)>& try_move,
                       std::vector<int>& on_surface);

}  // namespace shapemap
