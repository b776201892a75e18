// Symmetric volume maps: symmetric-volume-maps.txt Secs. 4-5, Algorithm 1.
#include "shapemap/volume/symmetric_map.h"
#include "shapemap/adjacency.h"
#include "shapemap/error.h"
#include "shapemap/geometry/harmonic_extension.h"
#include "shapemap/geometry/mass.h"
#include "shapemap/geometry/tet_volume.h"
#include "shapemap/optim/anderson.h"
#include "shapemap/optim/coupled_newton.h"
#include "shapemap/optim/lbfgs.h"
#include "shapemap/optim/newton.h"
#include "shapemap/task_pair.h"
#include "shapemap/timing.h"
#include "shapemap/volume/foldover_free.h"
#include "shapemap/volume/reconcile_boundary.h"
#include "shapemap/volume/locate_keeping_positive.h"
#include "shapemap/volume/return_to_boundary.h"
#include "shapemap/volume/target_coverage.h"
#include "shapemap/volume/untangle.h"
#include <cstdlib>
#include <Eigen/Dense>
#include <algorithm>
#include <chrono>
#include <cmath>
#include <functional>
#include <limits>
#include <memory>

namespace shapemap {

namespace {

// Boundary face f of M (surface numbering of `bd`) with barycentric b -> (tet, 4 coords).
void face_to_tet(const TetMesh& M, const TetBoundary& bd, int f, const Eigen::Vector3d& b,
                 int& tet, Eigen::Vector4d& bary) {
  tet = bd.face_tet(f);
  bary.setZero();
  for (int c = 0; c < 3; ++c) {
    int v = bd.to_volume(bd.surface.F(f, c));
    int corner = -1;
    for (int q = 0; q < 4; ++q)
      if (M.T(tet, q) == v) corner = q;
    if (corner < 0) throw Error("boundary_surface: face_tet does not contain the face");
    bary(corner) += b(c);
  }
}

// One tet incident to each vertex, and the corner of the vertex in it (-1 if unused).
void vertex_first_tet(const TetMesh& M, std::vector<int>& tet, std::vector<int>& corner) {
  tet.assign(M.num_vertices(), -1);
  corner.assign(M.num_vertices(), -1);
  for (int k = 0; k < M.num_tets(); ++k)
    for (int q = 0; q < 4; ++q)
      if (tet[M.T(k, q)] < 0) {
        tet[M.T(k, q)] = k;
        corner[M.T(k, q)] = q;
      }
}

// Nearest row of S (k×3) to each row of Q (n×3), brute force, parallel over Q.
std::vector<int> nearest_rows(const Eigen::MatrixXd& Q, const Eigen::MatrixXd& S) {
  std::vector<int> out(Q.rows(), -1);
  const int k = int(S.rows());
#pragma omp parallel for schedule(static)
  for (int i = 0; i < int(Q.rows()); ++i) {
    double best = std::numeric_limits<double>::infinity();
    int bi = -1;
    for (int j = 0; j < k; ++j) {
      double d = (S.row(j) - Q.row(i)).squaredNorm();
      if (d < best) {
        best = d;
        bi = j;
      }
    }
    out[i] = bi;
  }
  return out;
}

Eigen::VectorXd boundary_vertex_areas(const TriMesh& S) { return lumped_mass(S.V, S.F); }

Eigen::MatrixXi faces_in_volume_numbering(const TetBoundary& bd) {
  Eigen::MatrixXi F = bd.surface.F;
  for (int f = 0; f < F.rows(); ++f)
    for (int c = 0; c < 3; ++c) F(f, c) = bd.to_volume(F(f, c));
  return F;
}

}  // namespace

// ---------------------------------------------------------------------------------
// Locating positions in a tet mesh

BarycentricMap locate_in_tets(const TetMesh& M, const Eigen::MatrixXd& X,
                              const std::vector<int>& boundary_rows, int* outside) {
  BarycentricMap map;
  const int n = int(X.rows());
  map.elem.resize(n);
  map.bary.resize(n, 4);
  TetLocator loc(M.V, M.T);
  std::vector<ClosestPointResult> r = loc.locate(X);
  if (outside) *outside = 0;
  for (int i = 0; i < n; ++i) {
    if (outside && r[i].sqdist > 1e-20) ++*outside;
    map.elem(i) = r[i].elem;
    Eigen::Vector4d b = r[i].bary.cwiseMax(0.0);
    double s = b.sum();
    map.bary.row(i) = (s > 0 ? Eigen::Vector4d(b / s) : Eigen::Vector4d(1, 0, 0, 0)).transpose();
  }
  if (!boundary_rows.empty()) {
    TetBoundary bd = boundary_surface(M);
    ClosestPoint3 bvh(bd.surface.V, bd.surface.F);
    Eigen::MatrixXd Q(boundary_rows.size(), 3);
    for (size_t q = 0; q < boundary_rows.size(); ++q) Q.row(q) = X.row(boundary_rows[q]);
    std::vector<ClosestPointResult> rb = bvh.query(Q);
    for (size_t q = 0; q < boundary_rows.size(); ++q) {
      int tet;
      Eigen::Vector4d b;
      face_to_tet(M, bd, rb[q].elem, rb[q].bary.head<3>(), tet, b);
      map.elem(boundary_rows[q]) = tet;
      map.bary.row(boundary_rows[q]) = b.transpose();
    }
  }
  return map;
}

// ---------------------------------------------------------------------------------
// Initializations (Sec. 5.1)

BarycentricMap landmark_initial_map(const TetMesh& A, const TetMesh& B, const std::vector<int>& LA,
                                    const std::vector<int>& LB) {
  if (LA.size() != LB.size())
    throw InputError("landmarks: " + std::to_string(LA.size()) + " landmarks on A but " +
                     std::to_string(LB.size()) + " on B (counts must be equal)");
  if (LA.empty()) throw InputError("landmarks: no landmarks given");
  for (int v : LA)
    if (v < 0 || v >= A.num_vertices())
      throw InputError("landmarks: index " + std::to_string(v) + " out of range for A (" +
                       std::to_string(A.num_vertices()) + " vertices)");
  for (int v : LB)
    if (v < 0 || v >= B.num_vertices())
      throw InputError("landmarks: index " + std::to_string(v) + " out of range for B (" +
                       std::to_string(B.num_vertices()) + " vertices)");
  std::vector<int> tet, corner;
  vertex_first_tet(B, tet, corner);
  for (int v : LB)
    if (tet[v] < 0) throw InputError("landmarks: vertex " + std::to_string(v) + " of B is in no tet");
  Eigen::MatrixXd S(LA.size(), 3);
  for (size_t k = 0; k < LA.size(); ++k) S.row(k) = A.V.row(LA[k]);
  std::vector<int> near = nearest_rows(A.V, S);
  BarycentricMap map;
  map.elem.resize(A.num_vertices());
  map.bary.setZero(A.num_vertices(), 4);
  for (int i = 0; i < A.num_vertices(); ++i) {
    int t = LB[near[i]];
    map.elem(i) = tet[t];
    map.bary(i, corner[t]) = 1.0;
  }
  return map;
}

BarycentricMap boundary_initial_map(const TetMesh& A, const TetMesh& B,
                                    const Eigen::MatrixXd& boundary_targets) {
  TetBoundary bA = boundary_surface(A), bB = boundary_surface(B);
  const int nb = int(bA.to_volume.size());
  if (boundary_targets.rows() != nb || boundary_targets.cols() != 3)
    throw InputError("surface map: " + std::to_string(boundary_targets.rows()) +
                     " boundary images for " + std::to_string(nb) + " boundary vertices of A");
  ClosestPoint3 bvh(bB.surface.V, bB.surface.F);
  std::vector<ClosestPointResult> r = bvh.query(boundary_targets);
  BarycentricMap map;
  map.elem.setConstant(A.num_vertices(), -1);
  map.bary.setZero(A.num_vertices(), 4);
  for (int i = 0; i < nb; ++i) {
    int tet;
    Eigen::Vector4d b;
    face_to_tet(B, bB, r[i].elem, r[i].bary.head<3>(), tet, b);
    map.elem(bA.to_volume(i)) = tet;
    map.bary.row(bA.to_volume(i)) = b.transpose();
  }
  // Interior vertices: the target of the closest boundary vertex.
  std::vector<int> interior;
  for (int v = 0; v < A.num_vertices(); ++v)
    if (bA.to_surface(v) < 0) interior.push_back(v);
  Eigen::MatrixXd Q(interior.size(), 3);
  for (size_t q = 0; q < interior.size(); ++q) Q.row(q) = A.V.row(interior[q]);
  std::vector<int> near = nearest_rows(Q, bA.surface.V);
  for (size_t q = 0; q < interior.size(); ++q) {
    int src = bA.to_volume(near[q]);
    map.elem(interior[q]) = map.elem(src);
    map.bary.row(interior[q]) = map.bary.row(src);
  }
  return map;
}

BarycentricMap surface_initial_map(const TetMesh& A, const TetMesh& B, const TriMesh& SA,
                                   const TriMesh& SB, const BarycentricMap& map_AB) {
  validate_map(map_AB, SA.num_vertices(), SB.num_faces(), 3, "surface map A->B");
  Eigen::MatrixXd img = map_positions(map_AB, SB.V, SB.F);  // SA vertices -> B space
  TetBoundary bA = boundary_surface(A);
  ClosestPoint3 bvh(SA.V, SA.F);
  std::vector<ClosestPointResult> r = bvh.query(bA.surface.V);
  Eigen::MatrixXd targets(bA.surface.V.rows(), 3);
  for (int i = 0; i < targets.rows(); ++i) {
    Eigen::RowVector3d p = Eigen::RowVector3d::Zero();
    for (int c = 0; c < 3; ++c) p += r[i].bary(c) * img.row(SA.F(r[i].elem, c));
    targets.row(i) = p;
  }
  return boundary_initial_map(A, B, targets);
}

// ---------------------------------------------------------------------------------
// The X-step objective of one direction

namespace {
// Per tet: bit q set when the face opposite corner q lies on the boundary.
std::vector<unsigned char> boundary_face_bits(const TetMesh& M, const TetBoundary& bd) {
  std::vector<unsigned char> bits(M.num_tets(), 0);
  for (int f = 0; f < bd.surface.num_faces(); ++f) {
    const int t = bd.face_tet(f);
    for (int q = 0; q < 4; ++q) {
      bool in_face = false;
      for (int c = 0; c < 3; ++c) in_face |= bd.to_volume(bd.surface.F(f, c)) == M.T(t, q);
      if (!in_face) bits[t] |= static_cast<unsigned char>(1u << q);
    }
  }
  return bits;
}

// An orthonormal basis (columns) of the directions in which a point with barycentric
// coordinates `bary` in tet t of M may move and stay in M to first order: all three, unless
// it lies on faces of dM (a zero coordinate opposite a boundary face; across an interior
// face it moves on into the neighbouring tet). No columns at a corner of dM.
Eigen::MatrixXd free_directions(const TetMesh& M, const std::vector<unsigned char>& face_bits, int t,
                                const Eigen::RowVector4d& bary) {
  constexpr double eps = 1e-9;
  Eigen::Vector3d normals[4];
  int active = 0;
  for (int q = 0; q < 4; ++q)
    if (bary(q) <= eps && (face_bits[t] >> q & 1)) {
      const Eigen::Vector3d p0 = M.V.row(M.T(t, (q + 1) % 4)), p1 = M.V.row(M.T(t, (q + 2) % 4)),
                            p2 = M.V.row(M.T(t, (q + 3) % 4));
      normals[active++] = (p1 - p0).cross(p2 - p0).normalized();
    }
  if (active == 0) return Eigen::Matrix3d::Identity();
  if (active == 1) {
    const Eigen::Vector3d& n = normals[0];
    const Eigen::Vector3d a = std::abs(n.x()) < 0.9 ? Eigen::Vector3d::UnitX() : Eigen::Vector3d::UnitY();
    const Eigen::Vector3d t1 = n.cross(a).normalized();
    Eigen::MatrixXd T(3, 2);
    T << t1, n.cross(t1);
    return T;
  }
  const Eigen::Vector3d e = normals[0].cross(normals[1]);
  if (active == 2 && e.norm() > 1e-12) return e.normalized();
  return Eigen::MatrixXd(3, 0);
}

// The Jacobian of the piecewise-linear map X on tet t of the rest mesh M.
Eigen::Matrix3d tet_jacobian(const TetMesh& M, const Eigen::MatrixXd& X, int t) {
  Eigen::Matrix3d Dv, Dx;
  for (int c = 0; c < 3; ++c) {
    Dv.col(c) = (M.V.row(M.T(t, c + 1)) - M.V.row(M.T(t, 0))).transpose();
    Dx.col(c) = (X.row(M.T(t, c + 1)) - X.row(M.T(t, 0))).transpose();
  }
  return Dx * Dv.inverse();
}
}  // namespace

DirectionalEnergy::DirectionalEnergy(const TetMesh& Mi, const TetMesh& Mj) : Mi_(Mi), Mj_(Mj) {
  arap_.build(Mi_.V, Mi_.T);
  bi_ = boundary_surface(Mi_);
  bj_ = boundary_surface(Mj_);
  Ci_ = tet_lumped_mass(Mi_.V, Mi_.T);
  Cj_ = tet_lumped_mass(Mj_.V, Mj_.T);
  ci_ = Ci_.sum();
  cj_ = Cj_.sum();
  ai_ = boundary_vertex_areas(bi_.surface);
  aj_ = boundary_vertex_areas(bj_.surface);
  si_ = ai_.sum();
  sj_ = aj_.sum();
  ai_rest_ = ai_;
  aj_rest_ = aj_;
  Fi_vol_ = faces_in_volume_numbering(bi_);
  target_boundary_.build(bj_.surface.V, bj_.surface.F);
  bi_faces_ = boundary_face_bits(Mi_, bi_);
  bj_faces_ = boundary_face_bits(Mj_, bj_);
}

void DirectionalEnergy::set_weights(double alpha, double beta, double gamma, double backward_scale) {
  alpha_ = alpha;
  beta_ = beta;
  gamma_ = gamma;
  bscale_ = backward_scale;
}

void DirectionalEnergy::set_maps(const BarycentricMap& P_ij, const BarycentricMap& P_ji) {
  set_forward_map(P_ij);
  set_backward_map(P_ji);
}

void DirectionalEnergy::set_forward_map(const BarycentricMap& P_ij) {
  PijVj_ = map_positions(P_ij, Mj_.V, Mj_.T);
}

void DirectionalEnergy::set_backward_map(const BarycentricMap& P_ji) {
  Pji_ = P_ji;
  const int ni = Mi_.num_vertices(), nj = P_ji.size();
  Pji_verts_.resize(nj, 4);
  for (int r = 0; r < nj; ++r)
    for (int q = 0; q < 4; ++q) Pji_verts_(r, q) = Mi_.T(P_ji.elem(r), q);
  // Reverse CSR for the E_R gradient gather (entries in increasing 4w+q per vertex).
  rev_start_.assign(ni + 1, 0);
  for (int r = 0; r < nj; ++r)
    for (int q = 0; q < 4; ++q) rev_start_[Pji_verts_(r, q) + 1]++;
  for (int v = 0; v < ni; ++v) rev_start_[v + 1] += rev_start_[v];
  rev_list_.resize(4 * size_t(nj));
  std::vector<int> fill(rev_start_.begin(), rev_start_.end() - 1);
  for (int r = 0; r < nj; ++r)
    for (int q = 0; q < 4; ++q) rev_list_[fill[Pji_verts_(r, q)]++] = 4 * r + q;
}

// Per-row terms are written into arrays in parallel and summed serially in row order, and
// gradient rows are gathered per vertex in a fixed order: the result does not depend on
// the number of threads.
double DirectionalEnergy::evaluate(const Eigen::MatrixXd& X, Eigen::MatrixXd* grad,
                                   Terms* terms) const {
  const int ni = Mi_.num_vertices(), nj = Mj_.num_vertices();
  if (X.rows() != ni || X.cols() != 3) throw Error("DirectionalEnergy: X must be n_i×3");
  Terms t;
  // Terms with zero weight are skipped unless `terms` asks for them.
  const bool all = terms != nullptr;
  // E_ARAP (Eq. 20)
  t.arap = (alpha_ != 0 || all) ? arap_.energy(X, alpha_ != 0 ? grad : nullptr) : 0.0;
  if (grad) {
    if (alpha_ != 0)
      *grad *= alpha_;
    else
      grad->setZero(ni, 3);
  }
  if (barrier_) {  // first: an inverted active tet makes the value +inf, nothing else needed
    t.barrier = barrier_->energy(X, grad);
    if (!std::isfinite(t.barrier)) {
      if (terms) *terms = t;
      return t.barrier;
    }
  }
  const bool do_R = alpha_ != 1 || all, grad_R = grad && alpha_ != 1;
  if (do_R) {
    Dr_.resize(nj, 3);
    er_.resize(nj);
  }
  eq_.resize(ni);
  const double sq = 2.0 * beta_ / (ci_ * cj_), sr = 2.0 * (1.0 - alpha_) / (cj_ * cj_);
#pragma omp parallel
  {
    // E_R (Eq. 18, term (j,i)) residuals: (P_ji X)_w - V_j(w)
    if (do_R) {
#pragma omp for schedule(static)
      for (int w = 0; w < nj; ++w) {
        Eigen::RowVector3d p = Eigen::RowVector3d::Zero();
        for (int q = 0; q < 4; ++q) p += Pji_.bary(w, q) * X.row(Pji_verts_(w, q));
        p -= Mj_.V.row(w);
        Dr_.row(w) = p;
        er_(w) = Cj_(w) * p.squaredNorm();
      }
    }
    // E_Q (Eq. 17): C_i(v) |X_v - (P_ij V_j)_v|^2, and the gradients of E_Q and E_R
    // gathered per vertex.
#pragma omp for schedule(static)
    for (int v = 0; v < ni; ++v) {
      const Eigen::RowVector3d d = X.row(v) - PijVj_.row(v);
      eq_(v) = Ci_(v) * d.squaredNorm();
      if (grad) {
        Eigen::RowVector3d g = Eigen::RowVector3d::Zero();
        if (beta_ != 0) g = (sq * Ci_(v)) * d;
        if (grad_R)
          for (int p = rev_start_[v]; p < rev_start_[v + 1]; ++p) {
            const int w = rev_list_[p] >> 2, q = rev_list_[p] & 3;
            g += (sr * Cj_(w) * Pji_.bary(w, q)) * Dr_.row(w);
          }
        grad->row(v) += g;
      }
    }
  }
  double sum_q = 0;
  for (int v = 0; v < ni; ++v) sum_q += eq_(v);
  t.auxiliary = sum_q / (ci_ * cj_);
  if (do_R) {
    double sum_r = 0;
    for (int w = 0; w < nj; ++w) sum_r += er_(w);
    t.reversibility = sum_r / (cj_ * cj_);
  }
  projection_terms(X, grad, all, t);
  for (size_t q = 0; q < anchor_rows_.size(); ++q) {
    const Eigen::RowVector3d d = X.row(anchor_rows_[q]) - anchor_pts_.row(Eigen::Index(q));
    t.anchors += anchor_k_ * d.squaredNorm();
    if (grad) grad->row(anchor_rows_[q]) += (2.0 * anchor_k_) * d;
  }
  last_X_ = X;
  t.total = alpha_ * t.arap + (1 - alpha_) * t.reversibility +
            gamma_ * (t.projection_forward + bscale_ * t.projection_backward) + beta_ * t.auxiliary +
            t.barrier + t.anchors;
  if (terms) *terms = t;
  return t.total;
}

double DirectionalEnergy::weighted_map_terms(const Eigen::MatrixXd& X) const {
  const int ni = Mi_.num_vertices(), nj = Pji_.size();
  er_.resize(nj);
  eq_.resize(ni);
#pragma omp parallel
  {
#pragma omp for schedule(static)
    for (int w = 0; w < nj; ++w) {
      Eigen::RowVector3d p = -Mj_.V.row(w);
      for (int q = 0; q < 4; ++q) p += Pji_.bary(w, q) * X.row(Pji_verts_(w, q));
      er_(w) = Cj_(w) * p.squaredNorm();
    }
#pragma omp for schedule(static)
    for (int v = 0; v < ni; ++v) eq_(v) = Ci_(v) * (X.row(v) - PijVj_.row(v)).squaredNorm();
  }
  double sum_r = 0, sum_q = 0;  // serial sums: independent of the thread count
  for (int w = 0; w < nj; ++w) sum_r += er_(w);
  for (int v = 0; v < ni; ++v) sum_q += eq_(v);
  return (1.0 - alpha_) * sum_r / (cj_ * cj_) + beta_ * sum_q / (ci_ * cj_);
}

void DirectionalEnergy::add_eliminated_p_hessian(const Eigen::MatrixXd& X, const BarycentricMap& P_ij,
                                                 const Eigen::MatrixXd& X_ji, BlockHessian& H,
                                                 const std::vector<char>* held_ij,
                                                 const std::vector<char>* held_ji) const {
  const int ni = Mi_.num_vertices(), nj = Mj_.num_vertices();
  if (beta_ == 0 || alpha_ == 1 || P_ij.size() != ni || Pji_.size() != nj) return;
  // E_Q of row v of P_ij (y in M_j) with the other direction's E_R: per vertex of M_i,
  // b|X_v - y|^2 + a|A y + c - V_i(v)|^2, A the Jacobian of X_ji on y's tet. Eliminating y
  // leaves 2b (I - b S), S = T (b I + a T^T A^T A T)^-1 T^T; add_hessian() has 2b I.
  for (int v = 0; v < ni; ++v) {
    if (H.free_index(v) < 0 || (held_ij && (*held_ij)[v])) continue;
    double a, b;
    Eigen::Matrix3d A, S;
    if (forward_row_schur(v, P_ij, X_ji, a, b, A, S)) H.add_block(v, v, -2.0 * b * b * S);
  }
  // E_R of this direction with row w of P_ji (y in M_i, in tet s, coordinates l) and E_Q of
  // the other: a|X(y) - V_j(w)|^2 + b|X_ji(w) - y|^2. Eliminating y (Gauss-Newton: X(y) =
  // sum_k l_k X_k + A (y - y0), A the Jacobian of X on s) turns add_hessian()'s
  // 2a (l l^T ⊗ I) into 2a (l l^T ⊗ (I - a A T (a T^T A^T A T + b I)^-1 T^T A^T)).
  Eigen::Matrix<double, 12, 12> He;
  for (int w = 0; w < nj; ++w) {
    if (held_ji && (*held_ji)[w]) continue;
    const int t = Pji_.elem(w);
    const Eigen::MatrixXd T = free_directions(Mi_, bi_faces_, t, Pji_.bary.row(w));
    if (T.cols() == 0) continue;
    const Eigen::Matrix3d A = tet_jacobian(Mi_, X, t);
    const double a = (1.0 - alpha_) * Cj_(w) / (cj_ * cj_), b = beta_ * Cj_(w) / (cj_ * ci_);
    const Eigen::MatrixXd AT = A * T;
    const Eigen::MatrixXd M = b * Eigen::MatrixXd::Identity(T.cols(), T.cols()) + a * AT.transpose() * AT;
    const Eigen::Matrix3d D = -2.0 * a * a * (AT * M.ldlt().solve(AT.transpose()));
    for (int p = 0; p < 4; ++p)
      for (int q = 0; q < 4; ++q) He.block<3, 3>(3 * p, 3 * q) = (Pji_.bary(w, p) * Pji_.bary(w, q)) * D;
    H.add_element(t, He);
  }
}

bool DirectionalEnergy::forward_row_schur(int v, const BarycentricMap& P_ij, const Eigen::MatrixXd& X_ji,
                                          double& a, double& b, Eigen::Matrix3d& A, Eigen::Matrix3d& S) const {
  const Eigen::MatrixXd T = free_directions(Mj_, bj_faces_, P_ij.elem(v), P_ij.bary.row(v));
  if (T.cols() == 0) return false;  // at a corner of dM_j: y held, the fixed-P Hessian is exact
  A = tet_jacobian(Mj_, X_ji, P_ij.elem(v));
  b = beta_ * Ci_(v) / (ci_ * cj_);
  a = (1.0 - alpha_) * Ci_(v) / (ci_ * ci_);
  const Eigen::MatrixXd AT = A * T;
  const Eigen::MatrixXd M = b * Eigen::MatrixXd::Identity(T.cols(), T.cols()) + a * AT.transpose() * AT;
  S = T * M.ldlt().solve(T.transpose());
  return true;
}

void DirectionalEnergy::add_coupling(const BarycentricMap& P_ij, const Eigen::MatrixXd& X_ji,
                                     const std::vector<char>* held_ij,
                                     const std::function<void(int, int, const Eigen::Matrix3d&)>& add) const {
  const int ni = Mi_.num_vertices();
  if (beta_ == 0 || alpha_ == 1 || P_ij.size() != ni) return;
  // Residuals r1 = sqrt(b)(X_v - y), r2 = sqrt(a)(sum_k l_k X_ji(k) + A (y - y0) - V_i(v)):
  // Gauss-Newton with y eliminated couples X_v and X_ji(k) by
  // -2 (J_x^T J_y)(J_y^T J_y)^-1 (J_y^T J_k) = 2ab l_k S A^T.
  for (int v = 0; v < ni; ++v) {
    if (held_ij && (*held_ij)[v]) continue;
    double a, b;
    Eigen::Matrix3d A, S;
    if (!forward_row_schur(v, P_ij, X_ji, a, b, A, S)) continue;
    const Eigen::Matrix3d K = 2.0 * a * b * S * A.transpose();
    for (int k = 0; k < 4; ++k)
      if (P_ij.bary(v, k) != 0) add(v, Mj_.T(P_ij.elem(v), k), P_ij.bary(v, k) * K);
  }
}

void DirectionalEnergy::set_anchors(const std::vector<int>& rows, const Eigen::MatrixXd& A, double k) {
  if (A.rows() != Eigen::Index(rows.size())) throw Error("DirectionalEnergy::set_anchors: one point per row");
  anchor_rows_ = rows;
  anchor_pts_ = A;
  anchor_k_ = rows.empty() ? 0.0 : k;
}

void DirectionalEnergy::emphasize_projection(const std::vector<char>& marked_i, const std::vector<char>& marked_j,
                                             double factor) {
  ai_ = ai_rest_;
  aj_ = aj_rest_;
  for (size_t b = 0; b < marked_i.size() && b < size_t(ai_.size()); ++b)
    if (marked_i[b]) ai_(Eigen::Index(b)) *= factor;
  for (size_t b = 0; b < marked_j.size() && b < size_t(aj_.size()); ++b)
    if (marked_j[b]) aj_(Eigen::Index(b)) *= factor;
}

// E_P,f (Eq. 21) and E_P,b (Eq. 22) into t, their gradients added to *grad if non-null.
void DirectionalEnergy::projection_terms(const Eigen::MatrixXd& X, Eigen::MatrixXd* grad, bool all,
                                         Terms& t) const {
  // E_P,f (Eq. 21): boundary vertices of M_i at X, to dM_j.
  if (gamma_ != 0 || all) {
    const int nb = int(bi_.to_volume.size());
    Qf_.resize(nb, 3);
    for (int b = 0; b < nb; ++b) Qf_.row(b) = X.row(bi_.to_volume(b));
    const bool hinted = int(hits_f_.size()) == nb;  // last evaluation's answers
    target_boundary_.query(Qf_, hits_f_, hinted);
    ef_.resize(nb);
    const double s = 2.0 * gamma_ / si_;
#pragma omp parallel for schedule(static)
    for (int b = 0; b < nb; ++b) {
      const ClosestPointResult& r = hits_f_[b];
      Eigen::RowVector3d p = Eigen::RowVector3d::Zero();
      for (int c = 0; c < 3; ++c) p += r.bary(c) * bj_.surface.V.row(bj_.surface.F(r.elem, c));
      const Eigen::RowVector3d d = Qf_.row(b) - p;
      ef_(b) = ai_(b) * d.squaredNorm();
      if (grad && gamma_ != 0) grad->row(bi_.to_volume(b)) += (s * ai_(b)) * d;  // rows distinct
    }
    double e = 0;
    for (int b = 0; b < nb; ++b) e += ef_(b);
    t.projection_forward = e / si_;
    // E_P,b (Eq. 22): boundary vertices of M_j (rest) to the mapped boundary dF_i(X).
    if (bscale_ != 0 || all) {
      if (!mapped_built_) {
        mapped_boundary_.build(X, Fi_vol_);
        mapped_built_ = true;
      } else {
        mapped_boundary_.refit(X);
      }
      const int nbj = int(bj_.to_volume.size());
      const bool hinted_b = int(hits_b_.size()) == nbj;
      mapped_boundary_.query(bj_.surface.V, hits_b_, hinted_b);
      eb_.resize(nbj);
      const double sb = 2.0 * gamma_ * bscale_ / sj_;
      for (int b = 0; b < nbj; ++b) {  // serial scatter onto face corners (fixed order)
        const ClosestPointResult& r = hits_b_[b];
        Eigen::RowVector3d p = Eigen::RowVector3d::Zero();
        for (int c = 0; c < 3; ++c) p += r.bary(c) * X.row(Fi_vol_(r.elem, c));
        const Eigen::RowVector3d d = bj_.surface.V.row(b) - p;
        eb_(b) = aj_(b) * d.squaredNorm();
        if (grad && sb != 0)
          for (int c = 0; c < 3; ++c) grad->row(Fi_vol_(r.elem, c)) -= (sb * aj_(b) * r.bary(c)) * d;
      }
      double e2 = 0;
      for (int b = 0; b < nbj; ++b) e2 += eb_(b);
      t.projection_backward = e2 / sj_;
    }
  }
}

namespace {
// 2 × the Hessian of the squared distance to a closest point with barycentric coordinates b
// on triangle (p0, p1, p2), for the query moving and the triangle fixed: n n^T inside the
// face, I - e e^T on an edge (e its unit direction), I at a corner (and for a degenerate
// face).
Eigen::Matrix3d distance_hessian(const Eigen::Vector3d& b, const Eigen::Vector3d& p0,
                                 const Eigen::Vector3d& p1, const Eigen::Vector3d& p2) {
  constexpr double eps = 1e-9;
  const int inside = (b(0) > eps) + (b(1) > eps) + (b(2) > eps);
  if (inside == 3) {
    const Eigen::Vector3d n = (p1 - p0).cross(p2 - p0);
    const double l = n.norm();
    if (l > 0) return 2.0 * (n / l) * (n / l).transpose();
  } else if (inside == 2) {
    const Eigen::Vector3d& a = b(0) <= eps ? p1 : p0;
    const Eigen::Vector3d& c = b(2) <= eps ? p1 : p2;
    const Eigen::Vector3d e = c - a;
    const double l = e.norm();
    if (l > 0) return 2.0 * (Eigen::Matrix3d::Identity() - (e / l) * (e / l).transpose());
  }
  return 2.0 * Eigen::Matrix3d::Identity();
}
}  // namespace

void DirectionalEnergy::add_hessian(const Eigen::MatrixXd& X, BlockHessian& H) const {
  // The closest points of E_P belong to the last evaluation: make it this X.
  if (last_X_.rows() != X.rows() || last_X_ != X) evaluate(X);
  const int ni = Mi_.num_vertices(), nj = Mj_.num_vertices();
  if (alpha_ != 0) arap_.add_hessian(X, alpha_, H);  // Eq. 20
  if (barrier_) barrier_->add_hessian(X, 1.0, H);
  for (int v : anchor_rows_) H.add_diagonal(v, 2.0 * anchor_k_);
  // E_Q (Eq. 17): 2 beta/(c_i c_j) C_i(v) I per vertex.
  const double sq = 2.0 * beta_ / (ci_ * cj_);
  if (sq != 0)
    for (int v = 0; v < ni; ++v) H.add_diagonal(v, sq * Ci_(v));
  // E_R (Eq. 18, term (j,i)): row w of P_ji lies in tet P_ji.elem(w) of M_i, in its corner
  // order: 2(1-alpha)/c_j^2 C_j(w) (p p^T ⊗ I) on that tet's corners.
  const double sr = 2.0 * (1.0 - alpha_) / (cj_ * cj_);
  if (sr != 0) {
    Eigen::Matrix<double, 12, 12> He;
    for (int w = 0; w < nj; ++w) {
      He.setZero();
      const double s = sr * Cj_(w);
      for (int a = 0; a < 4; ++a)
        for (int b = 0; b < 4; ++b)
          He.block<3, 3>(3 * a, 3 * b).diagonal().setConstant(s * Pji_.bary(w, a) * Pji_.bary(w, b));
      H.add_element(Pji_.elem(w), He);
    }
  }
  if (gamma_ == 0) return;
  // E_P,f (Eq. 21): gamma/s_i a_b (distance Hessian at the closest point on dM_j).
  const int nb = int(bi_.to_volume.size());
  for (int b = 0; b < nb; ++b) {
    const ClosestPointResult& r = hits_f_[b];
    const Eigen::MatrixXi& Fj = bj_.surface.F;
    const Eigen::Matrix3d Hb =
        distance_hessian(r.bary.head<3>(), bj_.surface.V.row(Fj(r.elem, 0)).transpose(),
                         bj_.surface.V.row(Fj(r.elem, 1)).transpose(), bj_.surface.V.row(Fj(r.elem, 2)).transpose());
    H.add_block(bi_.to_volume(b), bi_.to_volume(b), (gamma_ * ai_(b) / si_) * Hb);
  }
  // E_P,b (Eq. 22): residual V_j(b) - sum_c bary_c X(face corner c), bary held.
  if (bscale_ == 0) return;
  const int nbj = int(bj_.to_volume.size());
  const double sb = gamma_ * bscale_ / sj_;
  for (int b = 0; b < nbj; ++b) {
    const ClosestPointResult& r = hits_b_[b];
    const int c0 = Fi_vol_(r.elem, 0), c1 = Fi_vol_(r.elem, 1), c2 = Fi_vol_(r.elem, 2);
    const Eigen::Matrix3d D = distance_hessian(r.bary.head<3>(), X.row(c0).transpose(), X.row(c1).transpose(),
                                               X.row(c2).transpose());
    const int c[3] = {c0, c1, c2};
    for (int p = 0; p < 3; ++p)
      for (int q = p; q < 3; ++q) {
        const double s = sb * aj_(b) * r.bary(p) * r.bary(q);
        if (s != 0) H.add_block(c[p], c[q], s * D);
      }
  }
}

// ---------------------------------------------------------------------------------
// Algorithm 1

namespace {

// P-step of one direction (Sec. 5.2): rows of P_ij are independent closest-point
// projections in R^6 onto M_j's tets with vertex coordinates [sqrt(a) X_ji, sqrt(b) V_j],
// of the points [sqrt(a) V_i, sqrt(b) X_ij]; a = (1-alpha)/c_i^2, b = beta/(c_i c_j).
class PStep {
 public:
  PStep(const TetMesh& Mi, const TetMesh& Mj, double ci, double cj)
      : Mi_(Mi), Mj_(Mj), ci_(ci), cj_(cj) {
    bj_ = boundary_surface(Mj);
    bi_ = boundary_surface(Mi);
  }
  void run(const Eigen::MatrixXd& Xij, const Eigen::MatrixXd& Xji, double alpha, double beta,
           bool boundary_to_boundary, const std::vector<char>* keep_rows,
           const BarycentricMap& P0, BarycentricMap& P) {
    const double a = std::sqrt(std::max(0.0, (1 - alpha) / (ci_ * ci_)));
    const double b = std::sqrt(std::max(0.0, beta / (ci_ * cj_)));
    const int nj = Mj_.num_vertices(), ni = Mi_.num_vertices();
    W_.resize(nj, 6);
    W_.leftCols(3) = a * Xji;
    W_.rightCols(3) = b * Mj_.V;
    if (!built_) {
      bvh_.build(W_, Mj_.T);
      if (boundary_to_boundary) bvh_bd_.build(W_, faces_in_volume_numbering(bj_));
      built_ = true;
    } else {
      bvh_.refit(W_);
      if (boundary_to_boundary) bvh_bd_.refit(W_);
    }
    Q_.resize(ni, 6);
    Q_.leftCols(3) = a * Mi_.V;
    Q_.rightCols(3) = b * Xij;
    // Hints: the previous P-step's answer for each row (the exact closest point is still
    // returned; a good hint only tightens the initial bound of the branch and bound). Rows
    // that line 10 restores below are not projected (stage 2: the boundary, about half the
    // rows).
    std::vector<ClosestPointResult>& r = hits_;
    const bool hinted = P.size() == ni;
    r.resize(ni);
    if (hinted)
      for (int v = 0; v < ni; ++v) r[v].elem = P.elem(v);
    bvh_.query(Q_, r, hinted, keep_rows);
    P.elem.resize(ni);
    P.bary.resize(ni, 4);
    for (int v = 0; v < ni; ++v) {
      if (keep_rows && (*keep_rows)[v]) continue;  // restored below
      P.elem(v) = r[v].elem;
      Eigen::Vector4d w = r[v].bary.cwiseMax(0.0);
      double s = w.sum();
      P.bary.row(v) = (s > 0 ? Eigen::Vector4d(w / s) : Eigen::Vector4d(1, 0, 0, 0)).transpose();
    }
    if (boundary_to_boundary) {
      const int nb = int(bi_.to_volume.size());
      Eigen::MatrixXd Qb(nb, 6);
      std::vector<char> skip_b(nb, 0);
      for (int q = 0; q < nb; ++q) {
        Qb.row(q) = Q_.row(bi_.to_volume(q));
        if (keep_rows) skip_b[q] = (*keep_rows)[bi_.to_volume(q)];
      }
      std::vector<ClosestPointResult> rb;
      bvh_bd_.query(Qb, rb, false, &skip_b);
      for (int q = 0; q < nb; ++q) {
        if (skip_b[q]) continue;
        int tet;
        Eigen::Vector4d w;
        face_to_tet(Mj_, bj_, rb[q].elem, rb[q].bary.head<3>(), tet, w);
        P.elem(bi_.to_volume(q)) = tet;
        P.bary.row(bi_.to_volume(q)) = w.transpose();
      }
    }
    if (keep_rows)  // Algorithm 1 line 10: restore the boundary map
      for (int v = 0; v < ni; ++v)
        if ((*keep_rows)[v]) {
          P.elem(v) = P0.elem(v);
          P.bary.row(v) = P0.bary.row(v);
        }
  }

