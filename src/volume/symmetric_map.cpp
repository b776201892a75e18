// Symmetric volume maps: symmetric-volume-maps.txt Secs. 4-5, Algorithm 1.
#include "shapemap/volume/symmetric_map.h"
#include "shapemap/adjacency.h"
#include "shapemap/error.h"
#include "shapemap/geometry/mass.h"
#include "shapemap/optim/lbfgs.h"
#include "shapemap/optim/newton.h"
#include <Eigen/Dense>
#include <algorithm>
#include <chrono>
#include <cmath>
#include <functional>
#include <limits>
#include <memory>

namespace shapemap {

namespace {

using Clock = std::chrono::steady_clock;
double seconds_since(Clock::time_point t0) {
  return std::chrono::duration<double>(Clock::now() - t0).count();
}

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
  Fi_vol_ = faces_in_volume_numbering(bi_);
  target_boundary_.build(bj_.surface.V, bj_.surface.F);
}

void DirectionalEnergy::set_weights(double alpha, double beta, double gamma, double backward_scale) {
  alpha_ = alpha;
  beta_ = beta;
  gamma_ = gamma;
  bscale_ = backward_scale;
}

void DirectionalEnergy::set_maps(const BarycentricMap& P_ij, const BarycentricMap& P_ji) {
  PijVj_ = map_positions(P_ij, Mj_.V, Mj_.T);
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
  last_X_ = X;
  t.total = alpha_ * t.arap + (1 - alpha_) * t.reversibility +
            gamma_ * (t.projection_forward + bscale_ * t.projection_backward) + beta_ * t.auxiliary;
  if (terms) *terms = t;
  return t.total;
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
    // returned; a good hint only tightens the initial bound of the branch and bound).
    std::vector<ClosestPointResult>& r = hits_;
    const bool hinted = P.size() == ni;
    r.resize(ni);
    if (hinted)
      for (int v = 0; v < ni; ++v) r[v].elem = P.elem(v);
    bvh_.query(Q_, r, hinted);
    P.elem.resize(ni);
    P.bary.resize(ni, 4);
    for (int v = 0; v < ni; ++v) {
      P.elem(v) = r[v].elem;
      Eigen::Vector4d w = r[v].bary.cwiseMax(0.0);
      double s = w.sum();
      P.bary.row(v) = (s > 0 ? Eigen::Vector4d(w / s) : Eigen::Vector4d(1, 0, 0, 0)).transpose();
    }
    if (boundary_to_boundary) {
      const int nb = int(bi_.to_volume.size());
      Eigen::MatrixXd Qb(nb, 6);
      for (int q = 0; q < nb; ++q) Qb.row(q) = Q_.row(bi_.to_volume(q));
      std::vector<ClosestPointResult> rb = bvh_bd_.query(Qb);
      for (int q = 0; q < nb; ++q) {
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

// L-BFGS over the rows `free_rows` of X (others fixed) of an objective on the full X.
// Returns the L-BFGS result (f and grad_norm at the final X).
LbfgsResult minimize_rows(const std::function<double(const Eigen::MatrixXd&, Eigen::MatrixXd*)>& f,
                          Eigen::MatrixXd& X, const std::vector<int>& free_rows, int iterations,
                          int memory) {
  const int k = int(free_rows.size());
  Eigen::VectorXd x(3 * k);
  for (int q = 0; q < k; ++q) x.segment<3>(3 * q) = X.row(free_rows[q]).transpose();
  Eigen::MatrixXd Xf = X, G;
  Eigen::VectorXd last_z, last_g;
  double last_f = 0;
  Objective obj = [&](const Eigen::VectorXd& z, Eigen::VectorXd& g) {
    for (int q = 0; q < k; ++q) Xf.row(free_rows[q]) = z.segment<3>(3 * q).transpose();
    double e = f(Xf, &G);
    for (int q = 0; q < k; ++q) g.segment<3>(3 * q) = G.row(free_rows[q]).transpose();
    last_z = z;
    last_g = g;
    last_f = e;
    return e;
  };
  LbfgsOptions lo;
  lo.max_iterations = iterations;
  lo.memory = memory;
  lo.grad_tol = 1e-10;
  lo.f_decrease_tol = 1e-12;
  LbfgsResult res;
  if (k > 0 && iterations > 0) {
    res = lbfgs_minimize(obj, x, lo);
  } else {
    Eigen::VectorXd g(3 * k);
    res.f = obj(x, g);
    res.grad_norm = k > 0 ? g.lpNorm<Eigen::Infinity>() : 0.0;
  }
  for (int q = 0; q < k; ++q) X.row(free_rows[q]) = x.segment<3>(3 * q).transpose();
  // Report the Euclidean norm of the gradient at the final point (Sec. 5.4 (i)).
  if (k > 0 && (last_z.size() != x.size() || last_z != x)) {
    Eigen::VectorXd g(3 * k);
    obj(x, g);
  }
  res.f = k > 0 ? last_f : res.f;
  res.grad_norm = k > 0 ? last_g.norm() : 0.0;
  return res;
}

// Projected Newton over the free vertices of `pn`'s pattern (others fixed) on the X-step
// objective of one direction; the same result fields as minimize_rows.
LbfgsResult newton_rows(const DirectionalEnergy& e, ProjectedNewton& pn, Eigen::MatrixXd& X,
                        const NewtonOptions& o, double* profile = nullptr) {
  const std::vector<int>& rows = pn.hessian().free_vertices();
  const int k = int(rows.size());
  Eigen::MatrixXd Xf = X, G;
  auto scatter = [&](const Eigen::VectorXd& z) {
    for (int q = 0; q < k; ++q) Xf.row(rows[q]) = z.segment<3>(3 * q).transpose();
  };
  NewtonValue f = [&](const Eigen::VectorXd& z, Eigen::VectorXd* g) {
    scatter(z);
    const double v = e.evaluate(Xf, g ? &G : nullptr);
    if (g)
      for (int q = 0; q < k; ++q) g->segment<3>(3 * q) = G.row(rows[q]).transpose();
    return v;
  };
  NewtonHessian h = [&](const Eigen::VectorXd& z, BlockHessian& H) {
    scatter(z);
    e.add_hessian(Xf, H);
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


// The landing stage (ours, issue 19) for one direction i -> j: gamma raised in rounds with
// every vertex free (the boundary slides toward dM_j, ARAP spreading the motion: on the
// glasses pair 2 rounds cut d^max from 8.7/15.7 to 0.8/1.2 x1e-2 of the diagonal at the same
// inverted count), then X's boundary to its closest points on dM_j, the interior relaxed with it held (Newton on the X-step objective, then
// Sec. 5.3's ARAP repair on interior vertices of inverted tets). The located result
// replaces X unless it inverts more tets than X located as it was ("snapped"); `located`
// receives the chosen map (the map files: barycentric coordinates do not change with the
// unit-volume scaling) and X its positions. Returns true when the landed X was kept.
bool land_on_target(DirectionalEnergy& e, const TetMesh& Mi, const TetMesh& Mj,
                    const std::vector<int>& interior, const std::vector<std::vector<int>>& vv,
                    const std::vector<std::vector<int>>& vt, const SymmetricVolumeMapOptions& opt,
                    Eigen::MatrixXd& X, BarycentricMap& located, SymmetricMapStage& st) {
  const TetBoundary& bi = e.boundary_i();
  const TetBoundary& bj = e.boundary_j();
  const std::vector<int> brows(bi.to_volume.data(), bi.to_volume.data() + bi.to_volume.size());
  const BarycentricMap snapped_map = locate_in_tets(Mj, X, brows);
  const Eigen::MatrixXd snapped = map_positions(snapped_map, Mj.V, Mj.T);
  NewtonOptions no;
  no.max_iterations = opt.land_newton_iterations;
  no.f_rel_tol = opt.newton_rel_tol;
  no.grad_tol = 0;
  if (opt.land_gamma_rounds > 0) {  // gamma continuation, every vertex free
    std::vector<int> all(Mi.num_vertices());
    for (int v = 0; v < int(all.size()); ++v) all[v] = v;
    ProjectedNewton pa(BlockHessian(Mi.T, Mi.num_vertices(), all));
    const double alpha = e.alpha(), beta = e.beta(), gamma = e.gamma(), bscale = e.backward_scale();
    double g = gamma;
    for (int r = 0; r < opt.land_gamma_rounds; ++r) {
      g *= opt.land_gamma_factor;
      e.set_weights(alpha, beta, g, bscale);
      const LbfgsResult rr = newton_rows(e, pa, X, no, st.newton_seconds);
      st.lbfgs_iterations += rr.iterations;
      st.evaluations += rr.evaluations;
    }
    e.set_weights(alpha, beta, gamma, bscale);
  }
  ClosestPoint3 target(bj.surface.V, bj.surface.F);
  Eigen::MatrixXd Q(brows.size(), 3);
  for (int b = 0; b < Q.rows(); ++b) Q.row(b) = X.row(brows[b]);
  auto point_of = [&](const ClosestPointResult& h) {
    Eigen::RowVector3d p = Eigen::RowVector3d::Zero();
    for (int c = 0; c < 3; ++c) p += h.bary(c) * bj.surface.V.row(bj.surface.F(h.elem, c));
    return p;
  };
  const std::vector<ClosestPointResult> hit = target.query(Q);
  for (int b = 0; b < Q.rows(); ++b) X.row(brows[b]) = point_of(hit[b]);
  ProjectedNewton pn(BlockHessian(Mi.T, Mi.num_vertices(), interior));
  const LbfgsResult r = newton_rows(e, pn, X, no, st.newton_seconds);
  st.lbfgs_iterations += r.iterations;
  st.evaluations += r.evaluations;
  // Repair of inverted tets (stage 5's energy, with the sigma penalty) in which boundary
  // vertices may slide: held near dM_j by a stiff closest-point spring, and near where the
  // round found them by a softer one (land_slide_anchor; without it they slid off parts of
  // dM_j and left them uncovered: glasses d^max 10%), and put back on dM_j after each round.
  // Interior vertices alone (the previous repair) left 133/231 inverted tets on the glasses
  // pair; sliding, 56/96 (d^max 1.6/1.7 x1e-2).
  const ArapEnergy& arap = e.arap();
  std::vector<char> on_boundary(Mi.num_vertices(), 0);
  for (int v : brows) on_boundary[v] = 1;
  // Spring stiffness: 1e4 x the ARAP stiffness of a typical tet (weight w / edge^2), so the
  // springs stretch ~1% of an edge where ARAP pulls hardest.
  const double w_mean = arap.weights().mean();
  const double edge = std::cbrt(6.0 * std::sqrt(2.0) * 2.0 * w_mean * e.volume_i());
  const double spring = 1e4 * w_mean / (edge * edge);
  for (int round = 0; round < opt.post_repair_rounds; ++round) {
    std::vector<int> verts, tets, slide;
    inverted_neighbourhood(arap, X, opt.repair_rings, vv, vt, verts, tets);
    if (verts.empty()) break;
    for (int v : verts)
      if (on_boundary[v]) slide.push_back(v);
    Eigen::MatrixXd S(slide.size(), 3), S0(slide.size(), 3);
    for (size_t q = 0; q < slide.size(); ++q) S0.row(q) = X.row(slide[q]);
    const double anchor = opt.land_slide_anchor * spring;
    auto f = [&](const Eigen::MatrixXd& Y, Eigen::MatrixXd* g) {
      double E = arap.energy(Y, tets, g, opt.post_repair_penalty);
      for (size_t q = 0; q < slide.size(); ++q) S.row(q) = Y.row(slide[q]);
      const std::vector<ClosestPointResult> c = target.query(S);
      for (size_t q = 0; q < slide.size(); ++q) {
        E += spring * c[q].sqdist + anchor * (S.row(q) - S0.row(q)).squaredNorm();
        if (g) g->row(slide[q]) += 2.0 * spring * (S.row(q) - point_of(c[q])) + 2.0 * anchor * (S.row(q) - S0.row(q));
      }
      return E;
    };
    st.iterations += minimize_rows(f, X, verts, opt.post_repair_steps, opt.lbfgs_memory).iterations;
    for (size_t q = 0; q < slide.size(); ++q) S.row(q) = X.row(slide[q]);
    const std::vector<ClosestPointResult> c = target.query(S);
    for (size_t q = 0; q < slide.size(); ++q) X.row(slide[q]) = point_of(c[q]);
  }
  // Interior images that still fall outside M_j are located (snapped) too.
  const BarycentricMap landed_map = locate_in_tets(Mj, X, brows);
  const Eigen::MatrixXd landed = map_positions(landed_map, Mj.V, Mj.T);
  const bool keep = count_inverted(arap, landed) <= count_inverted(arap, snapped);
  X = keep ? landed : snapped;
  located = keep ? landed_map : snapped_map;
  return keep;
}

}  // namespace

SymmetricVolumeMapResult symmetric_volume_map(const TetMesh& A, const TetMesh& B,
                                              const BarycentricMap& init12,
                                              const BarycentricMap& init21,
                                              const SymmetricVolumeMapOptions& opt,
                                              const ProgressCallback& progress) {
  validate_map(init12, A.num_vertices(), B.num_tets(), 4, "initial map A->B");
  validate_map(init21, B.num_vertices(), A.num_tets(), 4, "initial map B->A");
  // Unit volume (Sec. 5.5).
  Normalization nA = unit_volume_normalization(A), nB = unit_volume_normalization(B);
  TetMesh M1{nA.apply(A.V), A.T}, M2{nB.apply(B.V), B.T};

  DirectionalEnergy e12(M1, M2), e21(M2, M1);
  const double c1 = e12.volume_i(), c2 = e21.volume_i();
  PStep p12(M1, M2, c1, c2), p21(M2, M1, c2, c1);
  const int n1 = M1.num_vertices(), n2 = M2.num_vertices();

  SymmetricVolumeMapResult res;
  BarycentricMap P12 = init12, P21 = init21;
  const BarycentricMap P12_0 = init12, P21_0 = init21;  // Algorithm 1 lines 1-2
  Eigen::MatrixXd X12 = map_positions(P12, M2.V, M2.T);  // line 3
  Eigen::MatrixXd X21 = map_positions(P21, M1.V, M1.T);  // line 4

  std::vector<char> bd1(n1, 0), bd2(n2, 0);
  for (int i = 0; i < e12.boundary_i().to_volume.size(); ++i) bd1[e12.boundary_i().to_volume(i)] = 1;
  for (int i = 0; i < e21.boundary_i().to_volume.size(); ++i) bd2[e21.boundary_i().to_volume(i)] = 1;
  std::vector<int> all1(n1), all2(n2), int1, int2;
  for (int v = 0; v < n1; ++v) {
    all1[v] = v;
    if (!bd1[v]) int1.push_back(v);
  }
  for (int v = 0; v < n2; ++v) {
    all2[v] = v;
    if (!bd2[v]) int2.push_back(v);
  }

  int global_iter = 0;
  auto beta_at = [&](int it) {
    if (opt.beta_ramp_iterations <= 0) return opt.beta_end;
    double t = std::min(1.0, double(it) / opt.beta_ramp_iterations);
    return opt.beta_start + (opt.beta_end - opt.beta_start) * t;
  };
  // gamma ramps with beta over the same iterations when gamma_start >= 0 (the authors'
  // released code: both from 1/N of their final values), else stays at gamma.
  auto gamma_at = [&](int it) {
    if (opt.gamma_start < 0 || opt.beta_ramp_iterations <= 0) return opt.gamma;
    double t = std::min(1.0, double(it) / opt.beta_ramp_iterations);
    return opt.gamma_start + (opt.gamma - opt.gamma_start) * t;
  };
  double beta = beta_at(0), gamma = gamma_at(0);
  auto set_weights = [&](double a, double b, double g) {
    e12.set_weights(a, b, g, opt.backward_projection_scale);
    e21.set_weights(a, b, g, opt.backward_projection_scale);
  };

  // Stages 2 and 4: alternating P- and X-steps until a stopping rule of Sec. 5.4.
  auto optimize = [&](const std::string& name, bool fix_boundary) {
    SymmetricMapStage st;
    st.name = name;
    auto t0 = Clock::now();
    double E_prev = std::numeric_limits<double>::infinity();
    double beta_prev = -1;  // beta of E_prev: the decrease rule compares energies of one Eq. 25
    const std::vector<int>& free1 = fix_boundary ? int1 : all1;
    const std::vector<int>& free2 = fix_boundary ? int2 : all2;
    // Newton: one pattern (and CHOLMOD analysis) per direction for the whole stage.
    std::unique_ptr<ProjectedNewton> n12, n21;
    NewtonOptions no;
    no.max_iterations = opt.newton_iterations;
    no.f_rel_tol = opt.newton_rel_tol;
    no.grad_tol = 0;
    if (opt.solver == XStepSolver::Newton) {
      n12 = std::make_unique<ProjectedNewton>(BlockHessian(M1.T, n1, free1));
      n21 = std::make_unique<ProjectedNewton>(BlockHessian(M2.T, n2, free2));
    }
    for (int it = 0; it < opt.max_iterations; ++it) {
      beta = beta_at(global_iter);
      gamma = gamma_at(global_iter);
      set_weights(opt.alpha, beta, gamma);
      auto tp = Clock::now();
      // P-steps (Algorithm 1 lines 8 / 18), boundary restored in stage 2 (line 10)
      p12.run(X12, X21, opt.alpha, beta, opt.boundary_to_boundary, fix_boundary ? &bd1 : nullptr,
              P12_0, P12);
      p21.run(X21, X12, opt.alpha, beta, opt.boundary_to_boundary, fix_boundary ? &bd2 : nullptr,
              P21_0, P21);
      st.time_pstep += seconds_since(tp);
      // X-steps (lines 9 / 19)
      auto tx = Clock::now();
      e12.set_maps(P12, P21);
      e21.set_maps(P21, P12);
      auto f12 = [&](const Eigen::MatrixXd& X, Eigen::MatrixXd* g) { return e12.evaluate(X, g); };
      auto f21 = [&](const Eigen::MatrixXd& X, Eigen::MatrixXd* g) { return e21.evaluate(X, g); };
      LbfgsResult r1, r2;
      if (opt.solver == XStepSolver::Newton) {
        // (Running the two directions on one thread each was 1.3x faster but not
        // reproducible run to run: it stays serial, parallel inside.)
        r1 = newton_rows(e12, *n12, X12, no, st.newton_seconds);
        r2 = newton_rows(e21, *n21, X21, no, st.newton_seconds);
      } else {
        r1 = minimize_rows(f12, X12, free1, opt.xstep_iterations, opt.lbfgs_memory);
        r2 = minimize_rows(f21, X21, free2, opt.xstep_iterations, opt.lbfgs_memory);
      }
      st.time_xstep += seconds_since(tx);
      st.lbfgs_iterations += r1.iterations + r2.iterations;
      st.evaluations += r1.evaluations + r2.evaluations;
      double E = r1.f + r2.f;
      double gn = std::sqrt(r1.grad_norm * r1.grad_norm + r2.grad_norm * r2.grad_norm);
      ++global_iter;
      ++st.iterations;
      st.energy = E;
      report(progress, "volume-map/" + name, double(it + 1) / opt.max_iterations);
      st.energy_history.push_back(E);
      st.gradient_history.push_back(gn);
      bool ramp_done = beta_at(global_iter) == beta;  // beta no longer changes
      if (it + 1 < opt.min_iterations) {
        E_prev = E;
        beta_prev = beta;
        continue;
      }
      if (gn < opt.grad_tol) {
        st.stop_reason = "gradient";
        break;
      }
      // Only once beta is final, and between two iterations at that beta: the first
      // iteration at beta_end has a larger E_Q weight than the one before (E rises).
      if (ramp_done && beta_prev == beta &&
          E_prev - E < std::max(opt.decrease_tol, opt.decrease_rel_tol * std::abs(E))) {
        st.stop_reason = "decrease";
        break;
      }
      E_prev = E;
      beta_prev = beta;
      if (it + 1 == opt.max_iterations) st.stop_reason = "iterations";
    }
    st.inverted12 = count_inverted(e12.arap(), X12);
    st.inverted21 = count_inverted(e21.arap(), X21);
    st.seconds = seconds_since(t0);
    res.iterations += st.iterations;
    res.stages.push_back(st);
  };

  auto vv1 = vertex_neighbors(M1.T, n1), vv2 = vertex_neighbors(M2.T, n2);
  auto vt1 = vertex_elements(M1.T, n1), vt2 = vertex_elements(M2.T, n2);
  // Stages 3 and 5: ARAP only on the neighbourhood of inverted tets (Sec. 5.3).
  // fallback_rings > rings: rounds on that wider neighbourhood when the first ones leave
  // inverted tets, and the stage is undone (per direction) unless it lowered their number
  // (stage 5 only, see SymmetricVolumeMapOptions::post_repair_fallback_rings).
  auto repair = [&](const std::string& name, int rings, int steps, int rounds, int fallback_rings,
                    const SigmaPenalty& pen) {
    SymmetricMapStage st;
    st.name = name;
    auto t0 = Clock::now();
    for (int dir = 0; dir < 2; ++dir) {
      const ArapEnergy& arap = dir == 0 ? e12.arap() : e21.arap();
      Eigen::MatrixXd& X = dir == 0 ? X12 : X21;
      // Stage 5 must not leave more inverted tets than it found (ARAP alone does not keep
      // tets positive: moving the corners of one inverted tet can turn its neighbours over).
      const int inverted_start = fallback_rings > 0 ? count_inverted(arap, X) : 0;
      const Eigen::MatrixXd X_start = inverted_start > 0 ? X : Eigen::MatrixXd();
      const int total_rounds = fallback_rings > rings ? 2 * rounds : rounds;
      for (int round = 0; round < total_rounds; ++round) {
        std::vector<int> verts, tets;
        inverted_neighbourhood(arap, X, round < rounds ? rings : fallback_rings,
                               dir == 0 ? vv1 : vv2, dir == 0 ? vt1 : vt2, verts, tets);
        if (verts.empty()) break;
        auto f = [&](const Eigen::MatrixXd& Y, Eigen::MatrixXd* g) { return arap.energy(Y, tets, g, pen); };
        LbfgsResult r = minimize_rows(f, X, verts, steps, opt.lbfgs_memory);
        st.iterations += r.iterations;
      }
      if (fallback_rings > 0 && inverted_start > 0 && count_inverted(arap, X) >= inverted_start)
        X = X_start;
    }
    set_weights(opt.alpha, beta, gamma);
    st.energy = e12.evaluate(X12) + e21.evaluate(X21);
    st.inverted12 = count_inverted(e12.arap(), X12);
    st.inverted21 = count_inverted(e21.arap(), X21);
    st.seconds = seconds_since(t0);
    res.stages.push_back(st);
    report(progress, "volume-map/" + name, 1.0);
  };

  {  // Stage 1 record: the initial map.
    SymmetricMapStage st;
    st.name = "init";
    set_weights(opt.alpha, beta, gamma);
    e12.set_maps(P12, P21);
    e21.set_maps(P21, P12);
    st.energy = e12.evaluate(X12) + e21.evaluate(X21);
    st.inverted12 = count_inverted(e12.arap(), X12);
    st.inverted21 = count_inverted(e21.arap(), X21);
    res.stages.push_back(st);
  }
  if (opt.fix_boundary_first) optimize("boundary-fixed", true);        // stage 2
  repair("repair", opt.repair_rings, opt.repair_iterations, 1, 0, SigmaPenalty{0, 0});  // stage 3
  optimize("full", false);                                              // stage 4
  repair("post-repair", 0, opt.post_repair_steps, opt.post_repair_rounds,
         opt.post_repair_fallback_rings, opt.post_repair_penalty);      // stage 5

  // Ours (issue 19): the map files hold barycentric coordinates in the target's tets, so a
  // boundary that the penalty gamma E_P left off the target would be snapped into it after
  // the fact, inverting tets there (5-20x more than X had, on real pairs). Instead the
  // boundary of X is put on the target's boundary exactly (closest points), and the
  // interior relaxed with the boundary held: Newton on the X-step objective, then the
  // ARAP repair of Sec. 5.3 on inverted tets' interior vertices. X and the map files are
  // then one map.
  BarycentricMap final12, final21;  // the map files when landing
  if (opt.land_on_target) {
    SymmetricMapStage st;
    st.name = "land-on-target";
    auto t0 = Clock::now();
    set_weights(opt.alpha, beta, gamma);
    for (int dir = 0; dir < 2; ++dir) {
      const bool landed = land_on_target(dir == 0 ? e12 : e21, dir == 0 ? M1 : M2, dir == 0 ? M2 : M1,
                                         dir == 0 ? int1 : int2, dir == 0 ? vv1 : vv2, dir == 0 ? vt1 : vt2, opt,
                                         dir == 0 ? X12 : X21, dir == 0 ? final12 : final21, st);
      st.stop_reason += std::string(st.stop_reason.empty() ? "" : ", ") + (dir == 0 ? "AB " : "BA ") +
                        (landed ? "landed" : "snapped (landing inverted more)");
    }
    st.energy = e12.evaluate(X12) + e21.evaluate(X21);
    st.inverted12 = count_inverted(e12.arap(), X12);
    st.inverted21 = count_inverted(e21.arap(), X21);
    st.seconds = seconds_since(t0);
    res.stages.push_back(st);
    report(progress, "volume-map/land-on-target", 1.0);
  }

  // Final energies (Eq. 25 terms), unit-volume frame.
  set_weights(opt.alpha, beta, gamma);
  e12.set_maps(P12, P21);
  e21.set_maps(P21, P12);
  DirectionalEnergy::Terms t1, t2;
  res.E = e12.evaluate(X12, nullptr, &t1) + e21.evaluate(X21, nullptr, &t2);
  res.E_arap = t1.arap + t2.arap;
  res.E_R = t1.reversibility + t2.reversibility;
  res.E_P = t1.projection_forward + t2.projection_forward +
            opt.backward_projection_scale * (t1.projection_backward + t2.projection_backward);
  res.E_Q = t1.auxiliary + t2.auxiliary;

  // Outputs in the targets' original coordinates.
  res.X12 = nB.undo(X12);
  res.X21 = nA.undo(X21);
  res.P12 = P12;
  res.P21 = P21;
  std::vector<int> b1, b2;
  for (int v = 0; v < n1; ++v)
    if (bd1[v]) b1.push_back(v);
  for (int v = 0; v < n2; ++v)
    if (bd2[v]) b2.push_back(v);
  if (opt.land_on_target) {  // X is the map files' positions: the same numbers, unscaled
    res.map12 = final12;
    res.map21 = final21;
    res.X12 = map_positions(final12, B.V, B.T);
    res.X21 = map_positions(final21, A.V, A.T);
  } else {
    res.map12 = locate_in_tets(B, res.X12, b1);
    res.map21 = locate_in_tets(A, res.X21, b2);
  }
  return res;
}

}  // namespace shapemap
