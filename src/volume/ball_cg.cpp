// Preconditioned nonlinear CG of Algorithm 1 (steps 13-38), see the header.
#include "shapemap/volume/ball_cg.h"
#include "shapemap/error.h"
#include "shapemap/optim/line_search.h"
#include "shapemap/timing.h"
#include <algorithm>
#include <cmath>
#include <exception>
#include <limits>
#include <numeric>

namespace shapemap {

namespace {
// Below this many vertices the preconditioner's solves run on one thread.
constexpr int kParallelSolveMin = 2000;
}  // namespace

BallConjugateGradient::BallConjugateGradient(const IsovolumetricEnergy& energy, SphericalBallEnergy& sbe,
                                             const Eigen::MatrixXd& Vp, const BallParamOptions& opt,
                                             BallParamResult& stats, const ProgressCallback& progress)
    : energy_(energy),
      sbe_(sbe),
      Vp_(Vp),
      opt_(opt),
      stats_(stats),
      progress_(progress),
      nI_(sbe.num_interior()),
      nB_(sbe.num_boundary()),
      N_(sbe.num_variables()),
      // Simplicial: the CG loop is solve-bound (two solves per iteration), see sparse_cholesky.h.
      cholI_(SparseCholesky::Method::Simplicial, SparseCholesky::Ordering::NestedDissection),
      cholB_(SparseCholesky::Method::Simplicial) {
  objective_ = objective();
  Fb_ = energy.boundary_faces();
  for (Eigen::Index k = 0; k < Fb_.rows(); ++k)
    for (int c = 0; c < 3; ++c) Fb_(k, c) -= nI_;
  all_faces_.resize(size_t(Fb_.rows()));
  std::iota(all_faces_.begin(), all_faces_.end(), 0);
  gI01_.resize(nI_, 2);
  gI2_.resize(nI_, 1);
  gB_.resize(nB_, 2);
}

// ------------------------------------------------------------ preconditioner (steps 13-16)
void BallConjugateGradient::factor_blocks(const Eigen::MatrixXd& at, bool first) {
  energy_.stretch_laplacian(at, L_);
  if (nI_ > 0) {
    Eigen::SparseMatrix<double> LII = L_.topLeftCorner(nI_, nI_);
    if (first) cholI_.compute(LII); else cholI_.factorize(LII);
  }
  Eigen::SparseMatrix<double> LBB = L_.bottomRightCorner(nB_, nB_);
  if (first) cholB_.compute(LBB); else cholB_.factorize(LBB);
}

// L_V(f) is positive semidefinite for every f (each tet adds (2 / (3|tau|)) G G^T), but
// collapsed image tets can make its blocks numerically singular, so that CHOLMOD fails.
// Then the preconditioner falls back to L_V(e) of the (scaled) input, which is only a
// preconditioner choice: the energy and its gradient are unchanged.
void BallConjugateGradient::factor_preconditioner(const Eigen::MatrixXd& f) {
  const auto t0 = Clock::now();
  try {
    factor_blocks(f, true);
  } catch (const Error&) {
    stats_.preconditioner_fallbacks++;
    factor_blocks(Vp_, true);
    m_is_input_laplacian_ = true;
  }
  stats_.seconds_factor = seconds_since(t0);
}

void BallConjugateGradient::use_input_laplacian() {
  factor_blocks(Vp_, false);
  m_is_input_laplacian_ = true;
}

// Re-factor the preconditioner blocks at the map of x (same pattern).
void BallConjugateGradient::refactor_at(const Eigen::VectorXd& x) {
  const auto tf = Clock::now();
  Eigen::MatrixXd fc;
  sbe_.to_map(x, fc);
  try {
    factor_blocks(fc, false);
    m_is_input_laplacian_ = false;
  } catch (const Error&) {
    stats_.preconditioner_fallbacks++;
    factor_blocks(Vp_, false);
    m_is_input_laplacian_ = true;
  }
  stats_.seconds_factor += seconds_since(tf);
}

// h = M^{-1} g with M = blockdiag(I3 (x) L_II, L_BB, S L_BB S) (Eq. 16, step 22).
void BallConjugateGradient::precondition(const Eigen::VectorXd& g, Eigen::VectorXd& h) {
  const auto ts = Clock::now();
  h.resize(N_);
  gI01_.col(0) = g.segment(0, nI_);
  gI01_.col(1) = g.segment(nI_, nI_);
  gI2_.col(0) = g.segment(2 * nI_, nI_);
  gB_.col(0) = g.segment(3 * nI_, nB_);
  gB_.col(1) = g.segment(3 * nI_ + nB_, nB_).cwiseQuotient(s_phi_);
  // The solves are independent and SparseCholesky::solve is safe to call concurrently:
  // two balanced halves (2 interior columns | 1 interior column + the boundary block).
  // An exception must not leave an OpenMP section (std::terminate): kept and rethrown.
  Eigen::MatrixXd hI01, hI2, hB;
  std::exception_ptr failure[2];
  const int n = nI_ + nB_;
#pragma omp parallel sections if (n > kParallelSolveMin)
  {
#pragma omp section
    try {
      if (nI_ > 0) hI01 = cholI_.solve(gI01_);
    } catch (...) {
      failure[0] = std::current_exception();
    }
#pragma omp section
    try {
      if (nI_ > 0) hI2 = cholI_.solve(gI2_);
      hB = cholB_.solve(gB_);
    } catch (...) {
      failure[1] = std::current_exception();
    }
  }
  for (const auto& e : failure)
    if (e) std::rethrow_exception(e);
  if (nI_ > 0) {
    h.segment(0, nI_) = hI01.col(0);
    h.segment(nI_, nI_) = hI01.col(1);
    h.segment(2 * nI_, nI_) = hI2.col(0);
  }
  h.segment(3 * nI_, nB_) = hB.col(0);
  h.segment(3 * nI_ + nB_, nB_) = hB.col(1).cwiseQuotient(s_phi_);
  stats_.seconds_cg_solve += seconds_since(ts);
}

// ------------------------------------------------------------ frame (step 17)
Eigen::VectorXd BallConjugateGradient::choose_frame(const Eigen::MatrixXd& f) {
  if (opt_.rotate_frame) sbe_.set_frame(pole_avoiding_frame(f.bottomRows(nB_), Fb_));
  Eigen::VectorXd x = sbe_.from_map(f);
  s_phi_.resize(nB_);
  for (int b = 0; b < nB_; ++b)
    s_phi_(b) = opt_.metric_phi_preconditioner ? std::max(1e-3, std::sin(x(3 * nI_ + b))) : 1.0;
  return x;
}

// Smallest sin(theta) over the boundary: the pole guard compares it with the chart's
// value at the last frame choice (whatever the phi preconditioner block).
double BallConjugateGradient::min_sin_theta(const Eigen::VectorXd& x) const {
  double smin = 1;
  for (int b = 0; b < nB_; ++b) smin = std::min(smin, std::abs(std::sin(x(3 * nI_ + b))));
  return smin;
}

void BallConjugateGradient::start_from(const Eigen::MatrixXd& f) {
  x_ = choose_frame(f);
  s_min_chart_ = std::max(1e-3, min_sin_theta(x_));
  g_.resize(N_);
  h_.resize(N_);
  p_.resize(N_);
  xn_.resize(N_);
  gn_.resize(N_);
}

void BallConjugateGradient::evaluate_at_iterate() { E_ = evaluate(x_, g_); }

void BallConjugateGradient::set_iterate(const Eigen::VectorXd& x) {
  x_ = x;
  evaluate_at_iterate();
}

void BallConjugateGradient::set_barrier(bool on) {
  if (opt_.boundary_barrier <= 0) return;
  if (on)
    sbe_.set_fold_penalty(opt_.boundary_barrier, opt_.penalty_floor, all_faces_);
  else
    sbe_.set_fold_penalty(0, 0);
  evaluate_at_iterate();
}

// ------------------------------------------------------------ evaluations
double BallConjugateGradient::evaluate(const Eigen::VectorXd& x, Eigen::VectorXd& g) {
  const auto te = Clock::now();
  ++stats_.evaluations;
  const double e = sbe_.energy_and_gradient(x, g);
  stats_.seconds_cg_eval += seconds_since(te);
  return e;
}

double BallConjugateGradient::energy_only(const Eigen::VectorXd& x) {
  const auto te = Clock::now();
  ++stats_.evaluations;
  const double e = sbe_.energy(x);
  stats_.seconds_cg_eval += seconds_since(te);
  return e;
}

// ------------------------------------------------------------ CG (steps 18-38)
bool BallConjugateGradient::line_step(double alpha_prev, double dphi0, bool guard, double& alpha,
                                      double& En) {
  // Step 32: alpha by the quadratic model through Phi(0), Phi'(0), Phi(alpha_prev) (Eq. 17).
  alpha = -1;
  {
    xn_ = x_ + alpha_prev * p_;
    const double Ea = energy_only(xn_);
    const double denom = 2 * (Ea - E_ - alpha_prev * dphi0);
    if (std::isfinite(Ea) && denom > 0) alpha = -alpha_prev * alpha_prev * dphi0 / denom;
  }
  En = std::numeric_limits<double>::infinity();
  bool accepted = false;
  if (alpha > 0 && std::isfinite(alpha)) {
    xn_ = x_ + alpha * p_;
    En = evaluate(xn_, gn_);
    accepted = En < E_;
    // Optionally require the strong Wolfe conditions (Eq. 18) of the model step too.
    if (accepted && opt_.wolfe_model_step)
      accepted = En <= E_ + opt_.c1 * alpha * dphi0 && std::abs(gn_.dot(p_)) <= -opt_.c2 * dphi0;
  }
  if (accepted) {
    ++stats_.quadratic_steps;
  } else {
    // Fallback: strong Wolfe line search (Eq. 18), from the model step if it was usable.
    const double a0 = (alpha > 0 && std::isfinite(alpha)) ? alpha : alpha_prev;
    LineSearchResult ls = strong_wolfe_search(objective_, x_, E_, g_, p_, a0, opt_.c1, opt_.c2,
                                              opt_.max_line_search, xn_, gn_);
    if (!ls.ok || !(ls.f < E_)) return false;
    alpha = ls.alpha;
    En = ls.f;
    ++stats_.wolfe_steps;
  }
  if (!guard) return true;
  // Guard: no step may increase the number of inverted tets. Halve by the fold count
  // alone (one volume pass); E and g once, at the final step.
  int fn = sbe_.inverted_tets(xn_);
  int tries = 0;
  while (fn > folds_ && tries < 30) {
    alpha *= 0.5;
    xn_ = x_ + alpha * p_;
    fn = sbe_.inverted_tets(xn_);
    ++tries;
    ++stats_.fold_backtracks;
  }
  if (tries > 0) En = evaluate(xn_, gn_);
  if (fn > folds_ || !(En < E_)) return false;
  folds_ = fn;
  return true;
}

void BallConjugateGradient::run(int max_iter, bool guard) {
  folds_ = sbe_.inverted_tets(x_);
  precondition(g_, h_);
  double lambda = g_.dot(h_);  // step 24
  p_ = -h_;                    // step 25
  double alpha_prev = opt_.initial_step;
  bool steepest = true;  // p == -M^{-1} g
  for (int k = 0; k < max_iter; ++k) {
    double dphi0 = g_.dot(p_);
    if (!(dphi0 < 0)) {  // not a descent direction: restart along -M^{-1} g
      p_ = -h_;
      dphi0 = -lambda;
      ++stats_.restarts;
      steepest = true;
      if (!(dphi0 < 0)) break;  // zero gradient
    }
    double alpha = 0, En = 0;
    if (!line_step(alpha_prev, dphi0, guard, alpha, En)) {
      if (steepest) break;  // no progress even along -M^{-1} g
      p_ = -h_;
      ++stats_.restarts;
      steepest = true;
      continue;
    }
    // Steps 33-37.
    const double delta = E_ - En;
    x_.swap(xn_);
    g_.swap(gn_);
    E_ = En;
    alpha_prev = alpha;
    ++stats_.iterations;
    stats_.energies.push_back(E_);
    report(progress_, "ball/cg", double(k + 1) / std::max(1, max_iter));
    if (delta < opt_.tolerance) {
      stats_.converged = true;
      break;
    }
    // Pole guard: a boundary vertex close to a pole of the frame -> new frame, restart.
    bool new_frame = false;
    if (opt_.rotate_frame && min_sin_theta(x_) < opt_.pole_guard * s_min_chart_) {
      Eigen::MatrixXd f;
      sbe_.to_map(x_, f);
      x_ = choose_frame(f);
      s_min_chart_ = std::max(1e-3, min_sin_theta(x_));
      E_ = evaluate(x_, g_);
      ++stats_.frame_rotations;
      new_frame = true;
    }
    // Steps 22, 27-30: h = M^{-1} g, beta = lambda / lambda_0 (Eq. 16c), p = -h + beta p.
    precondition(g_, h_);
    const double lambda0 = lambda;
    lambda = g_.dot(h_);
    if (opt_.preconditioner_refresh > 0 && (k + 1) % opt_.preconditioner_refresh == 0) {
      refactor_at(x_);
      new_frame = true;  // restart: M changed
      ++stats_.preconditioner_refreshes;
      precondition(g_, h_);
      lambda = g_.dot(h_);
    }
    if (new_frame) {
      p_ = -h_;
      ++stats_.restarts;
      steepest = true;
    } else {
      const double beta = lambda / lambda0;
      p_ = -h_ + beta * p_;
      steepest = false;
    }
  }
}

}  // namespace shapemap
