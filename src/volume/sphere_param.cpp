// Spherical area-preserving map: linear puncture map, conformal energy minimization,
// stretch energy minimization (see the header and docs/methods.md).
#include "shapemap/volume/sphere_param.h"
#include "shapemap/timing.h"
#include "shapemap/volume/latitude_longitude.h"
#include "shapemap/error.h"
#include "shapemap/geometry/laplacian.h"
#include "shapemap/geometry/sparse_cholesky.h"
#include <Eigen/Geometry>
#include <Eigen/Sparse>
#include <algorithm>
#include <chrono>
#include <cmath>
#include <limits>
#include <vector>

namespace shapemap {

namespace {

using Plane = Eigen::MatrixXd;  // n×2

// Flat triangle areas of P (n×3).
Eigen::VectorXd areas3(const Eigen::MatrixXd& P, const Eigen::MatrixXi& F) {
  Eigen::VectorXd A(F.rows());
  for (Eigen::Index f = 0; f < F.rows(); ++f) {
    const Eigen::Vector3d a = P.row(F(f, 0)), b = P.row(F(f, 1)), c = P.row(F(f, 2));
    A(f) = 0.5 * (b - a).cross(c - a).norm();
  }
  return A;
}

// 1/2 tr(S^T L S) - A(S): conformal (sigma = 1) or stretch-minus-area energy.
double energy_minus_area(const Eigen::SparseMatrix<double>& L, const Eigen::MatrixXd& S,
                         const Eigen::MatrixXi& F) {
  const Eigen::MatrixXd LS = L * S;
  return 0.5 * S.cwiseProduct(LS).sum() - areas3(S, F).sum();
}

Eigen::MatrixXd inverse_stereographic(const Plane& uv) {
  Eigen::MatrixXd S(uv.rows(), 3);
  for (Eigen::Index i = 0; i < uv.rows(); ++i) {
    const double x = uv(i, 0), y = uv(i, 1);
    if (!std::isfinite(x) || !std::isfinite(y)) {
      S.row(i) << 0, 0, 1;
      continue;
    }
    const double b = 1 + x * x + y * y;
    S.row(i) << 2 * x / b, 2 * y / b, (b - 2) / b;
  }
  return S;
}

// z -> z / |z|^2 (the reflection of the sphere through the equator).
void invert(Plane& uv) {
  for (Eigen::Index i = 0; i < uv.rows(); ++i) {
    const double r2 = uv(i, 0) * uv(i, 0) + uv(i, 1) * uv(i, 1);
    if (r2 == 0) {
      uv(i, 0) = uv(i, 1) = 1e30;
    } else if (!std::isfinite(r2)) {
      uv(i, 0) = uv(i, 1) = 0;
    } else {
      uv(i, 0) /= r2;
      uv(i, 1) /= r2;
    }
  }
}

// Outward triangles on the sphere appear clockwise in the plane of the north-pole
// stereographic projection; flip x when the majority is counter-clockwise.
void make_downward(const Eigen::MatrixXi& F, Plane& uv) {
  double s = 0;
  for (Eigen::Index f = 0; f < F.rows(); ++f) {
    const Eigen::Vector2d a = uv.row(F(f, 0)), b = uv.row(F(f, 1)), c = uv.row(F(f, 2));
    const double det = (b - a).x() * (c - a).y() - (b - a).y() * (c - a).x();
    if (std::isfinite(det)) s += det > 0 ? 1 : -1;
  }
  if (s > 0) uv.col(0) *= -1;
}

void normalize_median(Plane& uv) {
  std::vector<double> r(uv.rows());
  for (Eigen::Index i = 0; i < uv.rows(); ++i) r[i] = uv.row(i).norm();
  std::nth_element(r.begin(), r.begin() + r.size() / 2, r.end());
  const double med = r[r.size() / 2];
  if (med > 0 && std::isfinite(med)) uv /= med;
}

// Solves L_II x_I = -L_IB x_B for rows with inner[i], in place.
void solve_inner(const Eigen::SparseMatrix<double>& L, const std::vector<char>& inner, Plane& uv) {
  const Eigen::Index n = L.rows();
  std::vector<int> idx(n, -1);
  int nI = 0;
  for (Eigen::Index i = 0; i < n; ++i)
    if (inner[i]) idx[i] = nI++;
  if (nI == 0) return;
  std::vector<Eigen::Triplet<double>> trip;
  trip.reserve(L.nonZeros());
  Eigen::MatrixXd rhs = Eigen::MatrixXd::Zero(nI, uv.cols());
  for (Eigen::Index c = 0; c < L.outerSize(); ++c)
    for (Eigen::SparseMatrix<double>::InnerIterator it(L, c); it; ++it) {
      const int r = int(it.row());
      if (idx[r] < 0) continue;
      if (idx[c] >= 0)
        trip.emplace_back(idx[r], idx[c], it.value());
      else
        rhs.row(idx[r]) -= it.value() * uv.row(c);
    }
  Eigen::SparseMatrix<double> A(nI, nI);
  A.setFromTriplets(trip.begin(), trip.end());
  SparseCholesky chol(SparseCholesky::Method::Simplicial);
  chol.compute(A);
  const Eigen::MatrixXd x = chol.solve(rhs);
  for (Eigen::Index i = 0; i < n; ++i)
    if (idx[i] >= 0) uv.row(i) = x.row(idx[i]);
}


// Authalic energy of unit vectors S (n×3) against target shares w (sum 1), m faces:
// E_A = E_S / A(S) - A(S) with E_S = sum a_f^2 / w_f, a_f the flat image areas
// (the 2-D analogue of Eq. 2a with A(e) = 1; E_A >= 0, = 0 iff area-preserving).
// With G non-null, also the Euclidean gradient (n×3) in S, faces summed in order.
double authalic_energy(const Eigen::MatrixXd& S, const Eigen::MatrixXi& F, const Eigen::VectorXd& w,
                       Eigen::MatrixXd* G) {
  const Eigen::Index m = F.rows();
  double AS = 0, ES = 0;
  Eigen::VectorXd a(m);
  for (Eigen::Index f = 0; f < m; ++f) {
    const Eigen::Vector3d p = S.row(F(f, 0)), q = S.row(F(f, 1)), r = S.row(F(f, 2));
    a(f) = 0.5 * (q - p).cross(r - p).norm();
    AS += a(f);
    ES += a(f) * a(f) / w(f);
  }
  const double E = ES / AS - AS;
  if (G) {
    G->setZero(S.rows(), 3);
    const double c2 = ES / (AS * AS) + 1;
    for (Eigen::Index f = 0; f < m; ++f) {
      const Eigen::Vector3d p = S.row(F(f, 0)), q = S.row(F(f, 1)), r = S.row(F(f, 2));
      Eigen::Vector3d nrm = (q - p).cross(r - p);
      const double l = nrm.norm();
      if (!(l > 0)) continue;
      nrm /= l;
      const double c = 2 * a(f) / w(f) / AS - c2;  // d E_A / d a_f
      G->row(F(f, 0)) += c * 0.5 * nrm.cross(r - q).transpose();
      G->row(F(f, 1)) += c * 0.5 * nrm.cross(p - r).transpose();
      G->row(F(f, 2)) += c * 0.5 * nrm.cross(q - p).transpose();
    }
  }
  return E;
}

// Rows of X projected to the tangent planes at the unit vectors S.
void tangent_project(const Eigen::MatrixXd& S, Eigen::MatrixXd& X) {
  for (Eigen::Index i = 0; i < S.rows(); ++i) X.row(i) -= X.row(i).dot(S.row(i)) * S.row(i);
}

// Local untangling on the sphere: a vertex of a folded face (or, when that stalls, of a
// growing neighbourhood of folded faces) is moved towards the normalized mean of its
// one-ring (t = 1, 1/2, 1/4, 1/8 of the way) when that lowers the number of folded faces
// around it (Gauss-Seidel sweeps), until no face is folded or max_rounds is reached.
// Returns the number of folded faces left.
int untangle_sphere(Eigen::MatrixXd& S, const Eigen::MatrixXi& F, int max_rounds) {
  const Eigen::Index n = S.rows();
  std::vector<std::vector<int>> nb(n), vf(n);
  for (Eigen::Index f = 0; f < F.rows(); ++f)
    for (int c = 0; c < 3; ++c) {
      vf[F(f, c)].push_back(int(f));
      nb[F(f, c)].push_back(F(f, (c + 1) % 3));
      nb[F(f, c)].push_back(F(f, (c + 2) % 3));
    }
  for (auto& v : nb) {
    std::sort(v.begin(), v.end());
    v.erase(std::unique(v.begin(), v.end()), v.end());
  }
  auto orient = [&](int f) {
    const Eigen::Vector3d a = S.row(F(f, 0)), b = S.row(F(f, 1)), c = S.row(F(f, 2));
    return a.dot(b.cross(c));
  };
  // Local badness: folded incident faces, then the most negative orientation.
  auto local = [&](int i, int& nf) {
    nf = 0;
    double worst = 0;
    for (int f : vf[i]) {
      const double o = orient(f);
      if (!(o > 0)) {
        ++nf;
        worst = std::min(worst, o);
      }
    }
    return worst;
  };
  int folded = spherical_folded_faces(S, F);
  int rings = 0, stall = 0;
  for (int round = 0; round < max_rounds && folded > 0; ++round) {
    std::vector<char> mark(n, 0);
    for (Eigen::Index f = 0; f < F.rows(); ++f)
      if (!(orient(int(f)) > 0))
        for (int k = 0; k < 3; ++k) mark[F(f, k)] = 1;
    for (int r = 0; r < rings; ++r) {
      std::vector<char> m2 = mark;
      for (Eigen::Index i = 0; i < n; ++i)
        if (mark[i])
          for (int j : nb[i]) m2[j] = 1;
      mark.swap(m2);
    }
    for (Eigen::Index i = 0; i < n; ++i) {
      if (!mark[i]) continue;
      Eigen::RowVector3d c = Eigen::RowVector3d::Zero();
      for (int j : nb[i]) c += S.row(j);
      if (!(c.norm() > 0)) continue;
      c.normalize();
      const Eigen::RowVector3d old = S.row(i);
      int nf0;
      const double w0 = local(int(i), nf0);
      int best_nf = nf0;
      double best_w = w0;
      Eigen::RowVector3d best = old;
      for (double t = 1; t > 0.1; t *= 0.5) {
        S.row(i) = ((1 - t) * old + t * c).normalized();
        int nf;
        const double w = local(int(i), nf);
        if (nf < best_nf || (nf == best_nf && w > best_w)) {
          best_nf = nf;
          best_w = w;
          best = S.row(i);
        }
      }
      S.row(i) = best;
    }
    const int fn = spherical_folded_faces(S, F);
    if (fn >= folded && ++stall >= 2) {
      ++rings;
      stall = 0;
    }
    folded = fn;
  }
  return folded;
}

// North-pole stereographic projection, the inverse of inverse_stereographic.
Plane stereographic(const Eigen::MatrixXd& S) {
  Plane uv(S.rows(), 2);
  for (Eigen::Index i = 0; i < S.rows(); ++i) {
    const double d = 1 - S(i, 2);
    uv.row(i) = d > 0 ? Eigen::RowVector2d(S(i, 0) / d, S(i, 1) / d)
                      : Eigen::RowVector2d(std::numeric_limits<double>::infinity(), 0);
  }
  return uv;
}

struct Stage {
  Plane uv;
  Eigen::MatrixXd S;
  double E = 0;
  int folded = 0;
  double t = 1;  // damping factor of the step that produced it
};

}  // namespace

int spherical_folded_faces(const Eigen::MatrixXd& S, const Eigen::MatrixXi& F) {
  return int(F.rows()) - positive_origin_cones(S, F);
}

namespace {

// The spherical area-preserving map of one surface, one method per stage (linear map, CEM,
// SEM, Riemannian CG on the authalic energy) and the choice among the starts; the surface's
// areas, cotangent Laplacian and target area shares are shared by all of them.
struct SphereMapSolver {
  const TriMesh& surface;
  const Eigen::MatrixXd& V;
  const Eigen::MatrixXi& F;
  const Eigen::Index n, m;
  const SphereParamOptions& opt;
  const ProgressCallback& progress;
  Eigen::VectorXd A0;               // face areas of the surface
  Eigen::SparseMatrix<double> Lc;   // its cotangent Laplacian
  Eigen::VectorXd target;           // target area shares (sum 1)

