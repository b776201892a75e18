// Point location in a triangulation of the unit sphere (the conformally flattened mesh
// of Blended Intrinsic Maps, lifted to the Riemann sphere by stereographic projection).
// Working on the sphere handles the removed pole (the punctured face covers the
// neighbourhood of ∞) and points mapped to ∞ without special cases.
//
// A point x (unit vector) lies in face (a, b, c) when the ray through x meets the
// triangle: the three triple products x·(b×c), x·(c×a), x·(a×b) are >= 0 (faces are
// counter-clockwise seen from outside). Queries walk across edges from a start face
// (a nearby known answer, or the face stored for its cell of a cube-map grid), and fall
// back to a scan of all faces if the walk does not arrive (overlapping or flipped
// faces). The answer does not depend on threads; it depends on the start face only
// where faces overlap.
#pragma once
#include <Eigen/Core>
#include <Eigen/Geometry>
#include <vector>

namespace shapemap {

class SphereLocator {
 public:
  struct Location {
    int face = -1;
    Eigen::Vector3d bary = Eigen::Vector3d::Zero();  // of the central projection of x
  };
  SphereLocator() = default;
  // S: n×3 unit vectors; F: m×3 faces, counter-clockwise seen from outside.
  SphereLocator(const Eigen::MatrixXd& S, const Eigen::MatrixXi& F) { build(S, F); }
  void build(const Eigen::MatrixXd& S, const Eigen::MatrixXi& F);
  // The face containing x (any length, direction used), walking from start_face for at
  // most 6 steps, then from the face stored in a cube-map grid cell containing x
  // (start_face = -1: from the grid directly). steps (optional) receives the walk length.
  Location locate(const Eigen::Vector3d& x, int start_face = -1, int* steps = nullptr) const;
  // A face incident to vertex v (a good start for points near v).
  int vertex_face(int v) const { return vertex_face_[v]; }
  int num_faces() const { return int(F_.rows()); }
  // Number of queries that needed the scan of all faces since build (diagnostics).
  long long fallbacks() const { return fallbacks_; }

 private:
  std::vector<Eigen::Vector3d> S_;
  Eigen::MatrixXi F_, TT_;  // TT_(f, k): face across the edge opposite corner k
  std::vector<int> vertex_face_;
  int grid_ = 0;                 // cube-map resolution per cube face
  std::vector<int> grid_face_;   // 6 * grid_ * grid_: a face near each cell centre
  int cell_of(const Eigen::Vector3d& x) const;
  int max_steps_ = 0;
  mutable long long fallbacks_ = 0;
  Location scan(const Eigen::Vector3d& x) const;
  Location walk(const Eigen::Vector3d& x, int start, int cap, int* steps) const;  // face -1 if not arrived
  Location locate_from(const Eigen::Vector3d& x, int start, int cap, int* steps) const;
  int walk_or_scan(const Eigen::Vector3d& x, int start) const;
};

}  // namespace shapemap
