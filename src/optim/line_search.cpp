// Line searches along a descent direction: strong Wolfe (Nocedal & Wright, Numerical
// Optimization 2nd ed., Algorithm 3.5 with the zoom of Algorithm 3.6 and the cubic
// interpolation of Eq. 3.59, safeguarded) and Armijo backtracking.
// Neither allocates: x_new and g_new are the caller's buffers (sized like x).
#include "shapemap/optim/line_search.h"

#include <algorithm>
#include <cmath>

namespace shapemap {

namespace {

// phi(alpha) = f(x + alpha d) and phi'(alpha) = g(x + alpha d).d, into x_new / g_new.
struct Phi {
  const Objective& f;
  const Eigen::VectorXd& x;
  const Eigen::VectorXd& d;
  Eigen::VectorXd& x_new;
  Eigen::VectorXd& g_new;
  int evaluations = 0;
  double operator()(double alpha, double& dphi) {
    x_new.noalias() = x + alpha * d;
    const double v = f(x_new, g_new);
    ++evaluations;
    dphi = g_new.dot(d);
    return v;
  }
};

// Minimizer of the cubic interpolating phi and phi' at a and b (N&W Eq. 3.59), or NaN
// if the cubic has no minimizer.
double cubic_min(double a, double fa, double da, double b, double fb, double db) {
  const double d1 = da + db - 3 * (fa - fb) / (a - b);
  const double disc = d1 * d1 - da * db;
  if (!(disc >= 0)) return std::nan("");
  const double d2 = (b > a ? 1.0 : -1.0) * std::sqrt(disc);
  const double den = db - da + 2 * d2;
  if (den == 0) return std::nan("");
  return b - (b - a) * (db + d2 - d1) / den;
}

// One strong Wolfe search (Algorithms 3.5 and 3.6): the bracket [a_lo, a_hi] and the
// evaluation count live across the bracketing phase and the zoom.
class StrongWolfeSearch {
 public:
  StrongWolfeSearch(const Objective& f, const Eigen::VectorXd& x, double fx, const Eigen::VectorXd& gx,
                    const Eigen::VectorXd& d, double c1, double c2, int max_evals, Eigen::VectorXd& x_new,
                    Eigen::VectorXd& g_new)
      : phi_{f, x, d, x_new, g_new},
        x_(x),
        gx_(gx),
        fx_(fx),
        dphi0_(gx.dot(d)),
        c1_(c1),
        c2_(c2),
        max_evals_(max_evals),
        // Near a minimizer the decrease c1 a |phi'(0)| falls below the rounding of f. A
        // point that meets the curvature condition and raises f by no more than rounding
        // (1e-10 |f|) is accepted then (as the "approximate Wolfe" conditions of Hager &
        // Zhang 2005 do); without this the search fails although x is as good as f can tell.
        f_noise_(1e-10 * std::abs(fx)) {
    res_.f = fx;
    a_lo_ = 0;
    f_lo_ = fx;
    d_lo_ = dphi0_;
  }

  // Bracketing phase (Algorithm 3.5), expanding the step fourfold while phi descends.
  LineSearchResult search(double alpha0) {
    if (!(dphi0_ < 0) || !(alpha0 > 0)) return fail_at_start();  // not a descent direction
    const double alpha_max = 1e10 * alpha0;
    double a_prev = 0, f_prev = fx_, d_prev = dphi0_;
    double a = alpha0;
    for (int i = 0; phi_.evaluations < max_evals_; ++i) {
      double da;
      const double fa = phi_(a, da);
      if (fa > fx_ + c1_ * a * dphi0_ && approx_wolfe(fa, da)) return succeed(a, fa);
      if (!std::isfinite(fa) || !std::isfinite(da) || fa > fx_ + c1_ * a * dphi0_ ||
          (i > 0 && fa >= f_prev)) {
        set_lo(a_prev, f_prev, d_prev);
        return zoom(a, fa, da, std::isfinite(fa) && std::isfinite(da));
      }
      if (std::abs(da) <= -c2_ * dphi0_) return succeed(a, fa);
      if (da >= 0) {
        set_lo(a, fa, da);
        return zoom(a_prev, f_prev, d_prev, true);
      }
      // Still descending with sufficient decrease: expand.
      set_lo(a, fa, da);
      a_prev = a;
      f_prev = fa;
      d_prev = da;
      if (a >= alpha_max) break;
      a = std::min(4 * a, alpha_max);
    }
    return finish_failed();
  }

