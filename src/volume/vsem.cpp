// Isovolumetric / volumetric stretch energies, L_V(f), AST and the VSEM fixed point
// (isovolumetric-ball-parameterization.txt, Eqs. 2, 3, 8-13, Algorithm 1 steps 1-13).
#include "shapemap/volume/vsem.h"
#include "shapemap/timing.h"
#include "shapemap/geometry/tet_volume.h"
#include "shapemap/error.h"
#include "shapemap/geometry/laplacian.h"
#include "shapemap/geometry/sparse_cholesky.h"
#include <Eigen/Geometry>
#include <Eigen/LU>
#include <Eigen/SVD>
#include <algorithm>
#include <cstdint>
#include <numeric>
#include <chrono>
#include <cmath>
#include <limits>
#include <string>

namespace shapemap {

namespace {

// Below this many elements the loops run serially (thread start-up dominates).
constexpr Eigen::Index kParallelMin = 4096;

constexpr int kTetEdge[6][2] = {{0, 1}, {0, 2}, {0, 3}, {1, 2}, {1, 3}, {2, 3}};

// Gradients g_i = d|tau|/d x_i of the signed volume of tet (x0,x1,x2,x3); returns the volume.
inline double volume_gradients(const Eigen::Vector3d& x0, const Eigen::Vector3d& x1,
                               const Eigen::Vector3d& x2, const Eigen::Vector3d& x3,
                               Eigen::Vector3d g[4]) {
  const Eigen::Vector3d a = x1 - x0, b = x2 - x0, c = x3 - x0;
  g[1] = b.cross(c) / 6.0;
  g[2] = c.cross(a) / 6.0;
  g[3] = a.cross(b) / 6.0;
  g[0] = -(g[1] + g[2] + g[3]);
  return a.dot(g[1]);
}

inline Eigen::Vector3d row3(const Eigen::MatrixXd& M, int i) {
  return Eigen::Vector3d(M(i, 0), M(i, 1), M(i, 2));
}

// Deterministic sum of a vector: fixed blocks summed in order.
double ordered_sum(const Eigen::VectorXd& x) {
  double s = 0;
  for (Eigen::Index i = 0; i < x.size(); ++i) s += x(i);
  return s;
}

}  // namespace

// ------------------------------------------------------------------------- AST
Eigen::MatrixXd AnisotropicScaling::apply(const Eigen::MatrixXd& V) const {
  Eigen::MatrixXd P = (V.rowwise() - center) * rotation.transpose();
  for (int l = 0; l < 3; ++l) P.col(l) *= scale(l);
  return P;
}

AnisotropicScaling anisotropic_scaling(const Eigen::MatrixXd& V) {
  if (V.rows() < 4 || V.cols() != 3) throw InputError("anisotropic_scaling: need n×3, n >= 4");
  AnisotropicScaling a;
  a.center = V.colwise().mean();                                  // c (Eq. 11)
  const Eigen::MatrixXd P = V.rowwise() - a.center;               // Eq. 12
  Eigen::JacobiSVD<Eigen::MatrixXd> svd(P, Eigen::ComputeThinV);  // Eq. 13
  Eigen::Matrix3d R = svd.matrixV().transpose();                  // R = V^T
  if (R.determinant() < 0) R.row(2) *= -1;                        // keep R in SO(3)
  a.rotation = R;
  const Eigen::MatrixXd Q = P * R.transpose();
  for (int l = 0; l < 3; ++l) {
    const double m = Q.col(l).cwiseAbs().maxCoeff();
    if (!(m > 0)) throw InputError("anisotropic_scaling: the mesh is flat");
    a.scale(l) = 1.0 / m;
  }
  return a;
}

// --------------------------------------------------------------- energies
void IsovolumetricEnergy::build(const Eigen::MatrixXd& V, const Eigen::MatrixXi& T) {
  if (V.cols() != 3 || T.cols() != 4) throw InputError("isovolumetric energy: need V n×3, T m×4");
  n_ = int(V.rows());
  if (T.size() > 0 && (T.minCoeff() < 0 || T.maxCoeff() >= n_))
    throw InputError("isovolumetric energy: tet index out of range");
  T_ = T;
  const Eigen::Index m = T.rows();
  vol_e_.resize(m);
  for (Eigen::Index t = 0; t < m; ++t) {
    Eigen::Vector3d g[4];
    vol_e_(t) = volume_gradients(row3(V, T(t, 0)), row3(V, T(t, 1)), row3(V, T(t, 2)),
                                 row3(V, T(t, 3)), g);
    if (!(vol_e_(t) > 0))
      throw InputError("isovolumetric energy: tet " + std::to_string(t) +
                       " has non-positive volume (degenerate or inverted input)");
  }
  total_e_ = ordered_sum(vol_e_);
  // vertex -> incidences (CSR), in increasing (tet, corner) order: deterministic gathers.
  inc_start_.assign(n_ + 1, 0);
  for (Eigen::Index t = 0; t < m; ++t)
    for (int c = 0; c < 4; ++c) ++inc_start_[T(t, c) + 1];
  for (int i = 0; i < n_; ++i) inc_start_[i + 1] += inc_start_[i];
  inc_.resize(size_t(m) * 4);
  std::vector<int> fill(inc_start_.begin(), inc_start_.end() - 1);
  for (Eigen::Index t = 0; t < m; ++t)
    for (int c = 0; c < 4; ++c) inc_[fill[T(t, c)]++] = int(t * 4 + c);
  scratch_.resize(m, 12);
  vol_scratch_.resize(m);
  TetMesh tm;
  tm.V = V;
  tm.T = T;
  const TetBoundary tb = boundary_surface(tm);
  Fb_.resize(tb.surface.F.rows(), 3);
  for (Eigen::Index k = 0; k < Fb_.rows(); ++k)
    for (int c = 0; c < 3; ++c) Fb_(k, c) = tb.to_volume(tb.surface.F(k, c));
}

void IsovolumetricEnergy::image_volumes(const Eigen::MatrixXd& f, Eigen::VectorXd& vol_f) const {
  const Eigen::Index m = T_.rows();
  vol_f.resize(m);
#pragma omp parallel for schedule(static) if (m > kParallelMin)
  for (Eigen::Index t = 0; t < m; ++t) {
    const Eigen::Vector3d x0 = row3(f, T_(t, 0));
    vol_f(t) = signed_tet_volume(x0, row3(f, T_(t, 1)), row3(f, T_(t, 2)), row3(f, T_(t, 3)));
  }
}

double IsovolumetricEnergy::image_volume(const Eigen::MatrixXd& f) const {
  image_volumes(f, vol_scratch_);
  return ordered_sum(vol_scratch_);
}

double IsovolumetricEnergy::stretch_energy(const Eigen::MatrixXd& f) const {
  image_volumes(f, vol_scratch_);
  double E = 0;
  for (Eigen::Index t = 0; t < vol_scratch_.size(); ++t)
    E += vol_scratch_(t) * vol_scratch_(t) / vol_e_(t);
  return E;
}

double IsovolumetricEnergy::energy(const Eigen::MatrixXd& f, double* E_V, double* V_f) const {
  image_volumes(f, vol_scratch_);
  double E = 0, Vf = 0;
  for (Eigen::Index t = 0; t < vol_scratch_.size(); ++t) {
    E += vol_scratch_(t) * vol_scratch_(t) / vol_e_(t);
    Vf += vol_scratch_(t);
  }
  if (E_V) *E_V = E;
  if (V_f) *V_f = Vf;
  if (!(Vf > 0)) return std::numeric_limits<double>::infinity();
  return total_e_ / Vf * E - Vf;  // Eq. 2a
}

void IsovolumetricEnergy::gather(Eigen::MatrixXd& G) const {
  G.resize(n_, 3);
#pragma omp parallel for schedule(static) if (n_ > kParallelMin)
  for (int i = 0; i < n_; ++i) {
    double s0 = 0, s1 = 0, s2 = 0;
    for (int k = inc_start_[i]; k < inc_start_[i + 1]; ++k) {
      const int t = inc_[k] >> 2, c = inc_[k] & 3;
      s0 += scratch_(t, 3 * c);
      s1 += scratch_(t, 3 * c + 1);
      s2 += scratch_(t, 3 * c + 2);
    }
    G(i, 0) = s0;
    G(i, 1) = s1;
    G(i, 2) = s2;
  }
}

void IsovolumetricEnergy::volume_gradient(const Eigen::MatrixXd& f, Eigen::MatrixXd& GV) const {
  GV.setZero(n_, 3);
  for (Eigen::Index k = 0; k < Fb_.rows(); ++k) {
    const int i = Fb_(k, 0), j = Fb_(k, 1), l = Fb_(k, 2);
    const Eigen::Vector3d a = row3(f, i), b = row3(f, j), c = row3(f, l);
    GV.row(i) += b.cross(c).transpose() / 6.0;
    GV.row(j) += c.cross(a).transpose() / 6.0;
    GV.row(l) += a.cross(b).transpose() / 6.0;
  }
}

void IsovolumetricEnergy::stretch_terms(const Eigen::MatrixXd& f) const {
  const Eigen::Index m = T_.rows();
#pragma omp parallel for schedule(static) if (m > kParallelMin)
  for (Eigen::Index t = 0; t < m; ++t) {
    Eigen::Vector3d g[4];
    const double a = volume_gradients(row3(f, T_(t, 0)), row3(f, T_(t, 1)), row3(f, T_(t, 2)),
                                      row3(f, T_(t, 3)), g);
    vol_scratch_(t) = a;
    const double s = 2.0 * a / vol_e_(t);  // d(a^2/|tau|) = 2a/|tau| g_i
    for (int c = 0; c < 4; ++c)
      for (int d = 0; d < 3; ++d) scratch_(t, 3 * c + d) = s * g[c](d);
  }
}

double IsovolumetricEnergy::energy_and_gradient(const Eigen::MatrixXd& f, Eigen::MatrixXd& G,
                                                double* E_V, double* V_f) const {
  const Eigen::Index m = T_.rows();
  stretch_terms(f);
  double E = 0, Vf = 0;
  for (Eigen::Index t = 0; t < m; ++t) {
    E += vol_scratch_(t) * vol_scratch_(t) / vol_e_(t);
    Vf += vol_scratch_(t);
  }
  if (E_V) *E_V = E;
  if (V_f) *V_f = Vf;
  gather(G);  // 3 L_V(f) f  (Eq. 8)
  if (!(Vf > 0)) {
    G.setZero(n_, 3);
    return std::numeric_limits<double>::infinity();
  }
  volume_gradient(f, gv_scratch_);                   // grad V(f) (Eq. 7)
  const double a = total_e_ / Vf;                    // V(e)/V(f)
  const double b = 1.0 + total_e_ * E / (Vf * Vf);   // 1 + V(e) E_V / V(f)^2
  G *= a;
  G -= b * gv_scratch_;                              // Eq. 10 before the chain rule
  return a * E - Vf;
}

Eigen::MatrixXd IsovolumetricEnergy::stretch_gradient(const Eigen::MatrixXd& f) const {
  stretch_terms(f);
  Eigen::MatrixXd G;
  gather(G);
  return G;
}

void IsovolumetricEnergy::stretch_weights(const Eigen::MatrixXd& f, Eigen::MatrixXd& W) const {
  const Eigen::Index m = T_.rows();
  W.resize(m, 6);
#pragma omp parallel for schedule(static) if (m > kParallelMin)
  for (Eigen::Index t = 0; t < m; ++t) {
    Eigen::Vector3d g[4];
    volume_gradients(row3(f, T_(t, 0)), row3(f, T_(t, 1)), row3(f, T_(t, 2)), row3(f, T_(t, 3)), g);
    const double s = -(2.0 / 3.0) / vol_e_(t);
    for (int e = 0; e < 6; ++e) W(t, e) = s * g[kTetEdge[e][0]].dot(g[kTetEdge[e][1]]);
  }
}

void IsovolumetricEnergy::stretch_laplacian(const Eigen::MatrixXd& f,
                                            Eigen::SparseMatrix<double>& L) const {
  Eigen::MatrixXd W;
  stretch_weights(f, W);
  assemble_tet_laplacian(T_, W, n_, L);
}

double isovolumetric_energy(const Eigen::MatrixXd& V, const Eigen::MatrixXi& T,
                            const Eigen::MatrixXd& f) {
  return IsovolumetricEnergy(V, T).energy(f);
}
double volumetric_stretch_energy(const Eigen::MatrixXd& V, const Eigen::MatrixXi& T,
                                 const Eigen::MatrixXd& f) {
  return IsovolumetricEnergy(V, T).stretch_energy(f);
}
Eigen::SparseMatrix<double> volumetric_stretch_laplacian(const Eigen::MatrixXd& V,
                                                         const Eigen::MatrixXi& T,
                                                         const Eigen::MatrixXd& f) {
  Eigen::SparseMatrix<double> L;
  IsovolumetricEnergy(V, T).stretch_laplacian(f, L);
  return L;
}

// ------------------------------------------------------------------ VSEM
namespace {
// Morton (Z-order) key of a point in the box [lo, lo + ext]: 21 bits per axis, interleaved.
std::uint64_t morton_key(const Eigen::RowVector3d& p, const Eigen::RowVector3d& lo, const Eigen::RowVector3d& ext) {
  std::uint64_t key = 0;
  for (int d = 0; d < 3; ++d) {
    const double u = ext(d) > 0 ? (p(d) - lo(d)) / ext(d) : 0.0;
    std::uint64_t q = std::uint64_t(std::clamp(u, 0.0, 1.0) * double((1u << 21) - 1));
    for (int b = 0; b < 21; ++b) key |= ((q >> b) & 1u) << (3 * b + d);
  }
  return key;
}
}  // namespace

int interior_first_order(const std::vector<char>& is_boundary, Eigen::VectorXi& perm,
                         Eigen::VectorXi& iperm, const Eigen::MatrixXd* V) {
  const int n = int(is_boundary.size());
  if (V && V->rows() != n) throw InputError("interior_first_order: V must have one row per vertex");
  perm.resize(n);
  iperm.resize(n);
  std::vector<std::uint64_t> key(size_t(n), 0);
  if (V && n > 0) {
    const Eigen::RowVector3d lo = V->colwise().minCoeff(), ext = V->colwise().maxCoeff() - lo;
    for (int i = 0; i < n; ++i) key[size_t(i)] = morton_key(V->row(i), lo, ext);
  }
  std::iota(iperm.data(), iperm.data() + n, 0);
  // Interior first; within each group in Z-order (ties: input order), so that the vertices
  // of a tet, and tets next to each other, sit close in memory.
  std::stable_sort(iperm.data(), iperm.data() + n, [&](int a, int b) {
    if (is_boundary[size_t(a)] != is_boundary[size_t(b)]) return is_boundary[size_t(b)] != 0;
    return key[size_t(a)] < key[size_t(b)];
  });
  for (int i = 0; i < n; ++i) perm(iperm(i)) = i;
  return int(std::count(is_boundary.begin(), is_boundary.end(), 0));
}

Eigen::MatrixXi renumber_tets(const Eigen::MatrixXi& T, const Eigen::VectorXi& perm) {
  const Eigen::Index m = T.rows();
  Eigen::VectorXi first(m);
  for (Eigen::Index t = 0; t < m; ++t)
    first(t) = std::min(std::min(perm(T(t, 0)), perm(T(t, 1))), std::min(perm(T(t, 2)), perm(T(t, 3))));
  std::vector<int> order(static_cast<size_t>(m));
  std::iota(order.begin(), order.end(), 0);
  std::stable_sort(order.begin(), order.end(), [&](int a, int b) { return first(a) < first(b); });
  Eigen::MatrixXi Tp(m, 4);
  for (Eigen::Index k = 0; k < m; ++k)
    for (int c = 0; c < 4; ++c) Tp(k, c) = perm(T(order[size_t(k)], c));  // corner order kept
  return Tp;
}

VsemResult vsem_fixed_point(const Eigen::MatrixXd& V, const Eigen::MatrixXi& T,
                            const Eigen::VectorXi& boundary, const Eigen::MatrixXd& fB,
                            const VsemOptions& opt, const ProgressCallback& progress) {
  const auto t0 = Clock::now();
  const int n = int(V.rows());
  if (fB.rows() != boundary.size() || fB.cols() != 3)
    throw InputError("vsem_fixed_point: fB must be nB×3 matching the boundary indices");
  std::vector<char> isb(n, 0);
  for (Eigen::Index k = 0; k < boundary.size(); ++k) {
    if (boundary(k) < 0 || boundary(k) >= n) throw InputError("vsem_fixed_point: bad boundary index");
    isb[boundary(k)] = 1;
  }
  Eigen::VectorXi perm, iperm;
  const int nI = interior_first_order(isb, perm, iperm, &V);
  // Work in the permuted numbering: interior rows first.
  const Eigen::MatrixXi Tp = renumber_tets(T, perm);
  Eigen::MatrixXd Vp(n, 3);
  for (int i = 0; i < n; ++i) Vp.row(perm(i)) = V.row(i);
  IsovolumetricEnergy energy(Vp, Tp);

  VsemResult res;
  Eigen::MatrixXd f = Eigen::MatrixXd::Zero(n, 3);
  for (Eigen::Index k = 0; k < boundary.size(); ++k) f.row(perm(boundary(k))) = fB.row(k);

  Eigen::SparseMatrix<double> L, LII;
  // 16 factor+solve pairs of a tet-mesh Laplacian, see sparse_cholesky.h.
  SparseCholesky chol(SparseCholesky::Method::Simplicial, SparseCholesky::Ordering::NestedDissection);
  Eigen::MatrixXd best;
  double best_E = std::numeric_limits<double>::infinity();
  for (int it = 0; it <= opt.iterations; ++it) {
    report(progress, "ball/vsem", double(it) / (opt.iterations + 1));
    energy.stretch_laplacian(it == 0 ? Vp : f, L);  // L_V(e) (step 7), then L_V(f) (step 10)
    if (nI > 0) {
      LII = L.topLeftCorner(nI, nI);
      if (it == 0) {
        chol.compute(LII);
      } else {
        // L_V(f) is positive semidefinite for any f, but collapsed image tets can make
        // L_II numerically singular: the fixed point cannot go on from f, so it stops
        // and keeps the best iterate so far.
        try {
          chol.factorize(LII);
        } catch (const Error&) {
          res.stopped_singular = true;
          break;
        }
      }
      Eigen::MatrixXd f0 = f;
      f0.topRows(nI).setZero();
      const Eigen::MatrixXd rhs = -(L * f0).topRows(nI);  // -L_IB f_B
      f.topRows(nI) = chol.solve(rhs);                     // steps 8 / 11
    }
    const double E = energy.energy(f);
    res.energies.push_back(E);
    res.iterations = it;
    if (!opt.keep_best || E < best_E || best.size() == 0) {
      best_E = E;
      best = f;
    }
  }
  report(progress, "ball/vsem", 1.0);
  const Eigen::MatrixXd& fr = opt.keep_best ? best : f;
  res.f.resize(n, 3);
  for (int i = 0; i < n; ++i) res.f.row(i) = fr.row(perm(i));
  res.seconds = seconds_since(t0);
  return res;
}

}  // namespace shapemap
