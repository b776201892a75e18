// Isovolumetric energy minimization for ball-shaped volume-preserving parameterizations
// (isovolumetric-ball-parameterization.txt, Algorithm 1). See the header and
// docs/methods.md for the deviations (pole handling, phi preconditioner block).
#include "shapemap/volume/ball_param.h"
#include "shapemap/checks.h"
#include "shapemap/error.h"
#include "shapemap/optim/lbfgs.h"
#include "shapemap/timing.h"
#include "shapemap/volume/ball_cg.h"
#include "shapemap/volume/untangle.h"
#include <Eigen/Geometry>
#include <algorithm>
#include <cmath>
#include <ctime>
#include <memory>
#include <numeric>

namespace shapemap {


// ------------------------------------------------------------ SphericalBallEnergy
SphericalBallEnergy::SphericalBallEnergy(const IsovolumetricEnergy& energy,
                                         const Eigen::VectorXi& interior,
                                         const Eigen::VectorXi& boundary)
    : E_(energy), interior_(interior), boundary_(boundary) {
  nI_ = int(interior.size());
  nB_ = int(boundary.size());
  if (nI_ + nB_ != energy.num_vertices())
    throw InputError("SphericalBallEnergy: interior + boundary must cover all vertices");
  f_.setZero(energy.num_vertices(), 3);
}

void SphericalBallEnergy::to_map(const Eigen::VectorXd& x, Eigen::MatrixXd& f) const {
  f.resize(E_.num_vertices(), 3);
  for (int i = 0; i < nI_; ++i)
    for (int d = 0; d < 3; ++d) f(interior_(i), d) = x(d * nI_ + i);
  const Eigen::Matrix3d Qt = Q_.transpose();
  for (int b = 0; b < nB_; ++b) {
    const double th = x(3 * nI_ + b), ph = x(3 * nI_ + nB_ + b);
    const Eigen::Vector3d s(std::sin(th) * std::cos(ph), std::sin(th) * std::sin(ph), std::cos(th));
    f.row(boundary_(b)) = (Qt * s).transpose();  // Eq. 4 in the frame Q
  }
}

Eigen::VectorXd SphericalBallEnergy::from_map(const Eigen::MatrixXd& f) const {
  Eigen::VectorXd x(num_variables());
  for (int i = 0; i < nI_; ++i)
    for (int d = 0; d < 3; ++d) x(d * nI_ + i) = f(interior_(i), d);
  for (int b = 0; b < nB_; ++b) {
    Eigen::Vector3d y = Q_ * f.row(boundary_(b)).transpose();
    y.normalize();
    x(3 * nI_ + b) = std::acos(std::clamp(y.z(), -1.0, 1.0));  // Eq. 5
    x(3 * nI_ + nB_ + b) = std::atan2(y.y(), y.x());
  }
  return x;
}

double SphericalBallEnergy::energy(const Eigen::VectorXd& x) const {
  to_map(x, f_);
  return E_.energy(f_) + (mu_ > 0 ? fold_penalty(f_, nullptr) : 0.0);
}

double SphericalBallEnergy::fold_penalty(const Eigen::MatrixXd& f, Eigen::MatrixXd* G) const {
  const Eigen::MatrixXi& T = E_.tets();
  const Eigen::VectorXd& vol = E_.domain_volumes();
  const double scale = floor_ * (4.0 * M_PI / 3.0) / E_.domain_volume();
  double P = 0;
  // Serial: only the few tets below the floor contribute, the loop is memory-bound.
  for (Eigen::Index t = 0; t < T.rows(); ++t) {
    const Eigen::Vector3d a = f.row(T(t, 0)), b = f.row(T(t, 1)), c = f.row(T(t, 2)), d = f.row(T(t, 3));
    const Eigen::Vector3d gb = (c - a).cross(d - a) / 6.0;  // d|f(tau)| / d f_b
    const double v = (b - a).dot(gb);
    const double gap = scale * vol(t) - v;
    if (!(gap > 0)) continue;
    P += mu_ * gap * gap / vol(t);
    if (!G) continue;
    const double w = -2.0 * mu_ * gap / vol(t);
    const Eigen::Vector3d gc = (d - a).cross(b - a) / 6.0, gd = (b - a).cross(c - a) / 6.0;
    G->row(T(t, 1)) += w * gb.transpose();
    G->row(T(t, 2)) += w * gc.transpose();
    G->row(T(t, 3)) += w * gd.transpose();
    G->row(T(t, 0)) -= w * (gb + gc + gd).transpose();
  }
  if (!penalty_faces_.empty()) {
    const Eigen::MatrixXi& Fb = E_.boundary_faces();
    const double target = 2.0 * 4.0 * M_PI / double(Fb.rows());  // det of a mean face
    for (int q : penalty_faces_) {
      const Eigen::Vector3d a = f.row(Fb(q, 0)), b = f.row(Fb(q, 1)), c = f.row(Fb(q, 2));
      const double gap = floor_ * target - a.dot(b.cross(c));
      if (!(gap > 0)) continue;
      P += mu_ * gap * gap / target;
      if (!G) continue;
      const double w = -2.0 * mu_ * gap / target;
      G->row(Fb(q, 0)) += w * b.cross(c).transpose();
      G->row(Fb(q, 1)) += w * c.cross(a).transpose();
      G->row(Fb(q, 2)) += w * a.cross(b).transpose();
    }
  }
  return P;
}

int SphericalBallEnergy::inverted_tets(const Eigen::VectorXd& x) const {
  to_map(x, f_);
  Eigen::VectorXd vol;
  E_.image_volumes(f_, vol);
  return int((vol.array() <= 0).count());
}

double SphericalBallEnergy::energy_and_gradient(const Eigen::VectorXd& x, Eigen::VectorXd& g) const {
  to_map(x, f_);
  double e = E_.energy_and_gradient(f_, G_);
  if (mu_ > 0) e += fold_penalty(f_, &G_);
  g.resize(num_variables());
  for (int i = 0; i < nI_; ++i)
    for (int d = 0; d < 3; ++d) g(d * nI_ + i) = G_(interior_(i), d);  // Eq. 10a
  for (int b = 0; b < nB_; ++b) {
    const double th = x(3 * nI_ + b), ph = x(3 * nI_ + nB_ + b);
    const double st = std::sin(th), ct = std::cos(th), sp = std::sin(ph), cp = std::cos(ph);
    const Eigen::Vector3d Gb = Q_ * G_.row(boundary_(b)).transpose();
    g(3 * nI_ + b) = ct * cp * Gb.x() + ct * sp * Gb.y() - st * Gb.z();  // Eq. 10b
    g(3 * nI_ + nB_ + b) = -st * sp * Gb.x() + st * cp * Gb.y();        // Eq. 10c
  }
  return e;
}

// ------------------------------------------------------------ pole-avoiding frame
Eigen::Matrix3d pole_avoiding_frame(const Eigen::MatrixXd& Y, const Eigen::MatrixXi& F) {
  const Eigen::Index k = Y.rows();
  auto score = [&](const Eigen::Vector3d& a) {
    double s = 1;
    for (Eigen::Index b = 0; b < k; ++b) s = std::min(s, 1 - std::abs(a.dot(Y.row(b).transpose())));
    return s;
  };
  // Candidates: normalized face centroids ranked by their local empty-cap size.
  std::vector<std::pair<double, int>> cand;
  cand.reserve(F.rows());
  for (Eigen::Index f = 0; f < F.rows(); ++f) {
    Eigen::Vector3d c = (Y.row(F(f, 0)) + Y.row(F(f, 1)) + Y.row(F(f, 2))).transpose();
    if (!(c.norm() > 0)) continue;
    c.normalize();
    double r = 1;
    for (int j = 0; j < 3; ++j) r = std::min(r, 1 - std::abs(c.dot(Y.row(F(f, j)).transpose())));
    cand.push_back({-r, int(f)});
  }
  const size_t K = std::min<size_t>(64, cand.size());
  std::partial_sort(cand.begin(), cand.begin() + K, cand.end());
  Eigen::Vector3d best = Eigen::Vector3d::UnitZ();
  double best_s = score(best);
  for (size_t i = 0; i < K; ++i) {
    const int f = cand[i].second;
    Eigen::Vector3d c = (Y.row(F(f, 0)) + Y.row(F(f, 1)) + Y.row(F(f, 2))).transpose();
    c.normalize();
    const double s = score(c);
    if (s > best_s) {
      best_s = s;
      best = c;
    }
  }
  // Rows e1, e2, e3 = best: Q best = e_z, det Q = +1.
  Eigen::Vector3d e3 = best;
  Eigen::Vector3d t = std::abs(e3.x()) < 0.9 ? Eigen::Vector3d::UnitX() : Eigen::Vector3d::UnitY();
  Eigen::Vector3d e1 = (t - t.dot(e3) * e3).normalized();
  Eigen::Vector3d e2 = e3.cross(e1);
  Eigen::Matrix3d Q;
  Q.row(0) = e1.transpose();
  Q.row(1) = e2.transpose();
  Q.row(2) = e3.transpose();
  return Q;
}

// ------------------------------------------------------------ Algorithm 1
namespace {

// One run of Algorithm 1 plus the post-step, one method per stage. State that lives across
// stages (the scaled input, the permuted numbering, the energies, the CG solver) is held
// here; the CG iteration itself is BallConjugateGradient (ball_cg.h).
class BallParameterization {
 public:
  BallParameterization(const TetMesh& mesh, const BallParamOptions& opt, const ProgressCallback& progress)
      : mesh_(mesh), opt_(opt), progress_(progress), n_(mesh.num_vertices()) {}

