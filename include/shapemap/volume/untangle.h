// Local untangling of folded tets by max-min ascent of the volumes around each vertex
// (Freitag & Plassmann 2000): the ball map's post-step (docs/methods.md, "Post-step") and
// the volume map's last step after landing (docs/methods.md, "Untangling in the target").
#pragma once
#include <Eigen/Core>
#include <functional>

namespace shapemap {

// Where a vertex may go. boundary(i): i moves towards the mean of its boundary neighbours
// (interior vertices: of all neighbours). place(i, y): puts candidate position y of i into
// the feasible set. tangent(i, d), optional: restricts an ascent direction d at i.
struct UntangleRules {
  std::function<bool(int)> boundary;
  std::function<void(int, Eigen::RowVector3d&)> place;
  std::function<void(int, Eigen::Vector3d&)> tangent;
  // When sweeps over the folded tets' vertices stall: sweeps in which the vertices up to
  // this many edges away also move, each raising the smallest volume of its own tets.
  int rings = 0;
  // Optional: place for those ring vertices that are on the boundary and in no folded tet
  // (the landing keeps them on the target's boundary: let inside, they drift inward, their
  // tets growing at every step, and the boundary leaves the target).
  std::function<void(int, Eigen::RowVector3d&)> place_boundary_ring;
};

// T: m×4 tets; f: n×3 positions. Gauss-Seidel sweeps over the vertices of tets with
// non-positive volume: each is moved towards the mean of its neighbours at t = 1, 1/2, 1/4,
// 1/8 when that lowers the number of non-positive incident tets or raises their smallest
// volume, then climbs the volume gradient of its smallest incident tet (max-min ascent).
// Every position tried goes through rules.place. Stops after max_rounds sweeps, when none
// is folded, or after two sweeps without fewer folds. Returns the number of tets with
// non-positive volume left. Without rings, vertices of positive tets only never move, and
// no sweep adds a folded tet.
int untangle_tets(const Eigen::MatrixXi& T, const UntangleRules& rules, int max_rounds, Eigen::MatrixXd& f);

// The ball map's case: rows < nI interior vertices (move freely), rows >= nI boundary
// vertices (move on the unit sphere only: tets with all four vertices on the boundary
// need them to move).
int untangle_ball_map(const Eigen::MatrixXi& T, int nI, int max_rounds, Eigen::MatrixXd& f);

}  // namespace shapemap
