// The heat method for geodesic distance (Crane, Weischedel, Wardetzky 2013, Algorithm 1).
#include "shapemap/geometry/geodesics.h"
#include "shapemap/adjacency.h"
#include "shapemap/error.h"
#include "shapemap/geometry/laplacian.h"
#include "shapemap/geometry/mass.h"
#include <Eigen/Geometry>
#include <algorithm>
#include <cmath>
#include <exception>
#include <limits>
#include <string>

namespace shapemap {

namespace {

// Regularization of the Poisson step, L + eps * M / h^2 (the mass is made dimensionless
// with the mean edge length h so that eps does not depend on the mesh scale).
constexpr double kPoissonEps = 1e-8;

Eigen::SparseMatrix<double> plus_diagonal(const Eigen::SparseMatrix<double>& A, double a,
                                          const Eigen::VectorXd& d) {
  Eigen::SparseMatrix<double> D(A.rows(), A.cols());
  std::vector<Eigen::Triplet<double>> trip;
  trip.reserve(d.size());
  for (Eigen::Index i = 0; i < d.size(); ++i) trip.emplace_back(int(i), int(i), d(i));
  D.setFromTriplets(trip.begin(), trip.end());
  Eigen::SparseMatrix<double> R = a * A + D;
  R.makeCompressed();
  return R;
}

}  // namespace

HeatGeodesics::HeatGeodesics(const Eigen::MatrixXd& V, const Eigen::MatrixXi& F, double t_factor)
    : V_(V), F_(F) {
  if (V.cols() != 3) throw InputError("HeatGeodesics: V must have 3 columns");
  if (F.cols() != 3 || F.rows() == 0) throw InputError("HeatGeodesics: F must be a non-empty m×3 matrix");
  if (F.minCoeff() < 0 || F.maxCoeff() >= V.rows())
    throw InputError("HeatGeodesics: face index out of range");
  if (!(t_factor > 0)) throw InputError("HeatGeodesics: t_factor must be positive");
  const Eigen::Index n = V.rows(), m = F.rows();

  const Eigen::SparseMatrix<double> L = cotan_laplacian(V, F);
  mass_ = lumped_mass(V, F);
  const Eigen::MatrixXi E = unique_edges(F);
  double h = 0;
  for (Eigen::Index e = 0; e < E.rows(); ++e) h += (V.row(E(e, 0)) - V.row(E(e, 1))).norm();
  h /= double(E.rows());
  if (!(h > 0)) throw InputError("HeatGeodesics: mesh has zero mean edge length");
  const double t = t_factor * h * h;

  // Vertices referenced by no face have zero mass and an empty Laplacian row: give them a
  // unit diagonal so that both systems stay positive definite (their distance is +inf).
  Eigen::VectorXd heat_diag = mass_, poisson_diag = (kPoissonEps / (h * h)) * mass_;
  for (Eigen::Index i = 0; i < n; ++i)
    if (!(mass_(i) > 0)) heat_diag(i) = poisson_diag(i) = 1.0;
  // (M + t L+) u = delta (Alg. 1, step I) with L+ the cotan Laplacian without its negative
  // weights: an M-matrix, so u > 0 everywhere (the maximum principle). With the cotan weights
  // as they are, u changes sign on non-Delaunay meshes (camel-gallop-03: 3,958 of 5,002
  // vertices negative from a foot; TOSCA's cat: 182 from vertex 0), the direction field
  // -grad u / |grad u| turns around there and the distances break (docs/methods.md).
  heat_.compute(plus_diagonal(drop_negative_weights(L), t, heat_diag));
  poisson_.compute(plus_diagonal(L, 1.0, poisson_diag)); // L phi = -div X      (Alg. 1, step III)

  area_.resize(m);
  cot_.resize(m, 3);
  for (auto& g : grad_) g.resize(m, 3);
#pragma omp parallel for schedule(static)
  for (Eigen::Index f = 0; f < m; ++f) {
    Eigen::Vector3d p[3];
    for (int c = 0; c < 3; ++c) p[c] = V.row(F(f, c));
    const Eigen::Vector3d nrm = (p[1] - p[0]).cross(p[2] - p[0]);
    const double two_area = nrm.norm();
    area_(f) = 0.5 * two_area;
    const Eigen::Vector3d N = two_area > 0 ? Eigen::Vector3d(nrm / two_area) : Eigen::Vector3d::Zero();
    for (int c = 0; c < 3; ++c) {
      // grad phi_c = N × e_c / (2A), e_c the edge opposite corner c, counter-clockwise.
      const Eigen::Vector3d e = p[(c + 2) % 3] - p[(c + 1) % 3];
      grad_[c].row(f) = two_area > 0 ? Eigen::Vector3d(N.cross(e) / two_area) : Eigen::Vector3d::Zero();
      const Eigen::Vector3d u = p[(c + 1) % 3] - p[c], v = p[(c + 2) % 3] - p[c];
      cot_(f, c) = two_area > 0 ? u.dot(v) / two_area : 0.0;
    }
  }
}

int HeatGeodesics::num_vertices() const { return int(V_.rows()); }

namespace {

// Steps II and III's right-hand side for one heat column u (n): writes -div X into rhs (n),
// with X = -grad u / |grad u| per face. buf is m×3 scratch. Faces are processed in parallel
// when `parallel` (the scatter into vertices is serial, so results do not depend on threads).
void negative_divergence(const Eigen::MatrixXd& V, const Eigen::MatrixXi& F,
                         const Eigen::MatrixXd* grad, const Eigen::MatrixXd& cot, const double* u,
                         double* rhs, Eigen::MatrixXd& buf, bool parallel) {
  const Eigen::Index m = F.rows(), n = V.rows();
  buf.resize(m, 3);
#pragma omp parallel for schedule(static) if (parallel)
  for (Eigen::Index f = 0; f < m; ++f) {
    const int i0 = F(f, 0), i1 = F(f, 1), i2 = F(f, 2);
    Eigen::Vector3d g = u[i0] * grad[0].row(f).transpose() + u[i1] * grad[1].row(f).transpose() +
                        u[i2] * grad[2].row(f).transpose();
    const double gn = g.norm();
    if (!(gn > 0)) {
      buf.row(f).setZero();
      continue;
    }
    const Eigen::Vector3d X = -g / gn;
    Eigen::Vector3d p[3];
    p[0] = V.row(i0);
    p[1] = V.row(i1);
    p[2] = V.row(i2);
    for (int c = 0; c < 3; ++c) {
      const int j = (c + 1) % 3, k = (c + 2) % 3;
      // (1/2) [cot(angle at k) (x_j - x_i).X + cot(angle at j) (x_k - x_i).X]   (Crane Eq. 4)
      buf(f, c) = 0.5 * (cot(f, k) * (p[j] - p[c]).dot(X) + cot(f, j) * (p[k] - p[c]).dot(X));
    }
  }
  std::fill(rhs, rhs + n, 0.0);
  for (Eigen::Index f = 0; f < m; ++f)
    for (int c = 0; c < 3; ++c) rhs[F(f, c)] -= buf(f, c);
}

void finish(Eigen::Ref<Eigen::VectorXd> phi, const std::vector<int>& sources,
            const Eigen::VectorXd& mass) {
  double lo = std::numeric_limits<double>::infinity();
  for (int s : sources) lo = std::min(lo, phi(s));
  phi.array() -= lo;
  for (Eigen::Index i = 0; i < phi.size(); ++i)
    if (!(mass(i) > 0)) phi(i) = std::numeric_limits<double>::infinity();
}

void check_sources(const std::vector<int>& sources, int n) {
  for (int s : sources)
    if (s < 0 || s >= n)
      throw InputError("HeatGeodesics: source vertex " + std::to_string(s) + " out of range [0," +
                       std::to_string(n) + ")");
}

}  // namespace

Eigen::VectorXd HeatGeodesics::distance(int source) const {
  return distance(std::vector<int>{source});
}

Eigen::VectorXd HeatGeodesics::distance(const std::vector<int>& sources) const {
  const int n = num_vertices();
  if (sources.empty()) throw InputError("HeatGeodesics: no source vertices");
  check_sources(sources, n);
  Eigen::VectorXd delta = Eigen::VectorXd::Zero(n);
  for (int s : sources) delta(s) = 1.0;
  const Eigen::VectorXd u = heat_.solve(delta);
  Eigen::VectorXd rhs(n);
  Eigen::MatrixXd buf;
  negative_divergence(V_, F_, grad_, cot_, u.data(), rhs.data(), buf, true);
  Eigen::VectorXd phi = poisson_.solve(rhs);
  finish(phi, sources, mass_);
  return phi;
}

Eigen::MatrixXd HeatGeodesics::distances(const std::vector<int>& sources) const {
  const int n = num_vertices();
  check_sources(sources, n);
  const int k = int(sources.size());
  Eigen::MatrixXd D(n, k);
  std::exception_ptr failure;
  // Parallel over sources; concurrent SparseCholesky::solve() calls on one factor are safe
  // (each uses its own cholmod_common). Each column is computed exactly as distance() does,
  // so results do not depend on the thread count. (Solving blocks of right-hand sides at
  // once was measured no faster per source with the reference BLAS.)
#pragma omp parallel
  {
    Eigen::MatrixXd buf;
    Eigen::VectorXd delta = Eigen::VectorXd::Zero(n), rhs(n);
#pragma omp for schedule(dynamic, 1)
    for (int c = 0; c < k; ++c) {
      try {
        delta(sources[c]) = 1.0;
        const Eigen::VectorXd u = heat_.solve(delta);
        delta(sources[c]) = 0.0;
        negative_divergence(V_, F_, grad_, cot_, u.data(), rhs.data(), buf, false);
        D.col(c) = poisson_.solve(rhs);
        finish(D.col(c), {sources[c]}, mass_);
      } catch (...) {
#pragma omp critical(shapemap_heat_distances)
        if (!failure) failure = std::current_exception();
      }
    }
  }
  if (failure) std::rethrow_exception(failure);
  return D;
}

}  // namespace shapemap