  // Steps 1-3: AST (Eqs. 11-13).
  void scale_anisotropically() {
    V_ = mesh_.V;
    if (opt_.anisotropic_scaling) {
      res_.ast = anisotropic_scaling(mesh_.V);
      V_ = res_.ast.apply(mesh_.V);
    }
  }

  // Step 5: B and I; step 6: spherical area-preserving boundary map; steps 7-13: VSEM.
  // start: a previous run on the same mesh whose boundary map and VSEM result are reused
  // (steps 6-13 do not depend on the CG options), or null.
  void map_boundary_and_vsem(const BallParamResult* start) {
    TetMesh am;
    am.V = V_;
    am.T = mesh_.T;
    const TetBoundary tb = boundary_surface(am);
    res_.boundary = tb.to_volume;
    if (start) {
      res_.sphere_folded_faces = start->sphere_folded_faces;
      res_.sphere_start = start->sphere_start;
      res_.sphere_area_distortion_mean = start->sphere_area_distortion_mean;
      res_.sphere_area_distortion_max = start->sphere_area_distortion_max;
      res_.f_vsem = start->f_vsem;
      return;
    }
    const auto t0 = Clock::now();
    const SphereParamResult sph = spherical_area_preserving_map(tb.surface, {}, opt_.sphere, progress_);
    res_.seconds_sphere = seconds_since(t0);
    res_.sphere_folded_faces = sph.folded_faces;
    // A CEM stage that took no step left the linear map: report that start as linear.
    res_.sphere_start = sph.start_stage == 0 && sph.conformal_iterations == 0 ? 1 : sph.start_stage;
    res_.sphere_area_distortion_mean = sph.area_distortion_mean;
    res_.sphere_area_distortion_max = sph.area_distortion_max;
    VsemOptions vo;
    vo.iterations = opt_.vsem_iterations;
    const VsemResult vs = vsem_fixed_point(V_, mesh_.T, tb.to_volume, sph.S, vo, progress_);
    res_.seconds_vsem = vs.seconds;
    res_.f_vsem = vs.f;
  }