  SphereMapSolver(const TriMesh& s, const SphereParamOptions& o, const ProgressCallback& p)
      : surface(s), V(s.V), F(s.F), n(s.V.rows()), m(s.F.rows()), opt(o), progress(p) {}

  // Step 1.
  Stage linear_map() {
    // ---- 1. Linear map: puncture the most regular face (Yueh et al., Sphere.Linear).
    A0 = areas3(V, F);
    Eigen::Index best = 0;
    double bestq = -1;
    for (Eigen::Index f = 0; f < m; ++f) {
      const Eigen::Vector3d a = V.row(F(f, 0)), b = V.row(F(f, 1)), c = V.row(F(f, 2));
      const double l2 = (b - a).squaredNorm() + (c - b).squaredNorm() + (a - c).squaredNorm();
      const double q = l2 > 0 ? 4 * std::sqrt(3.0) * A0(f) / l2 : 0;  // 1 = equilateral
      if (q > bestq) {
        bestq = q;
        best = f;
      }
    }
    if (!(bestq > 0)) throw InputError("spherical map: all faces are degenerate");
    Lc = cotan_laplacian(V, F);
    Plane uv = Plane::Zero(n, 2);
    {
      const int ia = F(best, 0), ib = F(best, 1), ic = F(best, 2);
      const Eigen::Vector3d A = V.row(ia), B = V.row(ib), C = V.row(ic);
      const double alpha = (C - A).dot(B - A) / (B - A).squaredNorm();
      const Eigen::Vector3d E = A + alpha * (B - A);
      const double nBA = (B - A).norm(), nCE = (C - E).norm();
      uv.row(ia) << -1.0 / nBA, (1 - alpha) / nCE;
      uv.row(ib) << 1.0 / nBA, alpha / nCE;
      uv.row(ic) << 0.0, -1.0 / nCE;
      std::vector<char> inner(n, 1);
      inner[ia] = inner[ib] = inner[ic] = 0;
      solve_inner(Lc, inner, uv);
      make_downward(F, uv);
      uv.rowwise() -= uv.colwise().mean();
      normalize_median(uv);
    }
    Stage cur;
    cur.uv = uv;
    cur.S = inverse_stereographic(uv);
    cur.E = energy_minus_area(Lc, cur.S, F);
    cur.folded = spherical_folded_faces(cur.S, F);
    report(progress, "ball/sphere-map", 0.05);
    return cur;
  }