 private:
  // Zoom (Algorithm 3.6) on the bracket [a_lo, a_hi] (either order); a_lo satisfies
  // sufficient decrease and has the lowest phi so far. hi_ok is false if phi(a_hi) or its
  // derivative was not finite.
  LineSearchResult zoom(double a_hi, double f_hi, double d_hi, bool hi_ok) {
    while (phi_.evaluations < max_evals_) {
      const double lo = std::min(a_lo_, a_hi), hi = std::max(a_lo_, a_hi), w = hi - lo;
      if (w <= 1e-16 * std::max(1.0, hi)) break;  // bracket collapsed to rounding
      double a = hi_ok ? cubic_min(a_lo_, f_lo_, d_lo_, a_hi, f_hi, d_hi) : std::nan("");
      // Safeguard: stay well inside the bracket, else bisect.
      if (!std::isfinite(a) || a < lo + 0.1 * w || a > hi - 0.1 * w) a = 0.5 * (a_lo_ + a_hi);
      double da;
      const double fa = phi_(a, da);
      if (fa > fx_ + c1_ * a * dphi0_ && approx_wolfe(fa, da)) return succeed(a, fa);
      if (!std::isfinite(fa) || fa > fx_ + c1_ * a * dphi0_ || fa >= f_lo_) {
        a_hi = a;
        f_hi = fa;
        d_hi = da;
        hi_ok = std::isfinite(fa) && std::isfinite(da);
      } else {
        if (std::abs(da) <= -c2_ * dphi0_) return succeed(a, fa);
        if (da * (a_hi - a_lo_) >= 0) {
          a_hi = a_lo_;
          f_hi = f_lo_;
          d_hi = d_lo_;
          hi_ok = true;
        }
        set_lo(a, fa, da);
      }
    }
    return finish_failed();
  }

  void set_lo(double a, double fa, double da) {
    a_lo_ = a;
    f_lo_ = fa;
    d_lo_ = da;
  }
  bool approx_wolfe(double fa, double da) const {
    return std::isfinite(fa) && fa <= fx_ + f_noise_ && std::abs(da) <= -c2_ * dphi0_;
  }
  LineSearchResult fail_at_start() {
    phi_.x_new = x_;
    phi_.g_new = gx_;
    res_.alpha = 0;
    res_.f = fx_;
    res_.ok = false;
    return res_;
  }
  // On failure: the best sufficient-decrease point, re-evaluated into x_new/g_new.
  LineSearchResult finish_failed() {
    res_.evaluations = phi_.evaluations;
    if (a_lo_ > 0 && phi_.evaluations < max_evals_ + 1) {
      double dd;
      res_.f = phi_(a_lo_, dd);
      res_.evaluations = phi_.evaluations;
      res_.alpha = a_lo_;
      res_.ok = false;
      return res_;
    }
    const int ev = res_.evaluations;
    fail_at_start();
    res_.evaluations = ev;
    return res_;
  }
  LineSearchResult succeed(double a, double fa) {
    res_.alpha = a;
    res_.f = fa;
    res_.ok = true;
    res_.evaluations = phi_.evaluations;
    return res_;
  }

  Phi phi_;
  const Eigen::VectorXd& x_;
  const Eigen::VectorXd& gx_;
  const double fx_, dphi0_, c1_, c2_;
  const int max_evals_;
  const double f_noise_;
  // The best point with sufficient decrease seen so far (alpha_lo of the zoom).
  double a_lo_ = 0, f_lo_ = 0, d_lo_ = 0;
  LineSearchResult res_;
};

}  // namespace

LineSearchResult strong_wolfe_search(const Objective& f, const Eigen::VectorXd& x, double fx,
                                     const Eigen::VectorXd& gx, const Eigen::VectorXd& d,
                                     double alpha0, double c1, double c2, int max_evals,
                                     Eigen::VectorXd& x_new, Eigen::VectorXd& g_new) {
  x_new.resize(x.size());
  g_new.resize(x.size());
  StrongWolfeSearch s(f, x, fx, gx, d, c1, c2, max_evals, x_new, g_new);
  return s.search(alpha0);
}

LineSearchResult armijo_search(const Objective& f, const Eigen::VectorXd& x, double fx,
                               const Eigen::VectorXd& gx, const Eigen::VectorXd& d,
                               double alpha0, double c1, int max_evals,
                               Eigen::VectorXd& x_new, Eigen::VectorXd& g_new) {
  LineSearchResult res;
  x_new.resize(x.size());
  g_new.resize(x.size());
  const double dphi0 = gx.dot(d);
  double a = alpha0;
  if (dphi0 < 0 && alpha0 > 0) {
    for (int k = 0; k < max_evals; ++k) {
      x_new.noalias() = x + a * d;
      const double fa = f(x_new, g_new);
      ++res.evaluations;
      if (std::isfinite(fa) && fa <= fx + c1 * a * dphi0) {
        res.alpha = a;
        res.f = fa;
        res.ok = true;
        return res;
      }
      a *= 0.5;
    }
  }
  x_new = x;
  g_new = gx;
  res.alpha = 0;
  res.f = fx;
  res.ok = false;
  return res;
}

}  // namespace shapemap