 private:
  const TetMesh& Mi_;
  const TetMesh& Mj_;
  double ci_, cj_;
  TetBoundary bi_, bj_;
  ClosestPoint6 bvh_, bvh_bd_;
  bool built_ = false;
  Eigen::MatrixXd W_, Q_;
  std::vector<ClosestPointResult> hits_;
};

// Projected Newton over the free vertices of `pn`'s pattern (others fixed) on the X-step
// objective of one direction; the same result fields as minimize_rows.
using RowsValue = std::function<double(const Eigen::MatrixXd&, Eigen::MatrixXd*)>;
using RowsHessian = std::function<void(const Eigen::MatrixXd&, BlockHessian&)>;

LbfgsResult newton_rows(const RowsValue& value, const RowsHessian& hessian, ProjectedNewton& pn,
                        Eigen::MatrixXd& X, const NewtonOptions& o, double* profile = nullptr) {
  const std::vector<int>& rows = pn.hessian().free_vertices();
  const int k = int(rows.size());
  Eigen::MatrixXd Xf = X, G;
  auto scatter = [&](const Eigen::VectorXd& z) {
    for (int q = 0; q < k; ++q) Xf.row(rows[q]) = z.segment<3>(3 * q).transpose();
  };
  NewtonValue f = [&](const Eigen::VectorXd& z, Eigen::VectorXd* g) {
    scatter(z);
    const double v = value(Xf, g ? &G : nullptr);
    if (g)
      for (int q = 0; q < k; ++q) g->segment<3>(3 * q) = G.row(rows[q]).transpose();
    return v;
  };
  NewtonHessian h = [&](const Eigen::VectorXd& z, BlockHessian& H) {
    scatter(z);
    hessian(Xf, H);
  };
  Eigen::VectorXd x(3 * k);
  for (int q = 0; q < k; ++q) x.segment<3>(3 * q) = X.row(rows[q]).transpose();
  NewtonResult nr = pn.minimize(f, h, x, o);
  if (profile) {
    profile[0] += nr.seconds_value;
    profile[1] += nr.seconds_hessian;
    profile[2] += nr.seconds_factor;
    profile[3] += nr.seconds_solve;
  }
  for (int q = 0; q < k; ++q) X.row(rows[q]) = x.segment<3>(3 * q).transpose();
  LbfgsResult res;
  res.iterations = nr.iterations;
  res.evaluations = nr.evaluations;
  res.f = nr.f;
  res.grad_norm = nr.grad_norm;
  res.converged = nr.stop == "gradient" || nr.stop == "decrease";
  return res;
}

LbfgsResult newton_rows(const DirectionalEnergy& e, ProjectedNewton& pn, Eigen::MatrixXd& X,
                        const NewtonOptions& o, double* profile = nullptr) {
  return newton_rows([&](const Eigen::MatrixXd& Y, Eigen::MatrixXd* g) { return e.evaluate(Y, g); },
                     [&](const Eigen::MatrixXd& Y, BlockHessian& H) { e.add_hessian(Y, H); }, pn, X, o,
                     profile);
}

// Rows where Y differs from X.
std::vector<char> rows_moved(const Eigen::MatrixXd& X, const Eigen::MatrixXd& Y) {
  std::vector<char> moved(size_t(X.rows()), 0);
  for (Eigen::Index v = 0; v < X.rows(); ++v) moved[size_t(v)] = X.row(v) != Y.row(v);
  return moved;
}

int count_inverted(const ArapEnergy& arap, const Eigen::MatrixXd& X) {
  Eigen::VectorXd d = arap.determinants(X);
  int c = 0;
  for (int k = 0; k < d.size(); ++k) c += d(k) <= 0;
  return c;
}

// Vertices of inverted tets (det J <= 0), grown by `rings` rings; and the tets incident
// to them.
void inverted_neighbourhood(const ArapEnergy& arap, const Eigen::MatrixXd& X, int rings,
                            const std::vector<std::vector<int>>& vv,
                            const std::vector<std::vector<int>>& vt, std::vector<int>& verts,
                            std::vector<int>& tets) {
  const Eigen::MatrixXi& T = arap.tets();
  Eigen::VectorXd d = arap.determinants(X);
  std::vector<char> in(arap.num_vertices(), 0);
  for (int k = 0; k < d.size(); ++k)
    if (d(k) <= 0)
      for (int q = 0; q < 4; ++q) in[T(k, q)] = 1;
  for (int r = 0; r < rings; ++r) {
    std::vector<char> next = in;
    for (int v = 0; v < int(in.size()); ++v)
      if (in[v])
        for (int w : vv[v]) next[w] = 1;
    in.swap(next);
  }
  verts.clear();
  for (int v = 0; v < int(in.size()); ++v)
    if (in[v]) verts.push_back(v);
  std::vector<char> tin(T.rows(), 0);
  for (int v : verts)
    for (int k : vt[v]) tin[k] = 1;
  tets.clear();
  for (int k = 0; k < int(tin.size()); ++k)
    if (tin[k]) tets.push_back(k);
}


// Insets toward the target's interior of the landing (fractions of the way from the closest
// point on dM_j to the inner corner of the target tet behind it).
constexpr double kLandInset[] = {0.0, 0.02, 0.05, 0.1, 0.2, 0.4};
// The landing's local gamma round runs when at most this share of dM_j's vertices is uncovered.
constexpr double kLandUncoveredShare = 0.01;
constexpr double kPullInset = 0.05;  // pull_inside: anchors 5% of the way to their tet's centre
// A landing move keeps a tet if its det J stays above this (or above its det J before the
// move, when that is smaller): det J > 0 alone let the projection leave tets with four
// boundary corners at det J ~ 1e-15 (cat -> lion A -> B: 23 below 1e-6), flat in effect,
// and their barrier gradients (~1e13) stalled every later Newton step.
constexpr double kLandMinDet = 1e-3;
constexpr double kUntangleDepth = 0.25;  // see Landing::untangle_located
// Landing::lift_flat_tets: tets with det J in (-kFlatDet, 0] are flat, lifted to kLiftDet.
constexpr double kFlatDet = 1e-4, kLiftDet = 1e-4;
constexpr int kLiftRounds = 30;
// Landing::untangle_regularized: tets at or below this det J seed its regions (flat tets at
// det J ~ +-1e-15 come back from a map file with either sign).
constexpr double kRegularizedSeedDet = 1e-6;

// A boundary vertex v whose closest point p flattens some of its tets (typically slivers with
// four boundary corners, the other three already on one plane of dM_j): put v at p and, per
// tet that is not positive then, inset one of its other corners that lie on dM_j (the
// first corner and inset, in order, that makes the tet positive and keeps that corner's
// other tets positive). All moves are undone if a tet stays flat; returns whether v landed.
template <class Det, class TargetOf>
bool fit_by_insetting_neighbours(int v, const Eigen::RowVector3d& p, const Det& det,
                                 const Eigen::MatrixXi& T, const std::vector<std::vector<int>>& vt,
                                 const ClosestPoint3& target, const TargetOf& target_of,
                                 const std::vector<char>& on_bd, std::vector<char>& is_surface,
                                 Eigen::MatrixXd& X) {
  std::vector<std::pair<int, double>> bad;
  for (int k : vt[v])
    if (det(k) > 0) bad.emplace_back(k, det(k));  // positive before: the tets to keep positive
  auto kept = [&](int k, double before) { return det(k) > std::min(kLandMinDet, before); };
  const Eigen::RowVector3d x0 = X.row(v);
  X.row(v) = p;
  std::vector<std::pair<int, Eigen::RowVector3d>> moved;  // (corner, old position)
  for (const auto& [k, k_before] : bad) {
    if (kept(k, k_before)) continue;
    bool fixed = false;
    for (int c = 0; c < 4 && !fixed; ++c) {
      const int w = T(k, c);
      if (w == v || !on_bd[w]) continue;
      std::vector<std::pair<int, double>> keep;
      for (int kw : vt[w])
        if (kw != k && det(kw) > 0) keep.emplace_back(kw, det(kw));
      Eigen::MatrixXd q = X.row(w);
      Eigen::RowVector3d pw, apex;
      target_of(target.query(q)[0], pw, apex);
      const Eigen::RowVector3d xw = X.row(w);
      for (double s : kLandInset) {
        if (s == 0) continue;
        X.row(w) = (1 - s) * pw + s * apex;
        bool ok = kept(k, k_before);
        for (const auto& [kw, kw_before] : keep) ok = ok && kept(kw, kw_before);
        if (ok) {
          fixed = true;
          moved.emplace_back(w, xw);
          break;
        }
      }
      if (!fixed) X.row(w) = xw;
    }
    if (!fixed) break;
  }
  // A later inset may have turned an earlier tet of v over again: check them all.
  bool all = true;
  for (const auto& [k, k_before] : bad) all = all && kept(k, k_before);
  if (!all) {
    for (auto it = moved.rbegin(); it != moved.rend(); ++it) X.row(it->first) = it->second;
    X.row(v) = x0;
    return false;
  }
  for (const auto& m : moved) is_surface[m.first] = 0;
  return true;
}

// Mean length of each face's first edge: the landing's length scale on a boundary surface.
double mean_face_edge(const TriMesh& m) {
  double edge = 0;
  for (int f = 0; f < m.num_faces(); ++f) edge += (m.V.row(m.F(f, 0)) - m.V.row(m.F(f, 1))).norm();
  return edge / std::max(1, m.num_faces());
}

// det J of tet k of X.
double det_J(const ArapEnergy& arap, const Eigen::MatrixXd& X, int k) {
  const Eigen::MatrixXi& T = arap.tets();
  Eigen::Matrix3d Ds;
  for (int j = 0; j < 3; ++j) Ds.col(j) = (X.row(T(k, j + 1)) - X.row(T(k, 0))).transpose();
  return (Ds * arap.rest_inverse()[k]).determinant();
}

// Puts row v of X at p when its tets positive before stay so (det J above
// min(kLandMinDet, before), the projection's rule, and above `ratio` x before); returns
// whether it moved.
bool move_keeping_positive(const ArapEnergy& arap, const std::vector<std::vector<int>>& vt, Eigen::MatrixXd& X, int v,
                           const Eigen::RowVector3d& p, double ratio = 0) {
  std::vector<std::pair<int, double>> before;
  for (int k : vt[v]) {
    const double d = det_J(arap, X, k);
    if (d > 0) before.emplace_back(k, d);
  }
  const Eigen::RowVector3d x0 = X.row(v);
  X.row(v) = p;
  for (const auto& [k, d0] : before)
    if (!(det_J(arap, X, k) > std::max(ratio * d0, std::min(kLandMinDet, d0)))) {
      X.row(v) = x0;
      return false;
    }
  return true;
}

// The landing's projection with the barrier (ours): each of `rows` (boundary vertices of
// M_i, hits: their closest points on dM_j) goes to its closest point p, unless that would
// flatten or turn over one of its tets (det J <= 0, tets positive before; e.g. a tet with
// four boundary corners whose last corner would land on the plane of the other three).
// Then it goes to (1 - s) p + s a for the first s of `inset` that keeps them positive, a
// being the inner corner of the target tet whose boundary face holds p: a point inside that
// tet, which the map files hold exactly. If none does, the vertex stays and joins `failing`.
// One vertex at a time in the order of `rows` (deterministic). Rows put on dM_j are
// appended to on_surface.
void project_keeping_positive(const ArapEnergy& arap, const std::vector<std::vector<int>>& vt,
                              const std::vector<int>& rows, const TetMesh& Mj,
                              const TetBoundary& bj, const std::vector<ClosestPointResult>& hit,
                              const ClosestPoint3& target, const std::vector<char>& on_bd,
                              Eigen::MatrixXd& X, std::vector<int>& on_surface,
                              std::vector<int>& failing) {
  const Eigen::MatrixXi& T = arap.tets();
  auto det = [&](int k) { return det_J(arap, X, k); };
  // The closest point on dM_j and the inner corner of the target tet behind it.
  auto target_of = [&](const ClosestPointResult& h, Eigen::RowVector3d& p, Eigen::RowVector3d& apex) {
    boundary_point_and_apex(Mj, bj, h, p, apex);
  };
  std::vector<char> is_surface(X.rows(), 0);
  for (int v : on_surface) is_surface[v] = 1;
  std::vector<std::pair<int, double>> positive;  // (tet, det J before)
  failing.clear();
  for (size_t b = 0; b < rows.size(); ++b) {
    const int v = rows[b];
    positive.clear();
    for (int k : vt[v])
      if (det(k) > 0) positive.emplace_back(k, det(k));
    Eigen::RowVector3d p, apex;
    target_of(hit[b], p, apex);
    const Eigen::RowVector3d x0 = X.row(v);
    bool ok = false;
    for (double s : kLandInset) {
      X.row(v) = (1 - s) * p + s * apex;
      ok = true;
      for (const auto& [k, before] : positive) ok = ok && det(k) > std::min(kLandMinDet, before);
      if (ok) {
        if (s == 0) is_surface[v] = 1;
        break;
      }
    }
    if (ok) continue;
    // v at p or inset, with neighbours inset to make room.
    X.row(v) = x0;
    for (double s : kLandInset) {
      ok = fit_by_insetting_neighbours(v, (1 - s) * p + s * apex, det, T, vt, target, target_of, on_bd,
                                       is_surface, X);
      if (ok) {
        is_surface[v] = s == 0;
        break;
      }
    }
    if (!ok) failing.push_back(v);
  }
  on_surface.clear();  // rows on dM_j: those landed now or before, less the neighbours inset
  for (int w = 0; w < int(X.rows()); ++w)
    if (is_surface[w]) on_surface.push_back(w);
}

// The landing stage (ours, issue 19) for one direction i -> j, after stage 5: X's boundary
// is put on dM_j, so that X is exactly what the map files (barycentric coordinates in M_j's
// tets) hold.
//  1. gamma continuation: gamma raised in rounds with every vertex free (the boundary
//     slides toward dM_j, ARAP spreading the motion: on the glasses pair 2 rounds cut d^max
//     from 8.7/15.7 to 0.8/1.2 x1e-2 of the diagonal);
//  2. the boundary to its closest points on dM_j: with the inversion barrier (default), by
//     project_keeping_positive and passes that relax and retry the vertices left off;
//     without it, all at once;
//  3. the interior relaxed with the boundary held (Newton on the X-step objective);
//  4. a repair of inverted tets in which boundary vertices slide along dM_j;
//  5. the located map's inverted tets untangled with every image held in M_j;
//  6. flat tets on flat parts of dM_j lifted;
//  7. what is still inverted untangled by the regularized energy of Garanzha et al. 2021;
//  8. boundary vertices that steps 4-7 left inside M_j put back on dM_j where they can be.
// The located result replaces X unless it inverts more tets than X located as it was
// ("snapped"); `located` receives the chosen map and X its positions.
class Landing {
 public:
  Landing(DirectionalEnergy& e, const TetMesh& Mi, const TetMesh& Mj, const std::vector<int>& interior,
          const std::vector<std::vector<int>>& vv, const std::vector<std::vector<int>>& vt,
          const SymmetricVolumeMapOptions& opt, SymmetricMapStage& st)
      : e_(e), Mi_(Mi), Mj_(Mj), interior_(interior), vv_(vv), vt_(vt), opt_(opt), st_(st),
        bj_(e.boundary_j()), target_(bj_.surface.V, bj_.surface.F), locator_(Mj.V, Mj.T),
        barrier_(e.arap(), opt.land_barrier_floor) {
    const TetBoundary& bi = e.boundary_i();
    brows_.assign(bi.to_volume.data(), bi.to_volume.data() + bi.to_volume.size());
    on_bd_.assign(Mi.num_vertices(), 0);
    for (int v : brows_) on_bd_[v] = 1;
    no_.max_iterations = opt.land_newton_iterations;
    no_.f_rel_tol = opt.newton_rel_tol;
    no_.grad_tol = 0;
  }