  // One hemisphere-alternation step (CEM and SEM share it). With max_folded >= 0 the step
  // is damped: the solved inner vertices move only a fraction t = 1, 1/2, ..., 1/64 of the
  // way from their inverted positions; the largest t whose image has at most max_folded
  // folded faces is taken (s.folded = -1 when none has).
  Stage step(const Eigen::SparseMatrix<double>& L, double R, const Stage& from, int max_folded) const {
    Plane uv0 = from.uv;
    invert(uv0);
    std::vector<char> inner(n, 0);
    for (Eigen::Index i = 0; i < n; ++i) inner[i] = uv0.row(i).norm() < R;
    Plane uv1 = uv0;
    solve_inner(L, inner, uv1);
    Stage s;
    for (double t = 1; t > 1.0 / 100; t *= 0.5) {
      s.uv = t == 1 ? uv1 : Plane(uv0 + t * (uv1 - uv0));
      normalize_median(s.uv);
      make_downward(F, s.uv);
      s.S = inverse_stereographic(s.uv);
      s.folded = spherical_folded_faces(s.S, F);
      s.t = t;
      if (max_folded < 0 || s.folded <= max_folded) return s;
    }
    s.folded = -1;
    return s;
  }

  // Step 2.
  void conformal(Stage& cur, SphereParamResult& res) const {
    // ---- 2. Conformal energy minimization (fixed cotangent Laplacian of the surface).
    for (int it = 0; it < opt.conformal_iterations; ++it) {
      Stage s = step(Lc, opt.conformal_radius, cur, -1);
      s.E = energy_minus_area(Lc, s.S, F);
      if (!(s.E < cur.E) || s.folded > cur.folded) break;
      const double dE = cur.E - s.E;
      cur = std::move(s);
      res.conformal_iterations = it + 1;
      report(progress, "ball/sphere-map", 0.05 + 0.25 * (it + 1) / opt.conformal_iterations);
      if (dE < opt.conformal_tolerance) break;
    }
    res.conformal_energy = cur.E;
  }

