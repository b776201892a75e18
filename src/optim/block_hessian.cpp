// Fixed-pattern block Hessian over the free vertices of a mesh (block_hessian.h).
#include "shapemap/optim/block_hessian.h"
#include "shapemap/error.h"
#include <algorithm>
#include <string>

namespace shapemap {

BlockHessian::BlockHessian(const Eigen::MatrixXi& E, int n, const std::vector<int>& free_vertices)
    : free_(free_vertices), arity_(int(E.cols())) {
  if (arity_ < 1 || arity_ > 4) throw Error("BlockHessian: elements must have 1 to 4 corners");
  index_.assign(n, -1);
  for (size_t q = 0; q < free_.size(); ++q) {
    const int v = free_[q];
    if (v < 0 || v >= n || index_[v] >= 0) throw Error("BlockHessian: bad or repeated free vertex");
    index_[v] = int(q);
  }
  const int nf = num_free();
  // Block pattern: (fr, fc) with fr >= fc for free corners of one element.
  std::vector<std::pair<int, int>> pairs;
  pairs.reserve(size_t(E.rows()) * arity_ * (arity_ - 1) / 2 + nf);
  for (int q = 0; q < nf; ++q) pairs.emplace_back(q, q);
  for (int e = 0; e < E.rows(); ++e)
    for (int a = 0; a < arity_; ++a)
      for (int b = 0; b < arity_; ++b) {
        const int fa = index_[E(e, a)], fb = index_[E(e, b)];
        if (fa > fb && fb >= 0) pairs.emplace_back(fa, fb);
      }
  // Sorted by column, then row: column fc's block rows ascend, the diagonal first.
  std::sort(pairs.begin(), pairs.end(), [](const auto& x, const auto& y) {
    return x.second != y.second ? x.second < y.second : x.first < y.first;
  });
  pairs.erase(std::unique(pairs.begin(), pairs.end()), pairs.end());
  col_start_.assign(nf + 1, 0);
  col_rows_.resize(pairs.size());
  for (size_t p = 0; p < pairs.size(); ++p) {
    col_rows_[p] = pairs[p].first;
    col_start_[pairs[p].second + 1]++;
  }
  for (int q = 0; q < nf; ++q) col_start_[q + 1] += col_start_[q];

  // Scalar CSC of the lower triangle: column 3fc+c holds rows 3fc+c..3fc+2 of the diagonal
  // block, then the 3 rows of each off-diagonal block row, ascending.
  const int N = 3 * nf;
  std::vector<int> outer(N + 1, 0);
  for (int fc = 0; fc < nf; ++fc) {
    const int off_blocks = col_start_[fc + 1] - col_start_[fc] - 1;
    for (int c = 0; c < 3; ++c) outer[3 * fc + c + 1] = (3 - c) + 3 * off_blocks;
  }
  for (int j = 0; j < N; ++j) outer[j + 1] += outer[j];
  H_.resize(N, N);
  H_.resizeNonZeros(outer[N]);
  std::copy(outer.begin(), outer.end(), H_.outerIndexPtr());
  int* inner = H_.innerIndexPtr();
  for (int fc = 0; fc < nf; ++fc)
    for (int c = 0; c < 3; ++c) {
      int o = outer[3 * fc + c];
      for (int r = c; r < 3; ++r) inner[o++] = 3 * fc + r;
      for (int s = col_start_[fc] + 1; s < col_start_[fc + 1]; ++s)
        for (int r = 0; r < 3; ++r) inner[o++] = 3 * col_rows_[s] + r;
    }
  set_zero();

  // Per element, the slot of each corner pair (fr >= fc), or -1.
  elem_slots_.assign(size_t(E.rows()) * arity_ * arity_, -1);
  for (int e = 0; e < E.rows(); ++e)
    for (int a = 0; a < arity_; ++a)
      for (int b = 0; b < arity_; ++b) {
        const int fa = index_[E(e, a)], fb = index_[E(e, b)];
        if (fa >= fb && fb >= 0) elem_slots_[(size_t(e) * arity_ + a) * arity_ + b] = slot_of(fa, fb);
      }
  elem_free_.resize(size_t(E.rows()) * arity_);
  for (int e = 0; e < E.rows(); ++e)
    for (int a = 0; a < arity_; ++a) elem_free_[size_t(e) * arity_ + a] = index_[E(e, a)];
}

int BlockHessian::slot_of(int fr, int fc) const {
  const auto b = col_rows_.begin() + col_start_[fc], e = col_rows_.begin() + col_start_[fc + 1];
  const auto it = std::lower_bound(b, e, fr);
  return it != e && *it == fr ? int(it - b) : -1;
}

int BlockHessian::offset(int fc, int slot, int r, int c) const {
  const int base = H_.outerIndexPtr()[3 * fc + c];
  return slot == 0 ? base + (r - c) : base + (3 - c) + 3 * (slot - 1) + r;
}

void BlockHessian::set_zero() {
  std::fill(H_.valuePtr(), H_.valuePtr() + H_.nonZeros(), 0.0);
}

void BlockHessian::add_element(int e, const Eigen::Ref<const Eigen::MatrixXd>& He) {
  double* val = H_.valuePtr();
  const int k = arity_;
  const int* fv = &elem_free_[size_t(e) * k];
  const int* slots = &elem_slots_[size_t(e) * k * k];
  for (int a = 0; a < k; ++a) {
    if (fv[a] < 0) continue;
    for (int b = 0; b < k; ++b) {
      const int slot = slots[a * k + b];
      if (slot < 0) continue;  // fixed corner, or the upper triangle
      const int fc = fv[b];
      if (a == b) {
        for (int c = 0; c < 3; ++c)
          for (int r = c; r < 3; ++r) val[offset(fc, 0, r, c)] += He(3 * a + r, 3 * a + c);
      } else {
        for (int c = 0; c < 3; ++c) {
          double* col = val + offset(fc, slot, 0, c);
          for (int r = 0; r < 3; ++r) col[r] += He(3 * a + r, 3 * b + c);
        }
      }
    }
  }
}

void BlockHessian::add_block(int a, int b, const Eigen::Matrix3d& B) {
  const int fa = index_[a], fb = index_[b];
  if (fa < 0 || fb < 0) return;
  double* val = H_.valuePtr();
  if (fa == fb) {
    for (int c = 0; c < 3; ++c)
      for (int r = c; r < 3; ++r) val[offset(fa, 0, r, c)] += B(r, c);
    return;
  }
  const bool lower = fa > fb;
  const int fr = lower ? fa : fb, fc = lower ? fb : fa;
  const int slot = slot_of(fr, fc);
  if (slot < 0)
    throw Error("BlockHessian: vertices " + std::to_string(a) + " and " + std::to_string(b) +
                " share no element");
  for (int c = 0; c < 3; ++c)
    for (int r = 0; r < 3; ++r) val[offset(fc, slot, r, c)] += lower ? B(r, c) : B(c, r);
}

void BlockHessian::add_diagonal(double s) {
  double* val = H_.valuePtr();
  for (int q = 0; q < num_free(); ++q)
    for (int c = 0; c < 3; ++c) val[offset(q, 0, c, c)] += s;
}

void BlockHessian::add_diagonal(int a, double s) {
  const int fa = index_[a];
  if (fa < 0) return;
  double* val = H_.valuePtr();
  for (int c = 0; c < 3; ++c) val[offset(fa, 0, c, c)] += s;
}

Eigen::VectorXd BlockHessian::multiply(const Eigen::VectorXd& x) const {
  return H_.selfadjointView<Eigen::Lower>() * x;
}

}  // namespace shapemap