  // Interior vertices first (x = [f_I; theta; phi], Eq. 14): E_I on the renumbered mesh.
  void number_interior_first() {
    const int nB = int(res_.boundary.size());
    std::vector<char> isb(n_, 0);
    for (int b = 0; b < nB; ++b) isb[res_.boundary(b)] = 1;
    Eigen::VectorXi iperm;
    nI_ = interior_first_order(isb, perm_, iperm, &V_);
    Tp_ = renumber_tets(mesh_.T, perm_);
    Vp_.resize(n_, 3);
    fp_.resize(n_, 3);
    for (int i = 0; i < n_; ++i) {
      Vp_.row(perm_(i)) = V_.row(i);
      fp_.row(perm_(i)) = res_.f_vsem.row(i);
    }
    energy_ = std::make_unique<IsovolumetricEnergy>(Vp_, Tp_);
    Eigen::VectorXi interior(nI_), boundary(nB);
    std::iota(interior.data(), interior.data() + nI_, 0);
    std::iota(boundary.data(), boundary.data() + nB, nI_);
    sbe_ = std::make_unique<SphericalBallEnergy>(*energy_, interior, boundary);
    cg_ = std::make_unique<BallConjugateGradient>(*energy_, *sbe_, Vp_, opt_, res_, progress_);
  }