  // Step 3 from a start map, into r.S (normalized, untangled).
  void stretch(Stage cur, double fold_allowance, SphereParamResult& r) const {
    // ---- 3. Stretch energy minimization (Yueh et al. 2019).
    auto stretch_laplacian = [&](const Eigen::MatrixXd& S) {
      Eigen::VectorXd As = areas3(S, F);
      As /= As.sum();
      Eigen::VectorXd sigma(m);
      for (Eigen::Index f = 0; f < m; ++f) sigma(f) = As(f) > 0 ? target(f) / As(f) : 0.0;
      return cotan_laplacian(S, F, sigma);
    };
    Eigen::SparseMatrix<double> Ls = stretch_laplacian(cur.S);
    cur.E = energy_minus_area(Ls, cur.S, F);
    r.stretch_energy_initial = cur.E;
    // The fixed-point iteration of SEM is not monotone: iterate as published, keep the
    // fold-free iterate with the lowest authalic energy E_A, stop after 8 steps without a
    // new best (or on the relative tolerance).
    Stage best_stage = cur;
    double best_EA = authalic_energy(cur.S, F, target, nullptr);
    int since_best = 0;
    // Fold allowance: a step is damped (see step) until it has at most this many folded
    // faces, and only iterates within it can be kept.
    const int max_folds = std::max(cur.folded, int(std::min(1.0, fold_allowance) * double(m)));
    for (int it = 0; it < opt.stretch_iterations; ++it) {
      // The stretch-weighted Laplacian of a badly folded image can be indefinite: then the
      // fixed point cannot continue, and the best iterate so far is kept.
      Stage s;
      try {
        s = step(Ls, opt.stretch_radius, cur, std::max(cur.folded, max_folds));
      } catch (const Error&) {
        break;
      }
      if (s.folded < 0) break;  // even the shortest damped step adds folds
      if (s.t < 1) ++r.stretch_damped_steps;
      Eigen::SparseMatrix<double> Ln = stretch_laplacian(s.S);
      s.E = energy_minus_area(Ln, s.S, F);
      if (!std::isfinite(s.E)) break;
      cur = std::move(s);
      Ls = std::move(Ln);
      r.stretch_iterations = it + 1;
      report(progress, "ball/sphere-map", 0.3 + 0.7 * (it + 1) / opt.stretch_iterations);
      Eigen::MatrixXd Sn = cur.S;
      Sn.rowwise().normalize();
      const double EA = authalic_energy(Sn, F, target, nullptr);
      if (cur.folded <= max_folds && EA < best_EA) {
        const double rel = (best_EA - EA) / std::max(1e-300, best_EA);
        best_stage = cur;
        best_EA = EA;
        since_best = 0;
        if (rel < opt.stretch_tolerance) break;
      } else if (++since_best >= 8) {
        break;
      }
    }
    cur = std::move(best_stage);
    r.stretch_folded_faces = cur.folded;
    r.stretch_energy = cur.E;
    r.S = cur.S;
    r.S.rowwise().normalize();
    // SEM may leave a few folded faces on strongly stretched parts: untangle them locally.
    if (cur.folded > 0) untangle_sphere(r.S, F, 200);
  }