  // Returns true when the landed X was kept.
  bool run(Eigen::MatrixXd& X, BarycentricMap& located) {
    const BarycentricMap snapped_map = locate_in_tets(Mj_, X, brows_);
    const Eigen::MatrixXd snapped = map_positions(snapped_map, Mj_.V, Mj_.T);
    barrier_.activate_positive(X);
    e_.set_barrier(opt_.land_barrier_floor > 0 ? &barrier_ : nullptr);
    continue_gamma(X);
    std::vector<int> surface_rows;  // located by snapping to dM_j
    if (opt_.land_barrier_floor > 0) {
      surface_rows = project_with_barrier(X);
    } else {
      const std::vector<ClosestPointResult> hit = target_.query(rows_of(X, brows_));
      for (size_t b = 0; b < brows_.size(); ++b) X.row(brows_[b]) = point_of(hit[b]);
      surface_rows = brows_;
    }
    relax(X, interior_, e_.gamma());
    if (opt_.land_barrier_floor > 0) pull_inside(X, surface_rows);
    e_.set_barrier(nullptr);
    // Located in M_j (interior images that still fall outside are snapped too) as it is, and
    // after the sliding repair when tets are inverted; the one of these and the snapped X
    // with the fewest inverted tets is kept (the repair has both lowered and raised the count
    // after the landing: busts A -> B 162 with it, 191 without; B -> A 1,508 with, 813 without).
    const ArapEnergy& arap = e_.arap();
    BarycentricMap best_map = snapped_map;
    Eigen::MatrixXd best = snapped;
    int best_count = count_inverted(arap, snapped);
    bool landed = false;
    auto consider = [&](const Eigen::MatrixXd& Y) {
      BarycentricMap m = locate_in_tets(Mj_, Y, surface_rows);
      Eigen::MatrixXd P = map_positions(m, Mj_.V, Mj_.T);
      const int c = count_inverted(arap, P);
      if (c <= best_count) {
        best_count = c;
        best_map = std::move(m);
        best = std::move(P);
        landed = true;
      }
    };
    consider(X);
    if (count_inverted(arap, X) > 0) {
      sliding_repair(X);
      consider(X);
    }
    if (landed && best_count > 0) {  // the located map's own inverted tets (snapped rows): cat -> lion B -> A 5 -> 3
      Eigen::MatrixXd Y = best;
      sliding_repair(Y);
      consider(Y);
    }
    if (landed && best_count > 0 && opt_.land_untangle_rounds > 0) {
      untangle_located(surface_rows, best_map, best, best_count);
      if (best_count > 0) lift_flat_tets(surface_rows, best_map, best, best_count);
    }
    if (landed && best_count > 0) untangle_regularized(surface_rows, best_map, best, best_count);
    if (landed) return_to_boundary(best_map, best);
    X = best;
    located = best_map;
    return landed;
  }