  // Steps 13-38: preconditioner of L_V(f^(0)), frame, preconditioned nonlinear CG; then
  // the stall fallback.
  void conjugate_gradient() {
    cg_->factor_preconditioner(fp_);
    cg_->start_from(fp_);
    const auto t_cg = Clock::now();
    const std::clock_t c_cg = std::clock();
    cg_->evaluate_at_iterate();
    res_.inverted_vsem = sbe_->inverted_tets(cg_->x());
    res_.energy_vsem = cg_->energy();
    // Boundary-layer barrier on during CG (E, g and the stopping test see E_I + barrier);
    // E is re-evaluated without it afterwards.
    cg_->set_barrier(true);
    cg_->run(opt_.max_iterations, opt_.prevent_new_folds);
    cg_->set_barrier(false);
    // A heavily folded VSEM map (long thin parts) can give an L_V(f^(0)) that factors but
    // is nearly singular: M^{-1} g is then huge (measured 1e9 on a pair of glasses) and the
    // model steps tiny, so CG stops early or crawls. A healthy run lowers E_I by an order
    // of magnitude, so when CG left E_I above half its start with inverted tets, CG runs
    // again (MaxIter more iterations) with the L_V(e) preconditioner of the factorization
    // fallback (measured on a bent thin tube: E_I after CG 6.03 -> 0.279 of 6.20). E is
    // compared without the barrier, like energy_vsem.
    if (opt_.stall_preconditioner_fallback && !cg_->preconditioner_is_input_laplacian() &&
        cg_->energy() > 0.5 * res_.energy_vsem && sbe_->inverted_tets(cg_->x()) > 0) {
      res_.preconditioner_fallbacks++;
      cg_->use_input_laplacian();
      res_.converged = false;
      cg_->set_barrier(true);
      cg_->run(opt_.max_iterations, opt_.prevent_new_folds);
      cg_->set_barrier(false);
    }
    res_.seconds_cg = seconds_since(t_cg);
    res_.cpu_seconds_cg = double(std::clock() - c_cg) / CLOCKS_PER_SEC;
    sbe_->to_map(cg_->x(), f_);
    E_ = cg_->energy();
    res_.inverted_cg = sbe_->inverted_tets(cg_->x());
    res_.energy_cg = E_;
    // Boundary faces whose image triangle is negatively oriented seen from the origin
    // (reported, not repaired here; see boundary_barrier and docs/methods.md).
    res_.flipped_boundary_faces_cg = spherical_folded_faces(f_, energy_->boundary_faces());
  }