  // Step 4 on r.S.
  void authalic_cg(SphereParamResult& r) const {
    Eigen::MatrixXd& S = r.S;
    Eigen::MatrixXd G, Gn, H, Hn, D, Sn;
    double E = authalic_energy(S, F, target, &G);
    r.authalic_energy_initial = E;
    int folded = spherical_folded_faces(S, F);
    // Preconditioner: inverse lumped image vertex areas (the mass matrix of the current
    // sphere mesh), so a vertex moves in proportion to its local scale; the exponentially
    // small triangles the conformal stage leaves on thin parts cannot flip in one step.
    Eigen::VectorXd lump(n);
    auto precondition = [&](const Eigen::MatrixXd& Sx, const Eigen::MatrixXd& Gx, Eigen::MatrixXd& Hx) {
      lump.setZero();
      for (Eigen::Index f = 0; f < m; ++f) {
        const Eigen::Vector3d p = Sx.row(F(f, 0)), q = Sx.row(F(f, 1)), r = Sx.row(F(f, 2));
        const double a = (q - p).cross(r - p).norm() / 6.0;
        for (int c = 0; c < 3; ++c) lump(F(f, c)) += a;
      }
      const double floor = 1e-12 * lump.sum();
      Hx.resize(n, 3);
      for (Eigen::Index i = 0; i < n; ++i) Hx.row(i) = Gx.row(i) / std::max(lump(i), floor);
      tangent_project(Sx, Hx);
    };
    double mean_edge = 0;
    for (Eigen::Index f = 0; f < m; ++f) mean_edge += (S.row(F(f, 0)) - S.row(F(f, 1))).norm();
    mean_edge /= double(m);
    tangent_project(S, G);
    precondition(S, G, H);
    D = -H;
    double gh = G.cwiseProduct(H).sum();
    double alpha = -1;
    for (int it = 0; it < opt.authalic_iterations; ++it) {
      double slope = G.cwiseProduct(D).sum();
      if (!(slope < 0)) {
        D = -H;
        slope = -gh;
        if (!(slope < 0)) break;
      }
      const double dmax = D.rowwise().norm().maxCoeff();
      if (!(dmax > 0)) break;
      if (alpha < 0) alpha = 0.5 * mean_edge / dmax;
      alpha = std::min(2 * alpha, 0.5 * mean_edge / dmax);  // no vertex moves more than half a mean edge
      bool ok = false;
      double En = E;
      int fn = folded;
      for (int ls = 0; ls < 40; ++ls) {
        Sn = S + alpha * D;
        Sn.rowwise().normalize();  // retraction
        En = authalic_energy(Sn, F, target, nullptr);
        if (std::isfinite(En) && En <= E + 1e-4 * alpha * slope) {
          fn = spherical_folded_faces(Sn, F);
          if (fn <= folded) {
            ok = true;
            break;
          }
        }
        alpha *= 0.5;
      }
      if (!ok) {
        if (D.isApprox(-H)) break;
        D = -H;  // restart along the preconditioned gradient
        alpha = -1;
        continue;
      }
      const double rel = (E - En) / std::max(1e-300, std::abs(E));
      S.swap(Sn);
      folded = fn;
      E = authalic_energy(S, F, target, &Gn);
      tangent_project(S, Gn);
      precondition(S, Gn, Hn);
      tangent_project(S, D);    // vector transport by projection
      tangent_project(S, H);
      const double ghn = Gn.cwiseProduct(Hn).sum();
      const double beta = std::max(0.0, (ghn - Gn.cwiseProduct(H).sum()) / gh);  // PR+
      D = -Hn + beta * D;
      G.swap(Gn);
      H.swap(Hn);
      gh = ghn;
      r.authalic_iterations = it + 1;
      if (it % 10 == 0) report(progress, "ball/sphere-map", 1.0);
      if (rel < opt.authalic_tolerance) break;
    }
    r.authalic_energy = E;
  }