 private:
  static Eigen::MatrixXd rows_of(const Eigen::MatrixXd& X, const std::vector<int>& rows) {
    Eigen::MatrixXd Q(rows.size(), 3);
    for (size_t q = 0; q < rows.size(); ++q) Q.row(q) = X.row(rows[q]);
    return Q;
  }
  Eigen::RowVector3d point_of(const ClosestPointResult& h) const {
    Eigen::RowVector3d p = Eigen::RowVector3d::Zero();
    for (int c = 0; c < 3; ++c) p += h.bary(c) * bj_.surface.V.row(bj_.surface.F(h.elem, c));
    return p;
  }

  // Newton on the X-step objective over `free` (sorted), with gamma = g for its duration.
  void relax(Eigen::MatrixXd& X, const std::vector<int>& free, double g) {
    const double g0 = e_.gamma();
    e_.set_weights(e_.alpha(), e_.beta(), g, e_.backward_scale());
    ProjectedNewton pn(BlockHessian(Mi_.T, Mi_.num_vertices(), free));
    const LbfgsResult r = newton_rows(e_, pn, X, no_, st_.newton_seconds);
    e_.set_weights(e_.alpha(), e_.beta(), g0, e_.backward_scale());
    st_.lbfgs_iterations += r.iterations;
    st_.evaluations += r.evaluations;
  }

