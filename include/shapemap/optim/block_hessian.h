// A sparse symmetric Hessian of an energy over vertex positions (n×3), in 3×3 blocks, with
// a pattern fixed by the elements (tets, triangles, ...) of a mesh: built once, filled
// many times. Only the lower triangle is stored (CSC, the layout CHOLMOD reads with
// stype = -1), over the free vertices only: rows and columns of fixed vertices are left
// out, so a Newton step moves the free vertices with the others held.
//
//   BlockHessian H(T, n, free);          // pattern: vertices sharing an element of T
//   H.set_zero();
//   H.add_element(k, He);                // He: (4·3)×(4·3) Hessian of element k's corners
//   H.add_block(a, b, B);                // B = d²E/dx_a dx_b (3×3); a, b share an element
//   solver.factorize(H.matrix());
#pragma once
#include <Eigen/Core>
#include <Eigen/Sparse>
#include <vector>

namespace shapemap {

class BlockHessian {
 public:
  BlockHessian() = default;
  // E: m×k elements (k <= 4) over n vertices; free_vertices: the vertices whose positions
  // are unknowns (ascending or not; each once). Vertex pairs that share an element get a
  // block. Unknown 3q+c is coordinate c of free_vertices[q].
  BlockHessian(const Eigen::MatrixXi& E, int n, const std::vector<int>& free_vertices);

  int num_free() const { return int(free_.size()); }
  const std::vector<int>& free_vertices() const { return free_; }
  int free_index(int v) const { return index_[v]; }  // -1 for a fixed vertex

  void set_zero();
  // Adds the element Hessian He (3k×3k, corner-major: row 3a+c = coordinate c of corner a)
  // of element e. Rows/columns of fixed corners are dropped.
  void add_element(int e, const Eigen::Ref<const Eigen::MatrixXd>& He);
  // Adds B to block (a, b) and B^T to block (b, a) (a != b), or B (symmetric) to the
  // diagonal block when a == b. a and b must share an element (throws otherwise).
  void add_block(int a, int b, const Eigen::Matrix3d& B);
  // Adds s to the 3 diagonal entries of every free vertex (a shift).
  void add_diagonal(double s);
  // Adds s·I_3 to the diagonal block of vertex a (if free).
  void add_diagonal(int a, double s);

  const Eigen::SparseMatrix<double>& matrix() const { return H_; }
  // y = H x (the full symmetric matrix; x, y of length 3·num_free()).
  Eigen::VectorXd multiply(const Eigen::VectorXd& x) const;

 private:
  // Offset in H_'s value array of entry (3*fr + r, 3*fc + c), fr >= fc, via the position
  // `slot` of block row fr in block column fc's list (slot 0 is the diagonal block).
  int offset(int fc, int slot, int r, int c) const;
  int slot_of(int fr, int fc) const;  // fr >= fc; -1 if no block

  std::vector<int> free_, index_;
  std::vector<int> col_start_, col_rows_;  // block column fc: block rows col_rows_[col_start_[fc]..)
  std::vector<int> elem_slots_;            // per element, k*k slots (lower pairs), -1 if fixed
  std::vector<int> elem_free_;             // per element, k free indices of its corners (-1 fixed)
  int arity_ = 0;
  Eigen::SparseMatrix<double> H_;
};

}  // namespace shapemap
