// Untangling by the regularized energy of Garanzha et al. 2021 (foldover_free.h).
#include "shapemap/volume/foldover_free.h"
#include "shapemap/optim/lbfgs.h"
#include <Eigen/Dense>
#include <algorithm>
#include <cmath>
#include <limits>

namespace shapemap {

double foldover_chi(double D, double eps, double* dchi) {
  const double r = std::sqrt(eps * eps + D * D);
  // For D < 0, (D + r) / 2 cancels: the same value as eps^2 / (2 (r - D)), without the loss.
  const double chi = D >= 0 ? 0.5 * (D + r) : 0.5 * eps * eps / (r - D);
  if (dchi) *dchi = r > 0 ? chi / r : 0.5;  // (1 + D/r) / 2 = chi / r
  return chi;
}

double foldover_free_distortion(const Eigen::Matrix3d& J, double eps, double theta, Eigen::Matrix3d* dF) {
  // d det J / dJ: the cofactor matrix, columns b x c, c x a, a x b for J = [a b c]; defined
  // for every J (unlike det J J^-T).
  Eigen::Matrix3d cof;
  cof.col(0) = J.col(1).cross(J.col(2));
  cof.col(1) = J.col(2).cross(J.col(0));
  cof.col(2) = J.col(0).cross(J.col(1));
  const double D = J.col(0).dot(cof.col(0));
  double dchi = 0;
  const double chi = foldover_chi(D, eps, &dchi);
  const double tr = J.squaredNorm();
  const double c23 = std::cbrt(chi * chi);            // chi^(2/3)
  const double shape = tr / c23, volume = (D * D + 1.0) / chi;
  if (dF) {
    // d shape = 2J / chi^(2/3) - (2/3) tr chi^(-5/3) dchi cof; d volume = (2D/chi - (D^2+1)
    // dchi / chi^2) cof.
    const double ds_dD = -(2.0 / 3.0) * shape / chi * dchi;
    const double dv_dD = 2.0 * D / chi - volume / chi * dchi;
    *dF = (1.0 - theta) * (2.0 / c23) * J + ((1.0 - theta) * ds_dD + theta * dv_dD) * cof;
  }
  return (1.0 - theta) * shape + theta * volume;
}

namespace {

// untangle_foldover_free: rounds without progress count as a stall only below this eps
// (the folds that stalled on the real bench pairs sat at eps 1e-8 to 1e-6; folds that came
// undone after 60 rounds did so at eps ~0.03).
constexpr double kStallEps = 1e-4;

Eigen::Matrix3d jacobian(const Eigen::MatrixXd& Y, const Eigen::MatrixXi& T, int k, const Eigen::Matrix3d& Dm_inv) {
  Eigen::Matrix3d Ds;
  for (int j = 0; j < 3; ++j) Ds.col(j) = (Y.row(T(k, j + 1)) - Y.row(T(k, 0))).transpose();
  return Ds * Dm_inv;
}

double min_det(const ArapEnergy& rest, const std::vector<int>& tets, const Eigen::MatrixXd& Y) {
  double d = std::numeric_limits<double>::infinity();
  for (int k : tets) d = std::min(d, jacobian(Y, rest.tets(), k, rest.rest_inverse()[k]).determinant());
  return d;
}

}  // namespace

FoldoverFreeResult untangle_foldover_free(const ArapEnergy& rest, const std::vector<int>& tets,
                                          const std::vector<int>& free, const RowsTerm& extra,
                                          const FoldoverFreeOptions& opt, Eigen::MatrixXd& Y) {
  const Eigen::MatrixXi& T = rest.tets();
  const std::vector<Eigen::Matrix3d>& Dm_inv = rest.rest_inverse();
  const Eigen::VectorXd& w = rest.weights();
  const int m = int(tets.size());
  std::vector<double> e(m);
  std::vector<Eigen::Matrix<double, 3, 4>> g(m);
  double eps = 0;
  // Per-tet values in parallel, summed serially in tet order (deterministic).
  auto energy = [&](const Eigen::MatrixXd& X, Eigen::MatrixXd* grad) {
#pragma omp parallel for schedule(static)
    for (int q = 0; q < m; ++q) {
      const int k = tets[q];
      Eigen::Matrix3d dF;
      e[q] = w(k) * foldover_free_distortion(jacobian(X, T, k, Dm_inv[k]), eps, opt.theta, grad ? &dF : nullptr);
      if (grad) {
        const Eigen::Matrix3d dDs = w(k) * dF * Dm_inv[k].transpose();  // dE/dDs
        g[q].rightCols<3>() = dDs;
        g[q].col(0) = -dDs.rowwise().sum();
      }
    }
    double E = 0;
    if (grad) grad->setZero(X.rows(), 3);
    for (int q = 0; q < m; ++q) {
      E += e[q];
      if (grad)
        for (int c = 0; c < 4; ++c) grad->row(T(tets[q], c)) += g[q].col(c).transpose();
    }
    if (extra) E += extra(X, grad);
    return E;
  };
  FoldoverFreeResult res;
  double Dminus = min_det(rest, tets, Y);
  eps = std::sqrt(1e-12 + 0.04 * std::pow(std::min(Dminus, 0.0), 2));
  double best = Dminus;
  int stalled = 0;
  for (res.rounds = 0; res.rounds < opt.max_rounds && !(Dminus > opt.min_det) && stalled < opt.stall_rounds;
       ++res.rounds) {
    const double E_old = energy(Y, nullptr);
    minimize_rows(energy, Y, free, opt.lbfgs_iterations, opt.lbfgs_memory);
    const double E_new = energy(Y, nullptr);
    Dminus = min_det(rest, tets, Y);
    // A stall counts only once eps is small: while it is large, D- may wait for eps to fall.
    stalled = Dminus > best + 0.01 * std::abs(best) || eps > kStallEps ? 0 : stalled + 1;
    best = std::max(best, Dminus);
    // The paper's eps rule: eps follows the smallest det J down, faster when the
    // minimization made progress.
    const double sigma = std::max(1.0 - E_new / E_old, 0.1);
    const double mu = (1.0 - sigma) * foldover_chi(Dminus, eps);
    eps = Dminus < mu ? 2.0 * std::sqrt(mu * (mu - Dminus)) : 1e-10;
  }
  res.min_det = Dminus;
  res.eps = eps;
  return res;
}

FoldoverFreeResult untangle_in_target(const ArapEnergy& arap, const std::vector<std::vector<int>>& vv,
                                      const std::vector<char>& on_bd_i, const InTarget& target, int rings,
                                      double flat_det, const FoldoverFreeOptions& opt, Eigen::MatrixXd& Y) {
  const Eigen::MatrixXi& T = arap.tets();
  const int n = int(Y.rows());
  // The region: vertices of the flat or inverted tets, grown `rings` rings; its tets.
  const Eigen::VectorXd d = arap.determinants(Y);
  std::vector<char> in(n, 0);
  for (int k = 0; k < int(T.rows()); ++k)
    if (!(d(k) > flat_det))
      for (int c = 0; c < 4; ++c) in[T(k, c)] = 1;
  for (int r = 0; r < rings; ++r) {
    std::vector<char> grown = in;
    for (int v = 0; v < n; ++v)
      if (in[v])
        for (int u : vv[v]) grown[u] = 1;
    in.swap(grown);
  }
  std::vector<int> free, tets;
  for (int v = 0; v < n; ++v)
    if (in[v]) free.push_back(v);
  if (free.empty()) return {};
  for (int k = 0; k < int(T.rows()); ++k)
    if (in[T(k, 0)] || in[T(k, 1)] || in[T(k, 2)] || in[T(k, 3)]) tets.push_back(k);
  // Spring stiffness: w / e^2 is the ARAP stiffness of a typical tet (as the landing's
  // sliding repair), so the boundary springs stretch ~1% of an edge where the tets pull
  // hardest, and the outside springs 0.1%.
  const double w_mean = arap.weights().mean();
  double tet_volume = 0;  // mean rest volume: v_k = 1 / (6 |det Dm^-1|)
  for (const Eigen::Matrix3d& Dm_inv : arap.rest_inverse()) tet_volume += 1.0 / (6.0 * std::abs(Dm_inv.determinant()));
  tet_volume /= double(std::max<Eigen::Index>(T.rows(), 1));
  const double edge = std::cbrt(6.0 * std::sqrt(2.0) * tet_volume);
  const double k_in = 1e4 * w_mean / (edge * edge), k_out = 100.0 * k_in;
  const Eigen::MatrixXi& F = target.dMj.F;
  // Each row's last answers start its next queries (the same closest points, found visiting
  // far fewer boxes: on a glasses map with hundreds of folds these queries were ~70% of the
  // landing's 10 minutes).
  std::vector<int> tet_hint(free.size(), -1), tri_hint(free.size(), -1);
  RowsTerm springs = [&](const Eigen::MatrixXd& X, Eigen::MatrixXd* grad) {
    double E = 0;
    for (size_t i = 0; i < free.size(); ++i) {
      const int v = free[i];
      const Eigen::Vector3d y = X.row(v).transpose();
      const ClosestPointResult h = target.tets_j.locate(y, tet_hint[i]);
      tet_hint[i] = h.elem;
      if (h.sqdist > 0) {  // outside M_j
        Eigen::Vector3d p = Eigen::Vector3d::Zero();
        for (int c = 0; c < 4; ++c) p += h.bary(c) * target.Mj.V.row(target.Mj.T(h.elem, c)).transpose();
        E += k_out * (y - p).squaredNorm();
        if (grad) grad->row(v) += 2.0 * k_out * (y - p).transpose();
      }
      if (on_bd_i[v]) {
        const ClosestPointResult s = target.boundary_j.query(y, tri_hint[i]);
        tri_hint[i] = s.elem;
        Eigen::Vector3d p = Eigen::Vector3d::Zero();
        for (int c = 0; c < 3; ++c) p += s.bary(c) * target.dMj.V.row(F(s.elem, c)).transpose();
        E += k_in * (y - p).squaredNorm();
        if (grad) grad->row(v) += 2.0 * k_in * (y - p).transpose();
      }
    }
    return E;
  };
  return untangle_foldover_free(arap, tets, free, springs, opt, Y);
}

}  // namespace shapemap