  // Step 1: gamma x land_gamma_factor per round, every vertex free (one symbolic analysis);
  // then, where the image does not cover dM_j, one more round there alone.
  void continue_gamma(Eigen::MatrixXd& X) {
    g_last_ = e_.gamma();
    if (opt_.land_gamma_rounds <= 0) return;
    std::vector<int> all(Mi_.num_vertices());
    for (int v = 0; v < int(all.size()); ++v) all[v] = v;
    ProjectedNewton pa(BlockHessian(Mi_.T, Mi_.num_vertices(), all));
    const double gamma = e_.gamma();
    auto round = [&]() {
      e_.set_weights(e_.alpha(), e_.beta(), g_last_, e_.backward_scale());
      const LbfgsResult rr = newton_rows(e_, pa, X, no_, st_.newton_seconds);
      st_.lbfgs_iterations += rr.iterations;
      st_.evaluations += rr.evaluations;
    };
    for (int r = 0; r < opt_.land_gamma_rounds; ++r) {
      g_last_ *= opt_.land_gamma_factor;
      round();
    }
    if (opt_.land_uncovered_edges > 0) {
      const TetBoundary& bi = e_.boundary_i();
      const double edge = mean_target_edge();
      std::vector<char> mi, mj;
      const int far = mark_uncovered(X, bi.surface.F, brows_, bj_.surface.V, bj_.surface.F,
                                     opt_.land_uncovered_edges * edge, 2, 3.0 * edge, mi, mj);
      // Local means few: where more of dM_j is uncovered the surfaces differ broadly (the
      // busts: 483 vertices, E_R x5 with the round), and the rounds above keep the balance.
      if (far > 0 && far <= kLandUncoveredShare * double(bj_.surface.V.rows())) {
        st_.land_uncovered += far;
        e_.emphasize_projection(mi, mj, opt_.land_gamma_factor);
        round();
        e_.emphasize_projection({}, {}, 1.0);
      }
    }
    e_.set_weights(e_.alpha(), e_.beta(), gamma, e_.backward_scale());
  }

  // Step 2 with the barrier. Passes: the vertices left off dM_j and their boundary
  // neighbours (which make room by sliding) relax with the interior (gamma at its last
  // continuation value), then try again. Returns the rows on dM_j.
  std::vector<int> project_with_barrier(Eigen::MatrixXd& X) {
    std::vector<int> surface_rows, failing, still;
    project_keeping_positive(e_.arap(), vt_, brows_, Mj_, bj_, target_.query(rows_of(X, brows_)), target_, on_bd_,
                             X, surface_rows, failing);
    std::vector<char> retry(Mi_.num_vertices(), 0);
    for (int pass = 0; pass < opt_.land_passes && !failing.empty(); ++pass) {
      std::fill(retry.begin(), retry.end(), 0);
      for (int v : failing) {
        retry[v] = 1;
        for (int w : vv_[v]) retry[w] = retry[w] || on_bd_[w];
      }
      failing.clear();
      for (int v = 0; v < Mi_.num_vertices(); ++v)
        if (retry[v]) failing.push_back(v);
      surface_rows.erase(std::remove_if(surface_rows.begin(), surface_rows.end(), [&](int v) { return retry[v] != 0; }),
                         surface_rows.end());
      std::vector<int> free = interior_;
      free.insert(free.end(), failing.begin(), failing.end());
      std::sort(free.begin(), free.end());
      relax(X, free, g_last_);
      project_keeping_positive(e_.arap(), vt_, failing, Mj_, bj_, target_.query(rows_of(X, failing)), target_,
                               on_bd_, X, surface_rows, still);
      failing.swap(still);
    }
    std::sort(surface_rows.begin(), surface_rows.end());
    st_.land_unprojected += int(brows_.size() - surface_rows.size());
    return surface_rows;
  }

  // Step 8 (ours), on the located map: boundary rows that the steps before left inside M_j
  // go back to dM_j, or toward it, where their tets stay positive as in the projection
  // (return_to_boundary.h); the map is located again.
  void return_to_boundary(BarycentricMap& best_map, Eigen::MatrixXd& best) {
    if (!opt_.land_return_rows) return;
    Eigen::MatrixXd Y = best;
    std::vector<int> rows;  // on dM_j afterwards
    const int moved = shapemap::return_to_boundary(
        Y, brows_, Mj_, bj_, target_, std::vector<double>(std::begin(kLandInset), std::end(kLandInset)),
        1e-9 * mean_target_edge(), [&](int v, const Eigen::RowVector3d& q) { return move_keeping_positive(Y, v, q); },
        rows);
    if (moved == 0) return;
    // Located in M_j: the rows of a tet that this turns over go back (locate_keeping_positive.h).
    const int back =
        take_rows_keeping_positive(e_.arap(), Mj_, locate_in_tets(Mj_, Y, rows), rows_moved(best, Y), best_map, best);
    if (back >= 0) st_.land_returned += std::max(0, moved - back);
  }

  bool move_keeping_positive(Eigen::MatrixXd& X, int v, const Eigen::RowVector3d& p) const {
    return shapemap::move_keeping_positive(e_.arap(), vt_, X, v, p);
  }

  // Step 3b: images still outside M_j after the projection (boundary vertices that no local
  // move put on or into M_j with their tets positive, and interior vertices pushed out with
  // them) are pulled to anchors just inside M_j (their closest point in M_j, moved 5% toward
  // the centre of its tet) by springs that stiffen each round, the interior and these
  // vertices free, the barrier on: located where they end, they need no snapping (the snap
  // turned 154 tets over on cat -> lion A -> B, 38 rows).
  void pull_inside(Eigen::MatrixXd& X, std::vector<int>& surface_rows) {
    std::vector<char> on_surface(Mi_.num_vertices(), 0), is_free(Mi_.num_vertices(), 0);
    for (int v : surface_rows) on_surface[v] = 1;
    // Eq. 21 weighs boundary vertex b by gamma a_b / s_i, gamma / n_boundary on average; the
    // springs start at 100x that and stiffen 10x per round up to 1e5x.
    const double k0 = 100.0 * g_last_ / double(std::max<size_t>(brows_.size(), 1));
    for (int round = 0; round < opt_.land_pull_rounds; ++round) {
      const std::vector<ClosestPointResult> r = locator_.locate(X);
      std::vector<int> out;
      for (int v = 0; v < Mi_.num_vertices(); ++v)
        if (!on_surface[v] && r[v].sqdist > 1e-20) out.push_back(v);
      if (out.empty()) break;
      Eigen::MatrixXd A(out.size(), 3);
      for (size_t q = 0; q < out.size(); ++q) {
        const ClosestPointResult& h = r[out[q]];
        Eigen::RowVector3d p = Eigen::RowVector3d::Zero(), c = Eigen::RowVector3d::Zero();
        for (int k = 0; k < 4; ++k) {
          p += h.bary(k) * Mj_.V.row(Mj_.T(h.elem, k));
          c += 0.25 * Mj_.V.row(Mj_.T(h.elem, k));
        }
        A.row(Eigen::Index(q)) = p + kPullInset * (c - p);
      }
      // Free: the interior, these rows and their neighbours (boundary neighbours make room;
      // they leave dM_j and are located, or snapped, where they end). Rings grown further,
      // or the neighbours put back on dM_j after each round, left more tets inverted on
      // cat -> lion (40 and 53 against 37).
      std::fill(is_free.begin(), is_free.end(), 0);
      for (int v : interior_) is_free[v] = 1;
      for (int v : out) {
        is_free[v] = 1;
        for (int w : vv_[v]) is_free[w] = 1;
      }
      std::vector<int> free;
      for (int v = 0; v < Mi_.num_vertices(); ++v)
        if (is_free[v]) free.push_back(v);
      e_.set_anchors(out, A, k0 * std::pow(10.0, std::min(round, 3)));
      relax(X, free, g_last_);
      e_.set_anchors({}, Eigen::MatrixXd(0, 3), 0);
      for (int v : free) on_surface[v] = on_surface[v] && !on_bd_[v];
    }
    surface_rows.erase(std::remove_if(surface_rows.begin(), surface_rows.end(), [&](int v) { return !on_surface[v]; }),
                       surface_rows.end());
  }

  // Step 5 (ours): the located map's inverted tets untangled where they are, every
  // position kept in M_j (untangle.h: max-min ascent of the tets' volumes; a boundary vertex
  // may leave dM_j for M_j's inside), kept when it inverts fewer tets. What the steps before
  // leave inverted is where images that no move put into M_j with their tets positive were
  // snapped into it (cat -> lion A -> B: 15 vertices 1e-4 to 5e-3 outside, 39 tets turned).
  void untangle_located(const std::vector<int>& surface_rows, BarycentricMap& best_map, Eigen::MatrixXd& best,
                        int& best_count) {
    Eigen::MatrixXd Y = best;
    UntangleRules rules;
    rules.boundary = [&](int i) { return on_bd_[i] != 0; };
    rules.place = [&](int, Eigen::RowVector3d& y) {  // the closest point of M_j
      const ClosestPointResult h = locator_.locate(Eigen::Vector3d(y.transpose()));
      if (!(h.sqdist > 0)) return;
      y.setZero();
      for (int k = 0; k < 4; ++k) y += h.bary(k) * Mj_.V.row(Mj_.T(h.elem, k));
    };
    rules.rings = opt_.land_untangle_rings;
    // Boundary vertices that only make room go into M_j at most kUntangleDepth mean edges of
    // dM_j deep (on the busts, let anywhere in M_j, they drifted inward and d^max rose from
    // 1.5 to 8.9 x1e-2; held on dM_j, 26 tets stayed inverted instead of 23).
    const double depth = kUntangleDepth * mean_target_edge();
    rules.place_boundary_ring = [&, depth](int i, Eigen::RowVector3d& y) {
      rules.place(i, y);
      const Eigen::RowVector3d p = point_of(target_.query(Eigen::Vector3d(y.transpose())));
      const double d = (y - p).norm();
      if (d > depth) y = p + (depth / d) * (y - p);
    };
    untangle_tets(e_.arap().tets(), rules, opt_.land_untangle_rounds, Y);
    keep_if_fewer(surface_rows, Y, best_map, best, best_count);
  }

  // Step 7 (ours): what is still inverted, untangled by the regularized energy of Garanzha
  // et al. 2021 (foldover_free.h) with 1, 2, 4, ... rings of vertices around it free, images
  // kept in M_j and boundary images near dM_j by springs; each result located and kept when
  // it inverts fewer tets. Wider rings let a fold of the boundary slide out (glasses A -> B,
  // the map files of the eighth session: 8 inverted tets, 3 with 1 ring, 0 with 8).
  void untangle_regularized(const std::vector<int>& surface_rows, BarycentricMap& best_map, Eigen::MatrixXd& best,
                            int& best_count) {
    const InTarget target{Mj_, bj_.surface, target_, locator_};
    for (int rings = 1; rings <= opt_.land_regularized_rings && best_count > 0; rings *= 2) {
      Eigen::MatrixXd Y = best;
      untangle_in_target(e_.arap(), vv_, on_bd_, target, rings, kRegularizedSeedDet, FoldoverFreeOptions{}, Y);
      keep_if_fewer(surface_rows, Y, best_map, best, best_count);
    }
  }

  double mean_target_edge() const { return mean_face_edge(bj_.surface); }

  // Y (a moved copy of the located `best`) located in M_j, rows that moved where they are now
  // and the others as before; it replaces best when it inverts fewer tets.
  void keep_if_fewer(const std::vector<int>& surface_rows, const Eigen::MatrixXd& Y, BarycentricMap& best_map,
                     Eigen::MatrixXd& best, int& best_count) const {
    std::vector<int> rows;
    for (int v : surface_rows)
      if (Y.row(v) == best.row(v)) rows.push_back(v);
    BarycentricMap m = locate_in_tets(Mj_, Y, rows);
    Eigen::MatrixXd P = map_positions(m, Mj_.V, Mj_.T);
    const int c = count_inverted(e_.arap(), P);
    if (c < best_count) {
      best_count = c;
      best_map = std::move(m);
      best = std::move(P);
    }
  }

  // Step 6 (ours): tets left flat on a flat part of dM_j (slivers of M_i with four boundary
  // corners, all four landed on one plane: det J ~ -1e-14) are lifted: a corner whose move
  // into M_j along dM_j's inner normal raises the tet's volume goes in by just enough for
  // det J = kLiftDet. That can flatten a neighbouring sliver the other way, whose own corner
  // then goes in: the moves cascade across the flat patch (heights only grow, as the lifting
  // of a Delaunay patch onto a paraboloid; rounds capped), and the state with the fewest
  // inverted tets is kept. The moves are ~1e-4 of a sliver's height, far below d^.
  void lift_flat_tets(const std::vector<int>& surface_rows, BarycentricMap& best_map, Eigen::MatrixXd& best,
                      int& best_count) {
    const ArapEnergy& arap = e_.arap();
    const Eigen::MatrixXi& T = arap.tets();
    auto vol = [&](const Eigen::MatrixXd& Y, int t) {
      return signed_tet_volume(Y.row(T(t, 0)), Y.row(T(t, 1)), Y.row(T(t, 2)), Y.row(T(t, 3)));
    };
    auto rest = [&](int t) {
      return signed_tet_volume(Mi_.V.row(T(t, 0)), Mi_.V.row(T(t, 1)), Mi_.V.row(T(t, 2)), Mi_.V.row(T(t, 3)));
    };
    const double depth = kUntangleDepth * mean_target_edge();
    Eigen::MatrixXd Y = best;
    int best_here = best_count;
    Eigen::MatrixXd best_Y = Y;
    for (int round = 0; round < kLiftRounds; ++round) {
      std::vector<int> flat;
      for (int t = 0; t < T.rows(); ++t) {
        const double v = vol(Y, t), r = rest(t);
        if (!(v > 0) && v > -kFlatDet * r) flat.push_back(t);
      }
      if (flat.empty()) break;
      for (int t : flat) {
        const double need = kLiftDet * rest(t) - vol(Y, t);
        if (need <= 0) continue;  // lifted by an earlier move of this round
        // Corners in order of the steepest rise along their inner normal; the first whose move
        // stays in M_j and within kUntangleDepth edges.
        static const int opp[4][3] = {{1, 3, 2}, {0, 2, 3}, {0, 3, 1}, {0, 1, 2}};
        std::vector<std::pair<double, int>> corners;  // (rate, corner)
        Eigen::RowVector3d u[4];
        for (int c = 0; c < 4; ++c) {
          const int w = T(t, c);
          if (!on_bd_[w]) continue;
          const ClosestPointResult h = target_.query(Eigen::Vector3d(Y.row(w).transpose()));
          const Eigen::MatrixXi& F = bj_.surface.F;
          const Eigen::RowVector3d a = bj_.surface.V.row(F(h.elem, 0)), b = bj_.surface.V.row(F(h.elem, 1)),
                                   d = bj_.surface.V.row(F(h.elem, 2));
          u[c] = -(b - a).cross(d - a).normalized();  // inward
          const Eigen::RowVector3d fa = Y.row(T(t, opp[c][0])), fb = Y.row(T(t, opp[c][1])), fc = Y.row(T(t, opp[c][2]));
          const double rate = u[c].dot((fb - fa).cross(fc - fa)) / 6.0;
          if (rate > 0) corners.emplace_back(rate, c);
        }
        std::sort(corners.begin(), corners.end(), std::greater<>());
        for (const auto& [rate, c] : corners) {
          if (need / rate > depth) continue;
          const Eigen::RowVector3d y = Y.row(T(t, c)) + (need / rate) * u[c];
          if (locator_.locate(Eigen::Vector3d(y.transpose())).sqdist > 0) continue;  // would leave M_j
          Y.row(T(t, c)) = y;
          break;
        }
      }
      const int c = count_inverted(arap, Y);
      if (c < best_here) {
        best_here = c;
        best_Y = Y;
      }
    }
    if (best_here < best_count) keep_if_fewer(surface_rows, best_Y, best_map, best, best_count);
  }