  // Post-step (docs/methods.md): (1) local untangling of the remaining folded tets; (2) if
  // folds remain, L-BFGS on E_I + fold penalty (tets, and boundary faces next to the folds)
  // with the weight raised tenfold per round until none is left; (3) CG polishing (with the
  // boundary barrier if on) in which no step may increase the number of folded tets. Each
  // stage is kept only if it lowers the fold count and its E_I is not above the VSEM
  // start's (or the CG result's, if higher): on a pair of glasses (120k tets) the penalty
  // rounds traded 5080 -> 1847 folds for E_I 4.6 -> 781 with interior vertices at radius
  // 75, which is no ball map.
  void repair() {
    if (!(res_.inverted_cg > 0 && (opt_.untangle_rounds > 0 || opt_.penalty_rounds > 0))) return;
    const auto t_post = Clock::now();
    // The cost split reports the CG loop of Algorithm 1 only; the post-step has its own time.
    const double eval_cg = res_.seconds_cg_eval, solve_cg = res_.seconds_cg_solve;
    const bool converged = res_.converged;
    const int it0 = res_.iterations;
    // E_I bound for the stages (the CG result can exceed E_vsem only with the barrier on).
    e_cap_ = std::max(res_.energy_vsem, energy_->energy(f_));
    int now = res_.inverted_cg;
    if (opt_.untangle_rounds > 0) untangle(now);
    if (now > 0 && opt_.penalty_rounds > 0) penalize_folds(now);
    if (now < res_.inverted_cg && opt_.polish_iterations > 0) polish(now);
    res_.polish_iterations = res_.iterations - it0;
    res_.converged = converged;
    E_ = energy_->energy(f_);
    res_.seconds_post = seconds_since(t_post);
    res_.seconds_cg_eval = eval_cg;
    res_.seconds_cg_solve = solve_cg;
  }

  BallParamResult finish() {
    res_.flipped_boundary_faces_final = spherical_folded_faces(f_, energy_->boundary_faces());
    res_.inverted_final = count_folds(f_);
    res_.energy_final = E_;
    res_.f.resize(n_, 3);
    for (int i = 0; i < n_; ++i) res_.f.row(i) = f_.row(perm_(i));
    report(progress_, "ball/cg", 1.0);
    return std::move(res_);
  }

 private:
  int count_folds(const Eigen::MatrixXd& fm) const {
    Eigen::VectorXd vol;
    energy_->image_volumes(fm, vol);
    return int((vol.array() <= 0).count());
  }
  // Keep a repair stage's map fu when it has fewer folds than now and E_I within the cap.
  void keep_if_better(Eigen::MatrixXd& fu, int k, int& now) {
    if (k < now && energy_->energy(fu) <= e_cap_) {
      f_ = fu;
      now = k;
    }
  }

  // Repair (1): local untangling (untangle.h).
  void untangle(int& now) {
    Eigen::MatrixXd fu = f_;
    untangle_ball_map(Tp_, nI_, opt_.untangle_rounds, fu);
    keep_if_better(fu, count_folds(fu), now);
  }

  // Repair (2): L-BFGS rounds on E_I + fold penalty of weight penalty_weight * 10^r.
  // Boundary faces at the vertices of folded tets are penalized too (their image
  // orientation on the sphere, same floor): a fold next to a locally folded boundary cannot
  // be removed by the tet term alone (measured: creature seed 2).
  void penalize_folds(int& now) {
    Eigen::VectorXd x = sbe_->from_map(f_);
    const Eigen::MatrixXi& Fo = energy_->boundary_faces();
    std::vector<int> faces;
    {
      Eigen::VectorXd vol;
      energy_->image_volumes(f_, vol);
      std::vector<char> near(n_, 0);
      for (Eigen::Index t = 0; t < Tp_.rows(); ++t)
        if (!(vol(t) > 0))
          for (int c = 0; c < 4; ++c) near[Tp_(t, c)] = 1;
      for (Eigen::Index q = 0; q < Fo.rows(); ++q)
        if (near[Fo(q, 0)] || near[Fo(q, 1)] || near[Fo(q, 2)]) faces.push_back(int(q));
    }
    Eigen::MatrixXd fu = f_;
    double mu = opt_.penalty_weight;
    int k = now;
    for (int r = 0; r < opt_.penalty_rounds && k > 0; ++r, mu *= 10) {
      sbe_->set_fold_penalty(mu, opt_.penalty_floor, faces);
      LbfgsOptions lo;
      lo.max_iterations = opt_.polish_iterations;
      lo.grad_tol = 0;
      const LbfgsResult lr = lbfgs_minimize(cg_->objective(), x, lo);
      res_.iterations += lr.iterations;
      sbe_->to_map(x, fu);
      k = count_folds(fu);
      ++res_.penalty_rounds;
    }
    sbe_->set_fold_penalty(0, 0);
    keep_if_better(fu, k, now);
  }

