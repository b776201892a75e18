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

}  // namespace

LineSearchResult strong_wolfe_search(const Objective& f, const Eigen::VectorXd& x, double fx,
                                     const Eigen::VectorXd& gx, const Eigen::VectorXd& d,
                                     double alpha0, double c1, double c2, int max_evals,
                                     Eigen::VectorXd& x_new, Eigen::VectorXd& g_new) {
  LineSearchResult res;
  res.f = fx;
  x_new.resize(x.size());
  g_new.resize(x.size());
  const double dphi0 = gx.dot(d);
  auto fail_at_start = [&]() {
    x_new = x;
    g_new = gx;
    res.alpha = 0;
    res.f = fx;
    res.ok = false;
    return res;
  };
  if (!(dphi0 < 0) || !(alpha0 > 0)) return fail_at_start();  // not a descent direction
  Phi phi{f, x, d, x_new, g_new};
  const double alpha_max = 1e10 * alpha0;
  // Near a minimizer the decrease c1 a |phi'(0)| falls below the rounding of f. A point
  // that meets the curvature condition and raises f by no more than rounding (1e-10 |f|)
  // is accepted then (as the "approximate Wolfe" conditions of Hager & Zhang 2005 do);
  // without this the search fails although x is as good as f can tell.
  const double f_noise = 1e-10 * std::abs(fx);
  auto approx_wolfe = [&](double fa, double da) {
    return std::isfinite(fa) && fa <= fx + f_noise && std::abs(da) <= -c2 * dphi0;
  };

  // The best point with sufficient decrease seen so far (alpha_lo of the zoom).
  double a_lo = 0, f_lo = fx, d_lo = dphi0;
  // On failure: return the best sufficient-decrease point, re-evaluated into x_new/g_new.
  auto finish_failed = [&]() {
    res.evaluations = phi.evaluations;
    if (a_lo > 0 && phi.evaluations < max_evals + 1) {
      double dd;
      res.f = phi(a_lo, dd);
      res.evaluations = phi.evaluations;
      res.alpha = a_lo;
      res.ok = false;
      return res;
    }
    const int ev = res.evaluations;
    fail_at_start();
    res.evaluations = ev;
    return res;
  };
  auto succeed = [&](double a, double fa) {
    res.alpha = a;
    res.f = fa;
    res.ok = true;
    res.evaluations = phi.evaluations;
    return res;
  };

  // Zoom (Algorithm 3.6) on the bracket [a_lo, a_hi] (either order); a_lo satisfies
  // sufficient decrease and has the lowest phi so far. hi_has_derivative is false if
  // phi(a_hi) was not finite.
  auto zoom = [&](double a_hi, double f_hi, double d_hi, bool hi_ok) {
    while (phi.evaluations < max_evals) {
      const double lo = std::min(a_lo, a_hi), hi = std::max(a_lo, a_hi), w = hi - lo;
      if (w <= 1e-16 * std::max(1.0, hi)) break;  // bracket collapsed to rounding
      double a = hi_ok ? cubic_min(a_lo, f_lo, d_lo, a_hi, f_hi, d_hi) : std::nan("");
      // Safeguard: stay well inside the bracket, else bisect.
      if (!std::isfinite(a) || a < lo + 0.1 * w || a > hi - 0.1 * w) a = 0.5 * (a_lo + a_hi);
      double da;
      const double fa = phi(a, da);
      if (fa > fx + c1 * a * dphi0 && approx_wolfe(fa, da)) return succeed(a, fa);
      if (!std::isfinite(fa) || fa > fx + c1 * a * dphi0 || fa >= f_lo) {
        a_hi = a;
        f_hi = fa;
        d_hi = da;
        hi_ok = std::isfinite(fa) && std::isfinite(da);
      } else {
        if (std::abs(da) <= -c2 * dphi0) return succeed(a, fa);
        if (da * (a_hi - a_lo) >= 0) {
          a_hi = a_lo;
          f_hi = f_lo;
          d_hi = d_lo;
          hi_ok = true;
        }
        a_lo = a;
        f_lo = fa;
        d_lo = da;
      }
    }
    return finish_failed();
  };

  // Bracketing phase (Algorithm 3.5).
  double a_prev = 0, f_prev = fx, d_prev = dphi0;
  double a = alpha0;
  for (int i = 0; phi.evaluations < max_evals; ++i) {
    double da;
    const double fa = phi(a, da);
    if (fa > fx + c1 * a * dphi0 && approx_wolfe(fa, da)) return succeed(a, fa);
    if (!std::isfinite(fa) || !std::isfinite(da) || fa > fx + c1 * a * dphi0 ||
        (i > 0 && fa >= f_prev)) {
      a_lo = a_prev;
      f_lo = f_prev;
      d_lo = d_prev;
      return zoom(a, fa, da, std::isfinite(fa) && std::isfinite(da));
    }
    if (std::abs(da) <= -c2 * dphi0) return succeed(a, fa);
    if (da >= 0) {
      a_lo = a;
      f_lo = fa;
      d_lo = da;
      return zoom(a_prev, f_prev, d_prev, true);
    }
    // Still descending with sufficient decrease: expand.
    a_lo = a;
    f_lo = fa;
    d_lo = da;
    a_prev = a;
    f_prev = fa;
    d_prev = da;
    if (a >= alpha_max) break;
    a = std::min(4 * a, alpha_max);
  }
  return finish_failed();
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