  // Step 4: repair of inverted tets (stage 5's energy, with the sigma penalty) in which
  // boundary vertices may slide: held near dM_j by a stiff closest-point spring, and near
  // where the round found them by a softer one (land_slide_anchor; without it they slid off
  // parts of dM_j and left them uncovered: glasses d^max 10%), and put back on dM_j after
  // each round. Interior vertices alone (the previous repair) left 133/231 inverted tets on
  // the glasses pair; sliding, 56/96 (d^max 1.6/1.7 x1e-2).
  void sliding_repair(Eigen::MatrixXd& X) {
    const ArapEnergy& arap = e_.arap();
    // Spring stiffness: 1e4 x the ARAP stiffness of a typical tet (weight w / edge^2), so the
    // springs stretch ~1% of an edge where ARAP pulls hardest.
    const double w_mean = arap.weights().mean();
    const double edge = std::cbrt(6.0 * std::sqrt(2.0) * 2.0 * w_mean * e_.volume_i());
    const double spring = 1e4 * w_mean / (edge * edge), anchor = opt_.land_slide_anchor * spring;
    for (int round = 0; round < opt_.post_repair_rounds; ++round) {
      std::vector<int> verts, tets, slide;
      inverted_neighbourhood(arap, X, opt_.repair_rings, vv_, vt_, verts, tets);
      if (verts.empty()) break;
      for (int v : verts)
        if (on_bd_[v]) slide.push_back(v);
      const Eigen::MatrixXd S0 = rows_of(X, slide);
      Eigen::MatrixXd S(slide.size(), 3);
      auto f = [&](const Eigen::MatrixXd& Y, Eigen::MatrixXd* g) {
        double E = arap.energy(Y, tets, g, opt_.post_repair_penalty);
        for (size_t q = 0; q < slide.size(); ++q) S.row(q) = Y.row(slide[q]);
        const std::vector<ClosestPointResult> c = target_.query(S);
        for (size_t q = 0; q < slide.size(); ++q) {
          E += spring * c[q].sqdist + anchor * (S.row(q) - S0.row(q)).squaredNorm();
          if (g)
            g->row(slide[q]) += 2.0 * spring * (S.row(q) - point_of(c[q])) + 2.0 * anchor * (S.row(q) - S0.row(q));
        }
        return E;
      };
      st_.iterations += minimize_rows(f, X, verts, opt_.post_repair_steps, opt_.lbfgs_memory).iterations;
      const std::vector<ClosestPointResult> c = target_.query(rows_of(X, slide));
      for (size_t q = 0; q < slide.size(); ++q) X.row(slide[q]) = point_of(c[q]);
    }
  }

  DirectionalEnergy& e_;
  const TetMesh &Mi_, &Mj_;
  const std::vector<int>& interior_;
  const std::vector<std::vector<int>>&vv_, &vt_;
  const SymmetricVolumeMapOptions& opt_;
  SymmetricMapStage& st_;
  const TetBoundary& bj_;
  ClosestPoint3 target_;
  TetLocator locator_;  // M_j's tets
  InversionBarrier barrier_;
  NewtonOptions no_;
  std::vector<int> brows_;
  std::vector<char> on_bd_;
  double g_last_ = 0;
};

}  // namespace

namespace {

// Algorithm 1 as a solver object: the state that lives across stages (both representations
// of both maps, the P-step BVHs, the X-step energies, the beta/gamma schedule) is held
// here, one method per stage.
class SymmetricMapSolver {
 public:
  SymmetricMapSolver(const TetMesh& A, const TetMesh& B, const BarycentricMap& init12,
                     const BarycentricMap& init21, const SymmetricVolumeMapOptions& opt,
                     const ProgressCallback& progress)
      : A_(A), B_(B), opt_(opt), progress_(progress),
        nA_(unit_volume_normalization(A)), nB_(unit_volume_normalization(B)),  // Sec. 5.5
        M1_{nA_.apply(A.V), A.T}, M2_{nB_.apply(B.V), B.T},
        e12_(M1_, M2_), e21_(M2_, M1_),
        p12_(M1_, M2_, e12_.volume_i(), e21_.volume_i()),
        p21_(M2_, M1_, e21_.volume_i(), e12_.volume_i()),
        P12_(init12), P21_(init21), P12_0_(init12), P21_0_(init21),  // lines 1-2
        X12_(map_positions(P12_, M2_.V, M2_.T)),                     // line 3
        X21_(map_positions(P21_, M1_.V, M1_.T)) {                    // line 4
    split_vertices(e12_, bd1_, all1_, int1_);
    split_vertices(e21_, bd2_, all2_, int2_);
    if (opt_.harmonic_interior) {  // ours, instead of Sec. 5.1's closest-boundary-vertex copy
      X12_ = harmonic_extension(M1_.V, M1_.T, X12_, bd1_);
      X21_ = harmonic_extension(M2_.V, M2_.T, X21_, bd2_);
    }
    vv1_ = vertex_neighbors(M1_.T, M1_.num_vertices());
    vv2_ = vertex_neighbors(M2_.T, M2_.num_vertices());
    vt1_ = vertex_elements(M1_.T, M1_.num_vertices());
    vt2_ = vertex_elements(M2_.T, M2_.num_vertices());
    beta_ = beta_at(0);
    gamma_ = gamma_at(0);
  }

  SymmetricVolumeMapResult run() {
    record_initial();                                                        // stage 1
    if (opt_.fix_boundary_first) alternate("boundary-fixed", true);          // stage 2
    repair("repair", opt_.repair_rings, opt_.repair_iterations, 1, 0, SigmaPenalty{0, 0});  // 3
    alternate("full", false);                                                // stage 4
    if (opt_.alpha_final >= 0 && opt_.alpha_final != opt_.alpha) reversible_continuation();  // ours
    repair("post-repair", 0, opt_.post_repair_steps, opt_.post_repair_rounds,
           opt_.post_repair_fallback_rings, opt_.post_repair_penalty);       // stage 5
    if (opt_.land_on_target) land();                                         // ours
    if (landed_both_ && opt_.land_interior_final && opt_.alpha_final >= 0 && opt_.alpha_final != opt_.alpha)
      relax_interiors_final();                                               // ours
    return finish();
  }

 private:
  // Boundary flags, all vertices, interior vertices of M_i.
  static void split_vertices(const DirectionalEnergy& e, std::vector<char>& bd,
                             std::vector<int>& all, std::vector<int>& interior) {
    const int n = e.arap().num_vertices();
    bd.assign(n, 0);
    for (int i = 0; i < e.boundary_i().to_volume.size(); ++i) bd[e.boundary_i().to_volume(i)] = 1;
    all.resize(n);
    for (int v = 0; v < n; ++v) {
      all[v] = v;
      if (!bd[v]) interior.push_back(v);
    }
  }

  // Sec. 4.4 / 5.5: beta from beta_start to beta_end over the ramp iterations, counted
  // across stages 2 and 4.
  double beta_at(int it) const {
    if (opt_.beta_ramp_iterations <= 0) return opt_.beta_end;
    const double t = std::min(1.0, double(it) / opt_.beta_ramp_iterations);
    return opt_.beta_start + (opt_.beta_end - opt_.beta_start) * t;
  }
  // gamma ramps with beta over the same iterations when gamma_start >= 0 (the authors'
  // released code: both from 1/N of their final values), else stays at gamma.
  double gamma_at(int it) const {
    if (opt_.gamma_start < 0 || opt_.beta_ramp_iterations <= 0) return opt_.gamma;
    const double t = std::min(1.0, double(it) / opt_.beta_ramp_iterations);
    return opt_.gamma_start + (opt_.gamma - opt_.gamma_start) * t;
  }
  // Newton iterations of this X-step (SymmetricVolumeMapOptions::newton_iterations_final).
  int newton_iterations_now(bool fix_boundary) const {
    const int end = std::max(0, opt_.beta_ramp_iterations);
    const bool final_weights = beta_ == beta_at(end) && gamma_ == gamma_at(end);
    return !fix_boundary && final_weights && opt_.newton_iterations_final > 0 ? opt_.newton_iterations_final
                                                                               : opt_.newton_iterations;
  }
  void set_weights() {
    e12_.set_weights(alpha_, beta_, gamma_, opt_.backward_projection_scale);
    e21_.set_weights(alpha_, beta_, gamma_, opt_.backward_projection_scale);
  }
  double energy() { return e12_.evaluate(X12_) + e21_.evaluate(X21_); }
  void count_inversions(SymmetricMapStage& st) const {
    st.inverted12 = count_inverted(e12_.arap(), X12_);
    st.inverted21 = count_inverted(e21_.arap(), X21_);
  }

  void record_initial() {
    SymmetricMapStage st;
    st.name = "init";
    set_weights();
    e12_.set_maps(P12_, P21_);
    e21_.set_maps(P21_, P12_);
    st.energy = energy();
    count_inversions(st);
    res_.stages.push_back(st);
  }

  // P-steps of both directions (Algorithm 1 lines 8 / 18; boundary rows restored in stage
  // 2, line 10), then the X-step energies take the new P.
  void p_steps(bool fix_boundary, SymmetricMapStage& st) { p_steps_at(X12_, X21_, fix_boundary, st); }
  // Both P-steps at the maps X12, X21 (the iterate's, or a Newton trial's).
  void p_steps_at(const Eigen::MatrixXd& X12, const Eigen::MatrixXd& X21, bool fix_boundary,
                  SymmetricMapStage& st) {
    const auto tp = Clock::now();
    if (memo_.holds(X12, X21, alpha_, beta_, fix_boundary, held12_, held21_)) {
      P12_ = memo_.P12;
      P21_ = memo_.P21;
    } else {
      // Independent (each reads both maps and writes its own P): at once, so that their
      // serial parts (the BVH refit, the conversion to barycentric rows) overlap.
      run_pair(
          [&] {
            p12_.run(X12, X21, alpha_, beta_, opt_.boundary_to_boundary, fix_boundary ? &bd1_ : nullptr,
                     *held12_, P12_);
          },
          [&] {
            p21_.run(X21, X12, alpha_, beta_, opt_.boundary_to_boundary, fix_boundary ? &bd2_ : nullptr,
                     *held21_, P21_);
          },
          two_threads_available());
      memo_.keep(X12, X21, alpha_, beta_, fix_boundary, held12_, held21_, P12_, P21_);
    }
    e12_.set_maps(P12_, P21_);
    e21_.set_maps(P21_, P12_);
    st.time_pstep += seconds_since(tp);
  }

  // X-steps of both directions (lines 9 / 19). Returns Eq. 25 and sets `grad_norm`.
  double x_steps(bool fix_boundary, ProjectedNewton* n12, ProjectedNewton* n21,
                 SymmetricMapStage& st, double& grad_norm) {
    const auto tx = Clock::now();
    LbfgsResult r1, r2;
    if (opt_.solver == XStepSolver::Newton) {
      NewtonOptions no;
      no.max_iterations = newton_iterations_now(fix_boundary);
      no.f_rel_tol = opt_.newton_rel_tol;
      no.max_expansions = fix_boundary ? opt_.boundary_fixed_expansions : 0;
      no.grad_tol = 0;
      // (Running the two directions on one thread each was 1.3x faster but not
      // reproducible run to run with the serial OpenBLAS, which is not safe from two threads.
      // These non-default paths stay serial, parallel inside; the joint X-step, the default,
      // factors the two directions at once: joint_x_step, CoupledNewton.)
      if (opt_.eliminate_p) {
        // Both directions start from the same X's and P's, as the fixed-P steps do, so that
        // swapping the inputs swaps the maps; then the P-steps at the new X's.
        Eigen::MatrixXd X12 = X12_;
        const BarycentricMap P12 = P12_, P21 = P21_;
        r1 = eliminated_p_x_step(0, fix_boundary, *n12, no, st);
        X12_.swap(X12);  // X12_ back at the start, X12 the new one
        P12_ = P12;
        P21_ = P21;
        r2 = eliminated_p_x_step(1, fix_boundary, *n21, no, st);
        X12_ = std::move(X12);
        P12_ = P12;  // the same hints for the P-steps whichever direction went first
        P21_ = P21;
        p_steps(fix_boundary, st);
      } else {
        r1 = newton_rows(e12_, *n12, X12_, no, st.newton_seconds);
        r2 = newton_rows(e21_, *n21, X21_, no, st.newton_seconds);
      }
    } else {
      auto f12 = [&](const Eigen::MatrixXd& X, Eigen::MatrixXd* g) { return e12_.evaluate(X, g); };
      auto f21 = [&](const Eigen::MatrixXd& X, Eigen::MatrixXd* g) { return e21_.evaluate(X, g); };
      r1 = minimize_rows(f12, X12_, fix_boundary ? int1_ : all1_, opt_.xstep_iterations, opt_.lbfgs_memory);
      r2 = minimize_rows(f21, X21_, fix_boundary ? int2_ : all2_, opt_.xstep_iterations, opt_.lbfgs_memory);
    }
    st.time_xstep += seconds_since(tx);
    st.lbfgs_iterations += r1.iterations + r2.iterations;
    st.evaluations += r1.evaluations + r2.evaluations;
    grad_norm = std::sqrt(r1.grad_norm * r1.grad_norm + r2.grad_norm * r2.grad_norm);
    // With the P's eliminated each f also holds terms of the other direction (its E_Q and
    // E_R at the trial's P's): sum Eq. 25 itself.
    return opt_.eliminate_p && opt_.solver == XStepSolver::Newton ? energy() : r1.f + r2.f;
  }

