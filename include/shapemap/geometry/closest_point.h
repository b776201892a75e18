// Closest-point queries with bounding-volume hierarchies.
//  - ClosestPoint3: triangle meshes in R^3.
//  - ClosestPoint6: triangle or tetrahedral meshes whose vertices live in R^6 (or any
//    fixed dimension D), the projection step of elastic correspondence (P, Q steps)
//    and of symmetric volume maps (P-step). Vertex coordinates change every outer
//    iteration: refit() updates the boxes without rebuilding the tree.
// Every query returns the element, its barycentric coordinates and the squared distance.
#pragma once
#include <Eigen/Core>
#include <vector>

namespace shapemap {

struct ClosestPointResult {
  int elem = -1;
  Eigen::Vector4d bary = Eigen::Vector4d::Zero();  // first 3 used for triangles
  double sqdist = 0;
};

template <int D>
class ClosestPointBVH {
 public:
  using Point = Eigen::Matrix<double, D, 1>;
  ClosestPointBVH() = default;
  // V: n×D vertex coordinates; E: m×3 (triangles) or m×4 (tets).
  ClosestPointBVH(const Eigen::MatrixXd& V, const Eigen::MatrixXi& E) { build(V, E); }
  void build(const Eigen::MatrixXd& V, const Eigen::MatrixXi& E);
  // New vertex coordinates, same elements: recompute boxes bottom-up.
  void refit(const Eigen::MatrixXd& V);
  ClosestPointResult query(const Point& p) const;
  // Rows of P (k×D) in parallel; results in order.
  std::vector<ClosestPointResult> query(const Eigen::MatrixXd& P) const;
  int arity() const { return arity_; }

  // Additions (backward compatible):
  // Warm start: hint is an element index expected to be close to p (e.g. the previous
  // iteration's answer, -1 = none). The answer is the same exact closest point; a good
  // hint only tightens the initial bound, so fewer boxes are visited.
  ClosestPointResult query(const Point& p, int hint) const;
  // Rows of P (k×D) in parallel into a caller-owned vector (resized to k; no allocation
  // when it already has k entries). If use_hints, out[i].elem on entry is the hint for
  // row i (as above).
  // Rows i with skip[i] != 0 (skip: nullptr or k entries) are not queried: out[i] is left as
  // it was (resized entries are default).
  void query(const Eigen::MatrixXd& P, std::vector<ClosestPointResult>& out,
             bool use_hints = false, const std::vector<char>* skip = nullptr) const;
  int num_elements() const { return int(E_.rows()); }
  const Eigen::MatrixXd& vertices() const { return V_; }
  const Eigen::MatrixXi& elements() const { return E_; }

 private:
  struct Node {
    Eigen::Matrix<double, D, 1> lo, hi;
    int left = -1, right = -1;  // children, or -1 for a leaf
    int begin = 0, end = 0;     // element range in order_ for leaves
  };
  Eigen::MatrixXd V_;
  Eigen::MatrixXi E_;
  int arity_ = 3;
  std::vector<Node> nodes_;
  std::vector<int> order_;
  // Element vertex coordinates packed in leaf order: element order_[k] occupies
  // packed_[(k*arity_ + j)*D + d] (vertex j, coordinate d); filled by build/refit, so the
  // leaf tests read contiguous memory.
  std::vector<double> packed_;
  void pack();
  void test_leaf(const Point& p, const Node& node, ClosestPointResult& best) const;
  void test_elem(const Point& p, int k, ClosestPointResult& best) const;
  int build_node(int begin, int end, std::vector<Eigen::Matrix<double, D, 1>>& centroids);
  void refit_node(int n);
};

using ClosestPoint3 = ClosestPointBVH<3>;
using ClosestPoint6 = ClosestPointBVH<6>;

// Closest point on a simplex (triangle if nverts = 3, tet if 4) in R^D to p, with
// barycentric coordinates; exact (brute-force reference for the tests).
template <int D>
ClosestPointResult closest_point_on_simplex(const Eigen::Matrix<double, D, 1>& p,
                                            const Eigen::Matrix<double, D, 1>* verts, int nverts);

// Point location: the tet containing p (barycentric coordinates >= -tol), or the
// closest tet if none contains it. A BVH over tet boxes in R^3.
class TetLocator {
 public:
  TetLocator() = default;
  TetLocator(const Eigen::MatrixXd& V, const Eigen::MatrixXi& T) { build(V, T); }
  void build(const Eigen::MatrixXd& V, const Eigen::MatrixXi& T);
  ClosestPointResult locate(const Eigen::Vector3d& p) const;
  std::vector<ClosestPointResult> locate(const Eigen::MatrixXd& P) const;  // parallel
  // Warm start (as ClosestPointBVH::query with a hint): the same answer, fewer boxes visited
  // when hint (a tet, -1 = none) is near p; a tet that contains p ends the search at once.
  ClosestPointResult locate(const Eigen::Vector3d& p, int hint) const;

 private:
  ClosestPointBVH<3> bvh_;
};

}  // namespace shapemap