  // Repair (3): fold-guarded CG polishing.
  void polish(int now) {
    cg_->set_iterate(sbe_->from_map(f_));
    cg_->set_barrier(true);
    cg_->run(opt_.polish_iterations, true);
    cg_->set_barrier(false);
    Eigen::MatrixXd fu;
    sbe_->to_map(cg_->x(), fu);
    if (count_folds(fu) <= now && energy_->energy(fu) <= e_cap_) f_.swap(fu);
  }

  const TetMesh& mesh_;
  const BallParamOptions& opt_;
  const ProgressCallback& progress_;
  const int n_;
  BallParamResult res_;
  Eigen::MatrixXd V_;             // input after AST
  int nI_ = 0;                    // interior vertices (numbered first)
  Eigen::VectorXi perm_;          // input vertex -> permuted index
  Eigen::MatrixXi Tp_;            // tets in the permuted numbering
  Eigen::MatrixXd Vp_, fp_;       // scaled input and VSEM map, permuted
  std::unique_ptr<IsovolumetricEnergy> energy_;
  std::unique_ptr<SphericalBallEnergy> sbe_;
  std::unique_ptr<BallConjugateGradient> cg_;
  Eigen::MatrixXd f_;             // current map (permuted numbering)
  double E_ = 0;                  // its E_I (as reported in energy_final)
  double e_cap_ = 0;              // E_I bound of the repair stages
};

BallParamResult ball_parameterization_once(const TetMesh& mesh, const BallParamOptions& opt,
                                           const ProgressCallback& progress, const std::string& name,
                                           const BallParamResult* start) {
  const auto t_start = Clock::now();
  require_valid_volume(mesh, name, 0.0);
  require_ball_topology(mesh, name);
  BallParameterization alg(mesh, opt, progress);
  alg.scale_anisotropically();
  alg.map_boundary_and_vsem(start);
  alg.number_interior_first();
  alg.conjugate_gradient();
  alg.repair();
  BallParamResult res = alg.finish();
  res.seconds_total = seconds_since(t_start);
  return res;
}

}  // namespace

BallParamResult ball_parameterization(const TetMesh& mesh, const BallParamOptions& opt,
                                      const ProgressCallback& progress, const std::string& name) {
  BallParamResult res = ball_parameterization_once(mesh, opt, progress, name, nullptr);
  if (res.inverted_final == 0 || opt.boundary_barrier > 0 || !(opt.fold_retry_barrier > 0)) return res;
  // Inverted tets left after the post-step: the boundary layer of thin parts folded over
  // during CG. CG again from the same VSEM start with the boundary-layer barrier, which
  // keeps that layer from folding.
  BallParamOptions retry = opt;
  retry.boundary_barrier = opt.fold_retry_barrier;
  BallParamResult r2;
  try {
    r2 = ball_parameterization_once(mesh, retry, progress, name, &res);
  } catch (const Error&) {
    return res;  // the first run stands
  }
  const bool better = r2.inverted_final < res.inverted_final ||
                      (r2.inverted_final == res.inverted_final && r2.energy_final < res.energy_final);
  const int before = res.inverted_final;
  const double retry_seconds = r2.seconds_total, seconds = res.seconds_total + retry_seconds;
  if (better) {
    r2.seconds_sphere = res.seconds_sphere;  // the kept map's boundary map and VSEM are the first run's
    r2.seconds_vsem = res.seconds_vsem;
    res = std::move(r2);
  }
  res.fold_retry = true;
  res.fold_retry_kept = better;
  res.inverted_before_retry = before;
  res.seconds_retry = retry_seconds;
  res.seconds_total = seconds;
  return res;
}

}  // namespace shapemap