  // Ours (issue 19, SymmetricVolumeMapOptions::eliminate_p): the X-step of direction
  // `dir` on f(X_ij) = min over P_ij and P_ji of Eq. 25, X_ji held. Each value re-runs both
  // P-steps at the trial X_ij (each one's objective is every term of Eq. 25 with its P in
  // it); f's gradient is the fixed-P one and its Hessian takes the Schur complements
  // (DirectionalEnergy::add_eliminated_p_hessian). The P's are left at the last trial's:
  // the caller runs the P-steps at the new X's of both directions.
  LbfgsResult eliminated_p_x_step(int dir, bool fix_boundary, ProjectedNewton& pn, const NewtonOptions& no,
                                  SymmetricMapStage& st) {
    DirectionalEnergy& e = dir == 0 ? e12_ : e21_;
    DirectionalEnergy& other = dir == 0 ? e21_ : e12_;
    Eigen::MatrixXd& X = dir == 0 ? X12_ : X21_;
    const Eigen::MatrixXd& Xji = dir == 0 ? X21_ : X12_;
    const BarycentricMap& P = dir == 0 ? P12_ : P21_;
    const std::vector<char>* keep = fix_boundary ? (dir == 0 ? &bd1_ : &bd2_) : nullptr;
    const std::vector<char>* keep_ji = fix_boundary ? (dir == 0 ? &bd2_ : &bd1_) : nullptr;
    Eigen::MatrixXd P_at;  // the X that P holds the minimizer for
    auto update_p = [&](const Eigen::MatrixXd& Y) {
      if (P_at.rows() == Y.rows() && P_at == Y) return;
      if (dir == 0)
        p_steps_at(Y, Xji, fix_boundary, st);
      else
        p_steps_at(Xji, Y, fix_boundary, st);
      P_at = Y;
    };
    // Eq. 25 up to terms constant in X_ij (the other direction's E_ARAP and E_P)
    auto value = [&](const Eigen::MatrixXd& Y, Eigen::MatrixXd* g) {
      update_p(Y);
      return e.evaluate(Y, g) + other.weighted_map_terms(Xji);
    };
    auto hessian = [&](const Eigen::MatrixXd& Y, BlockHessian& H) {
      update_p(Y);
      e.add_hessian(Y, H);
      e.add_eliminated_p_hessian(Y, P, Xji, H, keep, keep_ji);
    };
    return newton_rows(value, hessian, pn, X, no, st.newton_seconds);
  }

  // Ours (issue 19, SymmetricVolumeMapOptions::joint_xstep): both X-steps as one projected
  // Newton step on Eq. 25 with both P's eliminated (coupled_newton.h). The X-step of each
  // direction alone holds the other's X, but P_ij's rows tie X_ij to X_ji (E_Q of one
  // direction, E_R of the other): moving X_ij(v) along with the corners of its image's tet
  // in X_ji costs little, and the two separate steps each see only half of that motion.
  // The coupling blocks (DirectionalEnergy::add_coupling) let one step take it whole.
  // Returns Eq. 25 at the new X's, with the P's at their minimizers there.
  double joint_x_step(bool fix_boundary, CoupledNewton& cn, SymmetricMapStage& st, double& grad_norm) {
    const auto tx = Clock::now();
    const std::vector<int>& rows1 = fix_boundary ? int1_ : all1_;
    const std::vector<int>& rows2 = fix_boundary ? int2_ : all2_;
    const int k1 = int(rows1.size()), k2 = int(rows2.size());
    const std::vector<char>* keep1 = fix_boundary ? &bd1_ : nullptr;
    const std::vector<char>* keep2 = fix_boundary ? &bd2_ : nullptr;
    Eigen::MatrixXd Y12 = X12_, Y21 = X21_, G12, G21;
    Eigen::VectorXd at;  // the z that the P's hold the minimizers for
    auto scatter_p = [&](const Eigen::VectorXd& z) {
      for (int q = 0; q < k1; ++q) Y12.row(rows1[q]) = z.segment<3>(3 * q).transpose();
      for (int q = 0; q < k2; ++q) Y21.row(rows2[q]) = z.segment<3>(3 * (k1 + q)).transpose();
      if (at.size() == z.size() && at == z) return;
      p_steps_at(Y12, Y21, fix_boundary, st);
      at = z;
    };
    NewtonValue f = [&](const Eigen::VectorXd& z, Eigen::VectorXd* g) {
      scatter_p(z);
      double E12 = 0, E21 = 0;  // the two directions' terms are independent: at once
      run_pair([&] { E12 = e12_.evaluate(Y12, g ? &G12 : nullptr); },
               [&] { E21 = e21_.evaluate(Y21, g ? &G21 : nullptr); }, two_threads_available());
      const double E = E12 + E21;
      if (g) {
        for (int q = 0; q < k1; ++q) g->segment<3>(3 * q) = G12.row(rows1[q]).transpose();
        for (int q = 0; q < k2; ++q) g->segment<3>(3 * (k1 + q)) = G21.row(rows2[q]).transpose();
      }
      return E;
    };
    std::vector<Eigen::Triplet<double>> entries;
    CoupledHessian h = [&](const Eigen::VectorXd& z, BlockHessian& H1, BlockHessian& H2,
                           Eigen::SparseMatrix<double>& C) {
      scatter_p(z);
      // The two blocks read both maps and write their own: at once (their assembly is
      // serial in part).
      run_pair(
          [&] {
            e12_.add_hessian(Y12, H1);
            e12_.add_eliminated_p_hessian(Y12, P12_, Y21, H1, keep1, keep2);
          },
          [&] {
            e21_.add_hessian(Y21, H2);
            e21_.add_eliminated_p_hessian(Y21, P21_, Y12, H2, keep2, keep1);
          },
          two_threads_available());
      entries.clear();
      // C's rows: free vertices of M1 (X12), columns: of M2 (X21).
      auto put = [&](int r1, int c2, const Eigen::Matrix3d& B) {
        const int fr = H1.free_index(r1), fc = H2.free_index(c2);
        if (fr < 0 || fc < 0) return;
        for (int a = 0; a < 3; ++a)
          for (int b = 0; b < 3; ++b) entries.emplace_back(3 * fr + a, 3 * fc + b, B(a, b));
      };
      e12_.add_coupling(P12_, Y21, keep1, [&](int v, int k, const Eigen::Matrix3d& B) { put(v, k, B); });
      e21_.add_coupling(P21_, Y12, keep2,
                        [&](int w, int k, const Eigen::Matrix3d& B) { put(k, w, B.transpose()); });
      C.resize(3 * k1, 3 * k2);
      C.setFromTriplets(entries.begin(), entries.end());
    };
    Eigen::VectorXd z(3 * (k1 + k2));
    for (int q = 0; q < k1; ++q) z.segment<3>(3 * q) = X12_.row(rows1[q]).transpose();
    for (int q = 0; q < k2; ++q) z.segment<3>(3 * (k1 + q)) = X21_.row(rows2[q]).transpose();
    CoupledNewtonOptions no;
    no.newton.max_iterations = newton_iterations_now(fix_boundary);
    no.newton.f_rel_tol = opt_.newton_rel_tol;
    no.newton.max_expansions = fix_boundary ? opt_.boundary_fixed_expansions : 0;
    no.newton.grad_tol = 0;
    no.newton.refactor_cg = opt_.newton_refactor_cg;
    no.newton.cg_rel_tol = opt_.newton_cg_rel_tol;
    const NewtonResult nr = cn.minimize(f, h, z, no);
    scatter_p(z);
    X12_ = Y12;
    X21_ = Y21;
    p_steps(fix_boundary, st);  // the P's at the new X's (the last trial may have been rejected)
    st.newton_seconds[0] += nr.seconds_value;
    st.newton_seconds[1] += nr.seconds_hessian;
    st.newton_seconds[2] += nr.seconds_factor;
    st.newton_seconds[3] += nr.seconds_solve;
    st.time_xstep += seconds_since(tx);
    st.lbfgs_iterations += nr.iterations;
    st.evaluations += nr.evaluations;
    st.cg_iterations += cn.cg_iterations();
    st.factorizations += nr.factorizations;
    grad_norm = nr.grad_norm;
    return energy();
  }

  Eigen::VectorXd pack() const {
    Eigen::VectorXd x(X12_.size() + X21_.size());
    x << Eigen::Map<const Eigen::VectorXd>(X12_.data(), X12_.size()),
        Eigen::Map<const Eigen::VectorXd>(X21_.data(), X21_.size());
    return x;
  }
  void unpack(const Eigen::VectorXd& x) {
    Eigen::Map<Eigen::VectorXd>(X12_.data(), X12_.size()) = x.head(X12_.size());
    Eigen::Map<Eigen::VectorXd>(X21_.data(), X21_.size()) = x.tail(X21_.size());
  }

  // Stages 2 and 4: alternating P- and X-steps until a stopping rule of Sec. 5.4. With
  // anderson_memory > 0 (ours), once the weights are final the next X is Anderson's
  // extrapolation of the alternation; it is kept if Eq. 25 after its P-step is below the
  // last X-step's energy (which the plain next iterate never exceeds: the P-step is an exact
  // minimization), else the plain iterate is restored.
  void alternate(const std::string& name, bool fix_boundary) {
    SymmetricMapStage st;
    st.name = name;
    const auto t0 = Clock::now();
    double E_prev = std::numeric_limits<double>::infinity();
    double beta_prev = -1;  // beta of E_prev: the decrease rule compares energies of one Eq. 25
    // Newton: one pattern (and CHOLMOD analysis) per direction for the whole stage.
    std::unique_ptr<ProjectedNewton> n12, n21;
    std::unique_ptr<CoupledNewton> joint;
    if (opt_.solver == XStepSolver::Newton) {
      BlockHessian h12(M1_.T, M1_.num_vertices(), fix_boundary ? int1_ : all1_);
      BlockHessian h21(M2_.T, M2_.num_vertices(), fix_boundary ? int2_ : all2_);
      if (opt_.eliminate_p && opt_.joint_xstep) {
        joint = std::make_unique<CoupledNewton>(std::move(h12), std::move(h21));
      } else {
        n12 = std::make_unique<ProjectedNewton>(std::move(h12));
        n21 = std::make_unique<ProjectedNewton>(std::move(h21));
      }
    }
    AndersonAcceleration aa(opt_.anderson_memory);
    Eigen::VectorXd plain;  // G(x_k) when X holds an accelerated proposal
    const int max_iterations =
        opt_.max_iterations * (fix_boundary ? std::max(1, opt_.boundary_fixed_iteration_factor) : 1);
    for (int it = 0; it < max_iterations; ++it) {
      beta_ = beta_at(global_iter_);
      gamma_ = gamma_at(global_iter_);
      set_weights();
      p_steps(fix_boundary, st);
      if (plain.size() > 0) {  // guard the accelerated proposal
        if (energy() < E_prev) {
          ++st.anderson_accepted;
        } else {
          ++st.anderson_rejected;
          unpack(plain);
          p_steps(fix_boundary, st);
        }
        plain.resize(0);
      }
      const Eigen::VectorXd x_k = opt_.anderson_memory > 0 ? pack() : Eigen::VectorXd();
      double gn = 0;
      const double E = joint ? joint_x_step(fix_boundary, *joint, st, gn) : x_steps(fix_boundary, n12.get(), n21.get(), st, gn);
      ++global_iter_;
      ++st.iterations;
      st.energy = E;
      report(progress_, "volume-map/" + name, double(it + 1) / max_iterations);
      st.energy_history.push_back(E);
      st.gradient_history.push_back(gn);
      const bool ramp_done = beta_at(global_iter_) == beta_ && gamma_at(global_iter_) == gamma_;
      if (it + 1 >= opt_.min_iterations) {
        if (gn < opt_.grad_tol) {
          st.stop_reason = "gradient";
          break;
        }
        // Only once beta is final, and between two iterations at that beta: the first
        // iteration at beta_end has a larger E_Q weight than the one before (E rises).
        if (ramp_done && beta_prev == beta_ &&
            E_prev - E < std::max(opt_.decrease_tol, opt_.decrease_rel_tol * std::abs(E))) {
          st.stop_reason = "decrease";
          break;
        }
      }
      E_prev = E;
      beta_prev = beta_;
      if (it + 1 == max_iterations) {
        st.stop_reason = "iterations";
      } else if (opt_.anderson_memory > 0 && ramp_done) {
        plain = pack();
        unpack(aa.step(x_k, plain));
      } else {
        aa.reset();  // the fixed-point map changes with the weights
      }
    }
    count_inversions(st);
    st.seconds = seconds_since(t0);
    res_.iterations += st.iterations;
    res_.stages.push_back(st);
  }

  // Stages 3 and 5: ARAP only on the neighbourhood of inverted tets (Sec. 5.3).
  // fallback_rings > rings: rounds on that wider neighbourhood when the first ones leave
  // inverted tets, and the stage is undone (per direction) unless it lowered their number
  // (stage 5 only, see SymmetricVolumeMapOptions::post_repair_fallback_rings).
  void repair(const std::string& name, int rings, int steps, int rounds, int fallback_rings,
              const SigmaPenalty& pen) {
    SymmetricMapStage st;
    st.name = name;
    const auto t0 = Clock::now();
    for (int dir = 0; dir < 2; ++dir) {
      const ArapEnergy& arap = dir == 0 ? e12_.arap() : e21_.arap();
      Eigen::MatrixXd& X = dir == 0 ? X12_ : X21_;
      // Stage 5 must not leave more inverted tets than it found (ARAP alone does not keep
      // tets positive: moving the corners of one inverted tet can turn its neighbours over).
      const int inverted_start = fallback_rings > 0 ? count_inverted(arap, X) : 0;
      const Eigen::MatrixXd X_start = inverted_start > 0 ? X : Eigen::MatrixXd();
      const int total_rounds = fallback_rings > rings ? 2 * rounds : rounds;
      for (int round = 0; round < total_rounds; ++round) {
        std::vector<int> verts, tets;
        inverted_neighbourhood(arap, X, round < rounds ? rings : fallback_rings,
                               dir == 0 ? vv1_ : vv2_, dir == 0 ? vt1_ : vt2_, verts, tets);
        if (verts.empty()) break;
        auto f = [&](const Eigen::MatrixXd& Y, Eigen::MatrixXd* g) { return arap.energy(Y, tets, g, pen); };
        st.iterations += minimize_rows(f, X, verts, steps, opt_.lbfgs_memory).iterations;
      }
      if (fallback_rings > 0 && inverted_start > 0 && count_inverted(arap, X) >= inverted_start)
        X = X_start;
    }
    set_weights();
    st.energy = energy();
    count_inversions(st);
    st.seconds = seconds_since(t0);
    res_.stages.push_back(st);
    report(progress_, "volume-map/" + name, 1.0);
  }