  // Steps 3-4 from a start map (the CEM result or the linear map), into r.
  void stretch_and_refine(const Stage& cur, double fold_allowance, SphereParamResult& r) const {
    stretch(cur, fold_allowance, r);
    authalic_cg(r);
    {
      const Eigen::VectorXd As = areas3(r.S, F);
      const double tot = As.sum();
      double mean = 0, mx = 0;
      for (Eigen::Index f = 0; f < m; ++f) {
        const double d = std::abs(As(f) / tot / target(f) - 1);
        mean += d;
        mx = std::max(mx, d);
      }
      r.area_distortion_mean = mean / double(m);
      r.area_distortion_max = mx;
    }
    r.folded_faces = spherical_folded_faces(r.S, F);
  }

  // The starts tried and the one kept (see below), into res.
  void best_of_starts(const Stage& cur, const Stage& linear_stage, SphereParamResult& res) const {
    {
      const int cem_iterations = res.conformal_iterations;
      const double cem_energy = res.conformal_energy;
      // Candidates: SEM as published (undamped) and damped (see SphereParamOptions), each
      // from the CEM result and, when CEM changed the map, from the linear map (the conformal
      // steps can compress thin parts further). Selection (run_candidate): a result that has
      // not collapsed a part, then the fewest folded faces, then the lowest E_A; the published
      // path alone is the first candidate.
      struct Candidate {
        const Stage* start;
        int start_id;
        double allowance;
      };
      std::vector<Candidate> cand = {{&cur, 0, 1.0}};
      if (opt.stretch_fold_allowance < 1) cand.push_back({&cur, 0, opt.stretch_fold_allowance});
      if (opt.try_linear_start && cem_iterations > 0) {
        cand.push_back({&linear_stage, 1, 1.0});
        if (opt.stretch_fold_allowance < 1) cand.push_back({&linear_stage, 1, opt.stretch_fold_allowance});
      }
      // A result with a face more than latitude_start_distortion times off its area share has
      // collapsed a part (measured: a creature whose linear map put 80% of the vertices on a
      // thin ring; CEM and SEM stalled at mean distortion 1.9, max 170, with 0 folded faces,
      // and the ball map failed); it loses to any result that has not, whatever its folds.
      auto collapsed = [&](const SphereParamResult& r) {
        return opt.latitude_start_distortion > 0 && r.area_distortion_max > opt.latitude_start_distortion;
      };
      // Steps 3-4 from a start; kept when it is the first, or not collapsed when the kept one
      // is, or equally collapsed with fewer folded faces, then a lower E_A.
      bool first = true;
      auto run_candidate = [&](const Stage& start, int start_id, double allowance) {
        SphereParamResult r;
        stretch_and_refine(start, allowance, r);
        r.start_stage = start_id;
        r.stretch_damped = allowance < 1;
        const bool c = collapsed(r), c0 = collapsed(res);
        if (first || c < c0 ||
            (c == c0 && (r.folded_faces < res.folded_faces ||
                         (r.folded_faces == res.folded_faces && r.authalic_energy < res.authalic_energy))))
          res = std::move(r);
        first = false;
      };
      for (const Candidate& c : cand) run_candidate(*c.start, c.start_id, c.allowance);
      // Latitude-longitude start when the conformal starts collapsed a part (folded or not:
      // the conformal factor of a long part is exponentially small); the same selection.
      if (collapsed(res)) {
        Stage ll;
        ll.S = latitude_longitude_map(surface, Lc, target).S;
        if (ll.S.rows() == n) {
          // Tilt the pole axis off the projection pole (0, 0, 1) of the SEM steps.
          ll.S = (ll.S * Eigen::AngleAxisd(0.7, Eigen::Vector3d(1, 2, 3).normalized()).toRotationMatrix().transpose()).eval();
          ll.uv = stereographic(ll.S);
          ll.S = inverse_stereographic(ll.uv);
          ll.E = energy_minus_area(Lc, ll.S, F);
          ll.folded = spherical_folded_faces(ll.S, F);
          run_candidate(ll, 2, 1.0);
          if (opt.stretch_fold_allowance < 1) run_candidate(ll, 2, opt.stretch_fold_allowance);
        }
      }
      res.conformal_iterations = cem_iterations;
      res.conformal_energy = cem_energy;
    }
  }
};

}  // namespace

SphereParamResult spherical_area_preserving_map(const TriMesh& surface,
                                                const Eigen::VectorXd& face_weights,
                                                const SphereParamOptions& opt,
                                                const ProgressCallback& progress) {
  const auto t0 = Clock::now();
  const Eigen::Index n = surface.V.rows(), m = surface.F.rows();
  if (n < 4 || m < 4 || surface.F.cols() != 3)
    throw InputError("spherical map: the surface needs at least 4 vertices and 4 faces");
  if (face_weights.size() != 0 && face_weights.size() != m)
    throw InputError("spherical map: face_weights must have one entry per face");
  SphereParamResult res;
  SphereMapSolver solver(surface, opt, progress);
  const Stage linear_stage = solver.linear_map();
  Stage cur = linear_stage;
  solver.conformal(cur, res);
  solver.target = face_weights.size() ? face_weights : solver.A0;
  solver.target /= solver.target.sum();
  solver.best_of_starts(cur, linear_stage, res);
  report(progress, "ball/sphere-map", 1.0);
  res.seconds = seconds_since(t0);
  return res;
}

}  // namespace shapemap
