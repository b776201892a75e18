// The preconditioned nonlinear CG of the ball parameterization (isovolumetric-ball-
// parameterization.txt, Algorithm 1 steps 13-38) as a solver object: the preconditioner
// factors, the spherical-coordinate frame and the current iterate live across iterations
// and across the calls of the driver (CG, stall fallback, post-step polishing), so each
// stage can be run, and tested, alone.
#pragma once
#include "shapemap/geometry/sparse_cholesky.h"
#include "shapemap/optim/lbfgs.h"
#include "shapemap/progress.h"
#include "shapemap/volume/ball_param.h"
#include <vector>

namespace shapemap {

class BallConjugateGradient {
 public:
  // energy: E_I on the tet mesh, numbered interior vertices 0..nI-1 first, then the
  // boundary nI..n-1 (the driver's permuted numbering); sbe: E_I over x built on it; Vp: n×3 the (scaled) input in that numbering, whose
  // L_V(e) is the preconditioner's fallback; opt: the CG options; stats: counters and
  // timings are added to it (iterations, restarts, evaluations, seconds_cg_*, ...).
  BallConjugateGradient(const IsovolumetricEnergy& energy, SphericalBallEnergy& sbe,
                        const Eigen::MatrixXd& Vp,
                        const BallParamOptions& opt, BallParamResult& stats,
                        const ProgressCallback& progress = {});

  // Steps 13-16: M = blockdiag(I3 (x) L_II, L_BB, S L_BB S) from L_V(f) (f n×3); when it
  // does not factor, from L_V(e) of Vp (counted in stats.preconditioner_fallbacks).
  void factor_preconditioner(const Eigen::MatrixXd& f);
  // M from L_V(e) of Vp (same pattern as the first factorization).
  void use_input_laplacian();
  bool preconditioner_is_input_laplacian() const { return m_is_input_laplacian_; }

  // Step 17: spherical coordinates of f in a pole-avoiding frame (opt.rotate_frame);
  // the iterate becomes x(f). Does not evaluate E (see evaluate_at_iterate).
  void start_from(const Eigen::MatrixXd& f);
  // The iterate becomes x (frame unchanged); E and g are evaluated there.
  void set_iterate(const Eigen::VectorXd& x);
  void evaluate_at_iterate();

  // Boundary-layer barrier (BallParamOptions::boundary_barrier) on or off; when the
  // barrier is used, E and g are re-evaluated at the iterate.
  void set_barrier(bool on);

  // Steps 18-38 from the iterate: at most max_iter iterations; guard: no step may raise
  // the number of inverted tets (BallParamOptions::prevent_new_folds). Stops on the
  // tolerance (stats.converged), a stall, or max_iter.
  void run(int max_iter, bool guard);

  // E_I (+ the fold penalty or barrier set on the energy) and its gradient, counted in
  // stats.evaluations and stats.seconds_cg_eval.
  double evaluate(const Eigen::VectorXd& x, Eigen::VectorXd& g);
  Objective objective() {
    return [this](const Eigen::VectorXd& x, Eigen::VectorXd& g) { return evaluate(x, g); };
  }

  const Eigen::VectorXd& x() const { return x_; }
  double energy() const { return E_; }

 private:
  void factor_blocks(const Eigen::MatrixXd& at, bool first);
  void refactor_at(const Eigen::VectorXd& x);
  Eigen::VectorXd choose_frame(const Eigen::MatrixXd& f);
  double min_sin_theta(const Eigen::VectorXd& x) const;
  void precondition(const Eigen::VectorXd& g, Eigen::VectorXd& h);
  double energy_only(const Eigen::VectorXd& x);
  // One step along p_ (step 32: Eq. 17's model step, else the strong Wolfe search of
  // Eq. 18; then the fold guard): false when no acceptable step was found, else xn_, gn_,
  // En, alpha hold the new point.
  bool line_step(double alpha_prev, double dphi0, bool guard, double& alpha, double& En);

  const IsovolumetricEnergy& energy_;
  SphericalBallEnergy& sbe_;
  Objective objective_;  // evaluate(), for the Wolfe search
  const Eigen::MatrixXd& Vp_;
  const BallParamOptions& opt_;
  BallParamResult& stats_;
  ProgressCallback progress_;
  const int nI_, nB_, N_;
  Eigen::SparseMatrix<double> L_;
  SparseCholesky cholI_, cholB_;
  bool m_is_input_laplacian_ = false;
  Eigen::MatrixXi Fb_;  // boundary faces in boundary-local numbering (frame choice)
  std::vector<int> all_faces_;
  Eigen::VectorXd s_phi_;  // S = diag(sin theta) of the frame's chart (phi block)
  double s_min_chart_ = 1;
  // Iterate, gradient, energy, inverted tets; search direction and M^{-1} g; trial point.
  Eigen::VectorXd x_, g_, h_, p_, xn_, gn_;
  double E_ = 0;
  int folds_ = 0;
  Eigen::MatrixXd gI01_, gI2_, gB_;  // right-hand sides of the two solve halves
};

}  // namespace shapemap