  // Ours (issue 19): the map files hold barycentric coordinates in the target's tets, so a
  // boundary that the penalty gamma E_P left off the target would be snapped into it after
  // the fact, inverting tets there (5-20x more than X had, on real pairs). Instead the
  // boundary of X is put on the target's boundary (land_on_target), and X and the map
  // files are one map.
  void land() {
    SymmetricMapStage st;
    st.name = "land-on-target";
    const auto t0 = Clock::now();
    set_weights();
    // The two directions are independent (each its own energy, X and map files), and their
    // Newton steps' factorizations dominate: on two threads when the BLAS allows it.
    SymmetricMapStage part[2];
    bool landed[2] = {false, false};
    auto land_direction = [&](int dir) {
      Landing landing(dir == 0 ? e12_ : e21_, dir == 0 ? M1_ : M2_, dir == 0 ? M2_ : M1_, dir == 0 ? int1_ : int2_,
                      dir == 0 ? vv1_ : vv2_, dir == 0 ? vt1_ : vt2_, opt_, part[dir]);
      landed[dir] = landing.run(dir == 0 ? X12_ : X21_, dir == 0 ? final12_ : final21_);
    };
    run_pair([&] { land_direction(0); }, [&] { land_direction(1); }, factorizations_in_parallel());
    landed_both_ = landed[0] && landed[1];
    if (landed_both_) st.land_reconciled = reconcile_boundaries();
    for (int dir = 0; dir < 2; ++dir) {
      st.iterations += part[dir].iterations;
      st.lbfgs_iterations += part[dir].lbfgs_iterations;
      st.evaluations += part[dir].evaluations;
      st.land_unprojected += part[dir].land_unprojected;
      st.land_returned += part[dir].land_returned;
      st.land_uncovered += part[dir].land_uncovered;
      for (int k = 0; k < 4; ++k) st.newton_seconds[k] += part[dir].newton_seconds[k];
      st.stop_reason += std::string(dir == 0 ? "AB " : ", BA ") +
                        (landed[dir] ? "landed" : "snapped (landing inverted more)");
    }
    st.energy = energy();
    count_inversions(st);
    st.seconds = seconds_since(t0);
    res_.stages.push_back(st);
    report(progress_, "volume-map/land-on-target", 1.0);
  }

  // Ours, the landing's end: the two maps' boundaries made mutually inverse by
  // land_reconcile_rounds of reconcile_boundary_step, each move kept where the moved
  // vertex's tets keep land_reconcile_det of their det J, their ARAP energy (Eq. 20) rises
  // by at most land_reconcile_arap of itself, and the target stays covered
  // (land_reconcile_gap, target_coverage.h); per round each map is located again and kept
  // when it inverts no more tets than before. Returns the moves kept.
  int reconcile_boundaries() {
    const TetBoundary& b1 = e12_.boundary_i();
    const TetBoundary& b2 = e12_.boundary_j();
    const ClosestPoint3 on1(b1.surface.V, b1.surface.F), on2(b2.surface.V, b2.surface.F);
    const double edge = 0.5 * (mean_face_edge(b1.surface) + mean_face_edge(b2.surface));
    auto on_target = [&](const TetBoundary& b, const Eigen::MatrixXd& X, const ClosestPoint3& target) {
      std::vector<char> on(X.rows(), 0);
      Eigen::MatrixXd Q(b.to_volume.size(), 3);
      for (Eigen::Index r = 0; r < Q.rows(); ++r) Q.row(r) = X.row(b.to_volume(r));
      const std::vector<ClosestPointResult> h = target.query(Q);
      for (Eigen::Index r = 0; r < Q.rows(); ++r) on[b.to_volume(r)] = h[size_t(r)].sqdist <= 1e-18 * edge * edge;
      return on;
    };
    auto project = [](const ClosestPoint3& target) {
      return [&target](const Eigen::RowVector3d& x) {
        const ClosestPointResult h = target.query(Eigen::Vector3d(x.transpose()));
        Eigen::RowVector3d p = Eigen::RowVector3d::Zero();
        for (int c = 0; c < 3; ++c) p += h.bary(c) * target.vertices().row(target.elements()(h.elem, c));
        return p;
      };
    };
    std::vector<std::pair<int, Eigen::RowVector3d>> moves12, moves21;
    int kept = 0;
    for (int round = 0; round < opt_.land_reconcile_rounds; ++round) {
      const std::vector<char> on12 = on_target(b1, X12_, on2), on21 = on_target(b2, X21_, on1);
      reconcile_boundary_step(BoundaryMapSide{M1_.V, b1, X12_, on12}, BoundaryMapSide{M2_.V, b2, X21_, on21},
                              project(on1), project(on2), moves12, moves21);
      // The two maps' moves are independent (each reads and writes its own map): at once.
      int moved12 = 0, moved21 = 0;
      auto apply = [&](const std::vector<std::pair<int, Eigen::RowVector3d>>& moves, const ArapEnergy& arap,
                       const std::vector<std::vector<int>>& vt, const TetMesh& Mj, const TetBoundary& bi,
                       const TetBoundary& bj, const std::vector<char>& on, Eigen::MatrixXd& X,
                       BarycentricMap& located, int& moved) {
        Eigen::MatrixXd Y = X;
        const std::vector<int> brows(bi.to_volume.data(), bi.to_volume.data() + bi.to_volume.size());
        TargetCoverage coverage(Y, bi.surface.F, brows, bj.surface.V);
        int n = 0;
        for (const auto& [v, p] : moves)
          n += coverage.move(Y, coverage.surface_vertex(v),
                             [&, v = v, p = p](int) {
                               const double e0 = arap.energy(Y, vt[v], nullptr);
                               const Eigen::RowVector3d y0 = Y.row(v);
                               if (!move_keeping_positive(arap, vt, Y, v, p, opt_.land_reconcile_det)) return false;
                               if (arap.energy(Y, vt[v], nullptr) > (1 + opt_.land_reconcile_arap) * e0) {
                                 Y.row(v) = y0;
                                 return false;
                               }
                               return true;
                             },
                             opt_.land_reconcile_gap * edge);
        if (n == 0) return;
        std::vector<int> rows;
        for (Eigen::Index r = 0; r < bi.to_volume.size(); ++r)
          if (on[bi.to_volume(r)]) rows.push_back(bi.to_volume(r));
        // Located in M_j: the rows of a tet that this turns over go back (locate_keeping_positive.h).
        const int back =
            take_rows_keeping_positive(arap, Mj, locate_in_tets(Mj, Y, rows), rows_moved(X, Y), located, X);
        if (back >= 0) moved += std::max(0, n - back);
      };
      run_pair([&] { apply(moves12, e12_.arap(), vt1_, M2_, b1, b2, on12, X12_, final12_, moved12); },
               [&] { apply(moves21, e21_.arap(), vt2_, M1_, b2, b1, on21, X21_, final21_, moved21); },
               two_threads_available());
      kept += moved12 + moved21;
      if (moved12 + moved21 == 0) break;
    }
    return kept;
  }

  // Ours, after the landing (SymmetricVolumeMapOptions::land_interior_final): the landing
  // relaxed each interior at alpha with the other map held, and the reconciliation moved the
  // boundaries alone; so both interiors relax together at alpha_final (the stage-2 loop of
  // joint X-steps: boundaries held, P's boundary rows the map files'), with the inversion
  // barrier on. Each direction is located again and kept unless it inverts more tets.
  void relax_interiors_final() {
    InversionBarrier b12(e12_.arap(), opt_.land_barrier_floor), b21(e21_.arap(), opt_.land_barrier_floor);
    if (opt_.land_barrier_floor > 0) {
      b12.activate_positive(X12_);
      b21.activate_positive(X21_);
      e12_.set_barrier(&b12);
      e21_.set_barrier(&b21);
    }
    const Eigen::MatrixXd X12 = X12_, X21 = X21_;
    held12_ = &final12_;
    held21_ = &final21_;
    memo_ = {};  // the held rows' contents are not in its key
    alpha_ = opt_.alpha_final;
    alternate("interior-reversible", true);
    alpha_ = opt_.alpha;
    held12_ = &P12_0_;
    held21_ = &P21_0_;
    memo_ = {};
    e12_.set_barrier(nullptr);
    e21_.set_barrier(nullptr);
    SymmetricMapStage& st = res_.stages.back();
    st.relocated12 = relocate_interior(e12_.arap(), M2_, int1_, X12, X12_, final12_);
    st.relocated21 = relocate_interior(e21_.arap(), M1_, int2_, X21, X21_, final21_);  // locate_keeping_positive.h
    count_inversions(st);
  }

  // Stage 4 again at alpha_final from the map it converged to (SymmetricVolumeMapOptions::
  // alpha_final); stage 5 and the landing at alpha: at alpha_final they left a part of the
  // target's boundary uncovered on cat -> lion (d^max 2.5x, docs/methods.md).
  void reversible_continuation() {
    alpha_ = opt_.alpha_final;
    alternate("full-reversible", false);
    alpha_ = opt_.alpha;
  }

  // Final Eq. 25 terms (unit-volume frame), outputs in the targets' original coordinates.
  SymmetricVolumeMapResult finish() {
    set_weights();
    e12_.set_maps(P12_, P21_);
    e21_.set_maps(P21_, P12_);
    DirectionalEnergy::Terms t1, t2;
    res_.E = e12_.evaluate(X12_, nullptr, &t1) + e21_.evaluate(X21_, nullptr, &t2);
    res_.E_arap = t1.arap + t2.arap;
    res_.E_R = t1.reversibility + t2.reversibility;
    res_.E_P = t1.projection_forward + t2.projection_forward +
               opt_.backward_projection_scale * (t1.projection_backward + t2.projection_backward);
    res_.E_Q = t1.auxiliary + t2.auxiliary;
    res_.P12 = P12_;
    res_.P21 = P21_;
    if (opt_.land_on_target) {  // X is the map files' positions: the same numbers, unscaled
      res_.map12 = final12_;
      res_.map21 = final21_;
      res_.X12 = map_positions(final12_, B_.V, B_.T);
      res_.X21 = map_positions(final21_, A_.V, A_.T);
    } else {
      res_.X12 = nB_.undo(X12_);
      res_.X21 = nA_.undo(X21_);
      std::vector<int> b1, b2;
      for (int v = 0; v < int(bd1_.size()); ++v)
        if (bd1_[v]) b1.push_back(v);
      for (int v = 0; v < int(bd2_.size()); ++v)
        if (bd2_[v]) b2.push_back(v);
      res_.map12 = locate_in_tets(B_, res_.X12, b1);
      res_.map21 = locate_in_tets(A_, res_.X21, b2);
    }
    return std::move(res_);
  }

  const TetMesh& A_;
  const TetMesh& B_;
  const SymmetricVolumeMapOptions& opt_;
  const ProgressCallback& progress_;
  Normalization nA_, nB_;
  TetMesh M1_, M2_;  // unit volume
  DirectionalEnergy e12_, e21_;
  PStep p12_, p21_;
  BarycentricMap P12_, P21_;
  const BarycentricMap P12_0_, P21_0_;
  // P's boundary rows in stages with the boundary fixed: the initial map's (stage 2), the
  // map files' (relax_interiors_final).
  const BarycentricMap* held12_ = &P12_0_;
  const BarycentricMap* held21_ = &P21_0_;
  // The last P-steps' inputs and answers (speed): each outer iteration's line 8 and the first
  // value of its X-step ask again at the X's where the previous X-step's last P-steps ran.
  // (Not bit for bit the same as running them again: a run takes the current P as its hint,
  // and the hinted tet wins a tie, docs/methods.md.)
  struct PStepMemo {
    Eigen::MatrixXd X12, X21;
    double alpha = -1, beta = -1;
    bool fix_boundary = false;
    const BarycentricMap *held12 = nullptr, *held21 = nullptr;
    BarycentricMap P12, P21;
    bool holds(const Eigen::MatrixXd& x12, const Eigen::MatrixXd& x21, double a, double b, bool fixed,
               const BarycentricMap* h12, const BarycentricMap* h21) const {
      return a == alpha && b == beta && fixed == fix_boundary && h12 == held12 && h21 == held21 &&
             x12.rows() == X12.rows() && x21.rows() == X21.rows() && x12 == X12 && x21 == X21;
    }
    void keep(const Eigen::MatrixXd& x12, const Eigen::MatrixXd& x21, double a, double b, bool fixed,
              const BarycentricMap* h12, const BarycentricMap* h21, const BarycentricMap& p12,
              const BarycentricMap& p21) {
      X12 = x12;
      X21 = x21;
      alpha = a;
      beta = b;
      fix_boundary = fixed;
      held12 = h12;
      held21 = h21;
      P12 = p12;
      P21 = p21;
    }
  } memo_;
  Eigen::MatrixXd X12_, X21_;
  std::vector<char> bd1_, bd2_;
  std::vector<int> all1_, all2_, int1_, int2_;
  std::vector<std::vector<int>> vv1_, vv2_, vt1_, vt2_;
  int global_iter_ = 0;
  double beta_ = 0, gamma_ = 0;
  double alpha_ = opt_.alpha;  // Eq. 25's alpha now (SymmetricVolumeMapOptions::alpha_final)
  BarycentricMap final12_, final21_;  // the map files when landing
  bool landed_both_ = false;
  SymmetricVolumeMapResult res_;
};

}  // namespace

SymmetricVolumeMapResult symmetric_volume_map(const TetMesh& A, const TetMesh& B,
                                              const BarycentricMap& init12,
                                              const BarycentricMap& init21,
                                              const SymmetricVolumeMapOptions& opt,
                                              const ProgressCallback& progress) {
  validate_map(init12, A.num_vertices(), B.num_tets(), 4, "initial map A->B");
  validate_map(init21, B.num_vertices(), A.num_tets(), 4, "initial map B->A");
  return SymmetricMapSolver(A, B, init12, init21, opt, progress).run();
}

}  // namespace shapemap
