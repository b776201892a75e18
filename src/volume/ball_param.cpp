// Isovolumetric energy minimization for ball-shaped volume-preserving parameterizations
// (isovolumetric-ball-parameterization.txt, Algorithm 1). See the header and
// docs/methods.md for the deviations (pole handling, phi preconditioner block).
#include "shapemap/volume/ball_param.h"
#include "shapemap/checks.h"
#include "shapemap/error.h"
#include "shapemap/geometry/sparse_cholesky.h"
#include "shapemap/optim/lbfgs.h"
#include "shapemap/optim/line_search.h"
#include <Eigen/Geometry>
#include <algorithm>
#include <chrono>
#include <cmath>
#include <ctime>
#include <exception>
#include <limits>
#include <numeric>

namespace shapemap {

namespace {

using Clock = std::chrono::steady_clock;
double since(Clock::time_point t) { return std::chrono::duration<double>(Clock::now() - t).count(); }


// Local untangling with the boundary fixed (post-step, docs/methods.md): an interior
// vertex of a folded tet (or, when that stalls, of a growing neighbourhood) is moved
// towards the mean of its neighbours (t = 1, 1/2, 1/4, 1/8) when that lowers the number of
// non-positive tets around it, or keeps it and raises their smallest volume (Gauss-Seidel
// sweeps). f n×3, rows >= nI are boundary vertices: they move only on the unit sphere
// (towards the normalized mean of their boundary neighbours, re-normalized), which is
// needed for tets with all four vertices on the boundary. Neighbourhoods could grow by
// rings when stalled; kMaxUntangleRings = 0 (measured: growing them only smooths away
// volume accuracy, e.g. spot E_I 0.018 -> 0.023, without removing more folds).
// Returns the folds left.
constexpr int kMaxUntangleRings = 0;
// Below this many vertices the preconditioner's solves run on one thread.
constexpr int kParallelSolveMin = 2000;
int untangle_interior(const Eigen::MatrixXi& T, int nI, int max_rounds, Eigen::MatrixXd& f) {
  const int n = int(f.rows());
  std::vector<std::vector<int>> vt(n), nb(n);
  for (Eigen::Index t = 0; t < T.rows(); ++t)
    for (int c = 0; c < 4; ++c) {
      vt[T(t, c)].push_back(int(t));
      for (int d = 0; d < 4; ++d)
        if (d != c) nb[T(t, c)].push_back(T(t, d));
    }
  for (auto& v : nb) {
    std::sort(v.begin(), v.end());
    v.erase(std::unique(v.begin(), v.end()), v.end());
  }
  auto vol = [&](int t) {
    const Eigen::Vector3d a = f.row(T(t, 0)), b = f.row(T(t, 1)), c = f.row(T(t, 2)), d = f.row(T(t, 3));
    return (b - a).dot((c - a).cross(d - a)) / 6.0;
  };
  auto local = [&](int i, int& nf) {
    nf = 0;
    double worst = std::numeric_limits<double>::infinity();
    for (int t : vt[i]) {
      const double v = vol(t);
      if (!(v > 0)) ++nf;
      worst = std::min(worst, v);
    }
    return worst;
  };
  auto count = [&] {
    int k = 0;
    for (Eigen::Index t = 0; t < T.rows(); ++t) k += !(vol(int(t)) > 0);
    return k;
  };
  int folded = count();
  int rings = 0, stall = 0;
  for (int round = 0; round < max_rounds && folded > 0; ++round) {
    std::vector<char> mark(n, 0);
    for (Eigen::Index t = 0; t < T.rows(); ++t)
      if (!(vol(int(t)) > 0))
        for (int c = 0; c < 4; ++c) mark[T(t, c)] = 1;
    for (int r = 0; r < rings; ++r) {
      std::vector<char> m2 = mark;
      for (int i = 0; i < n; ++i)
        if (mark[i])
          for (int j : nb[i]) m2[j] = 1;
      mark.swap(m2);
    }
    for (int i = 0; i < n; ++i) {
      if (!mark[i]) continue;
      const bool bnd = i >= nI;
      Eigen::RowVector3d c = Eigen::RowVector3d::Zero();
      int k = 0;
      for (int j : nb[i])
        if (!bnd || j >= nI) {
          c += f.row(j);
          ++k;
        }
      if (k == 0) continue;
      c /= double(k);
      if (bnd && !(c.norm() > 0)) continue;
      const Eigen::RowVector3d old = f.row(i);
      int best_nf;
      double best_w = local(i, best_nf);
      if (best_nf == 0 && rings == 0) continue;  // only vertices of folded tets move
      Eigen::RowVector3d best = old;
      for (double s = 1; s > 0.1; s *= 0.5) {
        f.row(i) = (1 - s) * old + s * c;
        if (bnd) f.row(i).normalize();
        int nf;
        const double w = local(i, nf);
        if (nf < best_nf || (nf == best_nf && w > best_w)) {
          best_nf = nf;
          best_w = w;
          best = f.row(i);
        }
      }
      f.row(i) = best;
      // Then max-min ascent (Freitag & Plassmann 2000, local optimization-based
      // untangling): move along the volume gradient of the smallest incident tet while
      // the smallest incident volume increases.
      double scale = 0;
      for (int j : nb[i]) scale = std::max(scale, (f.row(j) - f.row(i)).norm());
      for (int it = 0; it < 30 && best_w <= 0; ++it) {
        int tmin = -1;
        double vmin = std::numeric_limits<double>::infinity();
        for (int t : vt[i]) {
          const double v = vol(t);
          if (v < vmin) {
            vmin = v;
            tmin = t;
          }
        }
        int c = 0;
        while (T(tmin, c) != i) ++c;
        // d vol / d f_i = (1/6) (f_b - f_a) x (f_c - f_a) for the opposite face (a, b, c)
        // ordered so that the volume is (f_i - f_a) . ((f_b - f_a) x (f_c - f_a)) / 6 > 0.
        static const int opp[4][3] = {{1, 3, 2}, {0, 2, 3}, {0, 3, 1}, {0, 1, 2}};
        const Eigen::Vector3d fa = f.row(T(tmin, opp[c][0])), fb = f.row(T(tmin, opp[c][1])),
                              fc = f.row(T(tmin, opp[c][2]));
        Eigen::Vector3d d = (fb - fa).cross(fc - fa);
        if (bnd) {
          const Eigen::Vector3d y = f.row(i);
          d -= d.dot(y) * y;
        }
        if (!(d.norm() > 0)) break;
        d.normalize();
        const Eigen::RowVector3d o = f.row(i);
        bool moved = false;
        for (double st = 0.5 * scale; st > 1e-6 * scale; st *= 0.5) {
          f.row(i) = o + st * d.transpose();
          if (bnd) f.row(i).normalize();
          int nf;
          const double w = local(i, nf);
          if (nf < best_nf || (nf == best_nf && w > best_w)) {
            best_nf = nf;
            best_w = w;
            moved = true;
            break;
          }
        }
        if (!moved) {
          f.row(i) = o;
          break;
        }
      }
    }
    const int fn = count();
    if (fn >= folded && ++stall >= 2) {
      if (rings >= kMaxUntangleRings) break;
      ++rings;
      stall = 0;
    }
    folded = fn;
  }
  return folded;
}

}  // namespace

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

// start: a previous run on the same mesh whose boundary map and VSEM result are reused
// (steps 6-13 do not depend on the CG options), or null.
BallParamResult ball_parameterization_once(const TetMesh& mesh, const BallParamOptions& opt,
                                           const ProgressCallback& progress, const std::string& name,
                                           const BallParamResult* start) {
  const auto t_start = Clock::now();
  require_valid_volume(mesh, name, 0.0);
  require_ball_topology(mesh, name);
  BallParamResult res;
  const int n = mesh.num_vertices();

  // Steps 1-3: AST.
  Eigen::MatrixXd V = mesh.V;
  if (opt.anisotropic_scaling) {
    res.ast = anisotropic_scaling(mesh.V);
    V = res.ast.apply(mesh.V);
  }

  // Step 5: B and I; step 6: spherical area-preserving boundary map.
  TetMesh am;
  am.V = V;
  am.T = mesh.T;
  const TetBoundary tb = boundary_surface(am);
  const int nB = int(tb.to_volume.size());
  res.boundary = tb.to_volume;
  auto t0 = Clock::now();
  if (start) {
    res.sphere_folded_faces = start->sphere_folded_faces;
    res.sphere_start = start->sphere_start;
    res.sphere_area_distortion_mean = start->sphere_area_distortion_mean;
    res.sphere_area_distortion_max = start->sphere_area_distortion_max;
    res.f_vsem = start->f_vsem;
  } else {
    const SphereParamResult sph = spherical_area_preserving_map(tb.surface, {}, opt.sphere, progress);
    res.seconds_sphere = since(t0);
    res.sphere_folded_faces = sph.folded_faces;
    // A CEM stage that took no step left the linear map: report that start as linear.
    res.sphere_start = sph.start_stage == 0 && sph.conformal_iterations == 0 ? 1 : sph.start_stage;
    res.sphere_area_distortion_mean = sph.area_distortion_mean;
    res.sphere_area_distortion_max = sph.area_distortion_max;

    // Steps 7-13: VSEM fixed point.
    VsemOptions vo;
    vo.iterations = opt.vsem_iterations;
    const VsemResult vs = vsem_fixed_point(V, mesh.T, tb.to_volume, sph.S, vo, progress);
    res.seconds_vsem = vs.seconds;
    res.f_vsem = vs.f;
  }

  // Permuted numbering: interior first.
  std::vector<char> isb(n, 0);
  for (int b = 0; b < nB; ++b) isb[tb.to_volume(b)] = 1;
  Eigen::VectorXi perm, iperm;
  const int nI = interior_first_order(isb, perm, iperm, &V);
  const Eigen::MatrixXi Tp = renumber_tets(mesh.T, perm);
  Eigen::MatrixXd Vp(n, 3), fp(n, 3);
  for (int i = 0; i < n; ++i) {
    Vp.row(perm(i)) = V.row(i);
    fp.row(perm(i)) = res.f_vsem.row(i);
  }
  const IsovolumetricEnergy energy(Vp, Tp);
  Eigen::VectorXi interior(nI), boundary(nB);
  std::iota(interior.data(), interior.data() + nI, 0);
  std::iota(boundary.data(), boundary.data() + nB, nI);
  SphericalBallEnergy sbe(energy, interior, boundary);
  // Boundary faces in boundary-local numbering (for the frame choice).
  Eigen::MatrixXi Fb = energy.boundary_faces();
  for (Eigen::Index k = 0; k < Fb.rows(); ++k)
    for (int c = 0; c < 3; ++c) Fb(k, c) -= nI;

  // Steps 13-16: L_V(f^(0)), preconditioner blocks, Cholesky factors (once).
  t0 = Clock::now();
  Eigen::SparseMatrix<double> L;
  // Simplicial: the CG loop is solve-bound (two solves per iteration), see sparse_cholesky.h.
  SparseCholesky cholI(SparseCholesky::Method::Simplicial, SparseCholesky::Ordering::NestedDissection);
  SparseCholesky cholB(SparseCholesky::Method::Simplicial);
  // L_V(f) is positive semidefinite for every f (each tet adds (2 / (3|tau|)) G G^T), but
  // collapsed image tets can make its blocks numerically singular, so that CHOLMOD
  // fails. Then the preconditioner falls back to L_V(e) of the (scaled) input, which is
  // only a preconditioner choice: the energy and its gradient are unchanged.
  auto factor_blocks = [&](const Eigen::MatrixXd& at, bool first) {
    energy.stretch_laplacian(at, L);
    if (nI > 0) {
      Eigen::SparseMatrix<double> LII = L.topLeftCorner(nI, nI);
      if (first) cholI.compute(LII); else cholI.factorize(LII);
    }
    Eigen::SparseMatrix<double> LBB = L.bottomRightCorner(nB, nB);
    if (first) cholB.compute(LBB); else cholB.factorize(LBB);
  };
  bool m_is_input_laplacian = false;  // M was factored from L_V(e)
  try {
    factor_blocks(fp, true);
  } catch (const Error&) {
    res.preconditioner_fallbacks++;
    factor_blocks(Vp, true);
    m_is_input_laplacian = true;
  }
  res.seconds_factor = since(t0);
  // Re-factor the preconditioner blocks at the current map (same pattern).
  auto refactor = [&](const Eigen::VectorXd& xx) {
    const auto tf = Clock::now();
    Eigen::MatrixXd fc;
    sbe.to_map(xx, fc);
    try {
      factor_blocks(fc, false);
      m_is_input_laplacian = false;
    } catch (const Error&) {
      res.preconditioner_fallbacks++;
      factor_blocks(Vp, false);
      m_is_input_laplacian = true;
    }
    res.seconds_factor += since(tf);
  };

  // Step 17: spherical coordinates, in a pole-avoiding frame.
  auto choose_frame = [&](const Eigen::MatrixXd& f, Eigen::VectorXd& s_phi) {
    if (opt.rotate_frame) sbe.set_frame(pole_avoiding_frame(f.bottomRows(nB), Fb));
    Eigen::VectorXd x = sbe.from_map(f);
    s_phi.resize(nB);
    for (int b = 0; b < nB; ++b)
      s_phi(b) = opt.metric_phi_preconditioner ? std::max(1e-3, std::sin(x(3 * nI + b))) : 1.0;
    return x;
  };
  // Smallest sin(theta) over the boundary: the pole guard compares it with the chart's
  // value at the last frame choice (whatever the phi preconditioner block).
  auto min_sin_theta = [&](const Eigen::VectorXd& xx) {
    double smin = 1;
    for (int b = 0; b < nB; ++b) smin = std::min(smin, std::abs(std::sin(xx(3 * nI + b))));
    return smin;
  };
  Eigen::VectorXd s_phi;
  Eigen::VectorXd x = choose_frame(fp, s_phi);
  double s_min_chart = std::max(1e-3, min_sin_theta(x));

  const int N = sbe.num_variables();
  // Right-hand sides of the two solve halves below (allocated once).
  Eigen::MatrixXd gI01(nI, 2), gI2(nI, 1), gB(nB, 2);
  // h = M^{-1} g with M = blockdiag(I3 (x) L_II, L_BB, S L_BB S) (Eq. 16, step 22).
  auto precondition = [&](const Eigen::VectorXd& g, Eigen::VectorXd& h) {
    const auto ts = Clock::now();
    h.resize(N);
    gI01.col(0) = g.segment(0, nI);
    gI01.col(1) = g.segment(nI, nI);
    gI2.col(0) = g.segment(2 * nI, nI);
    gB.col(0) = g.segment(3 * nI, nB);
    gB.col(1) = g.segment(3 * nI + nB, nB).cwiseQuotient(s_phi);
    // The solves are independent and SparseCholesky::solve is safe to call concurrently:
    // two balanced halves (2 interior columns | 1 interior column + the boundary block).
    // An exception must not leave an OpenMP section (std::terminate): kept and rethrown.
    Eigen::MatrixXd hI01, hI2, hB;
    std::exception_ptr failure[2];
#pragma omp parallel sections if (n > kParallelSolveMin)
    {
#pragma omp section
      try {
        if (nI > 0) hI01 = cholI.solve(gI01);
      } catch (...) {
        failure[0] = std::current_exception();
      }
#pragma omp section
      try {
        if (nI > 0) hI2 = cholI.solve(gI2);
        hB = cholB.solve(gB);
      } catch (...) {
        failure[1] = std::current_exception();
      }
    }
    for (const auto& e : failure)
      if (e) std::rethrow_exception(e);
    if (nI > 0) {
      h.segment(0, nI) = hI01.col(0);
      h.segment(nI, nI) = hI01.col(1);
      h.segment(2 * nI, nI) = hI2.col(0);
    }
    h.segment(3 * nI, nB) = hB.col(0);
    h.segment(3 * nI + nB, nB) = hB.col(1).cwiseQuotient(s_phi);
    res.seconds_cg_solve += since(ts);
  };
  const Objective objective = [&](const Eigen::VectorXd& xx, Eigen::VectorXd& gg) {
    const auto te = Clock::now();
    ++res.evaluations;
    const double e = sbe.energy_and_gradient(xx, gg);
    res.seconds_cg_eval += since(te);
    return e;
  };
  auto energy_only = [&](const Eigen::VectorXd& xx) {
    const auto te = Clock::now();
    ++res.evaluations;
    const double e = sbe.energy(xx);
    res.seconds_cg_eval += since(te);
    return e;
  };

  // Steps 18-38: preconditioned nonlinear CG.
  const auto t_cg = Clock::now();
  const std::clock_t c_cg = std::clock();
  Eigen::VectorXd g(N), h(N), p(N), xn(N), gn(N);
  double E = objective(x, g);
  int folds = sbe.inverted_tets(x);
  res.inverted_vsem = folds;
  res.energy_vsem = E;
  // The CG loop (steps 18-38); `guard` = prevent_new_folds. Returns on convergence,
  // stall or max_iter; x, g, E, folds hold the last iterate.
  auto cg_loop = [&](int max_iter, bool guard) {
    folds = sbe.inverted_tets(x);
    precondition(g, h);
    double lambda = g.dot(h);  // step 24
    p = -h;                    // step 25
    double alpha_prev = opt.initial_step;
    bool steepest = true;  // p == -M^{-1} g
    for (int k = 0; k < max_iter; ++k) {
      double dphi0 = g.dot(p);
      if (!(dphi0 < 0)) {  // not a descent direction: restart along -M^{-1} g
        p = -h;
        dphi0 = -lambda;
        ++res.restarts;
        steepest = true;
        if (!(dphi0 < 0)) break;  // zero gradient
      }
      // Step 32: alpha by the quadratic model through Phi(0), Phi'(0), Phi(alpha_prev) (Eq. 17).
      double alpha = -1;
      {
        xn = x + alpha_prev * p;
        const double Ea = energy_only(xn);
        const double denom = 2 * (Ea - E - alpha_prev * dphi0);
        if (std::isfinite(Ea) && denom > 0) alpha = -alpha_prev * alpha_prev * dphi0 / denom;
      }
      double En = std::numeric_limits<double>::infinity();
      bool accepted = false;
      if (alpha > 0 && std::isfinite(alpha)) {
        xn = x + alpha * p;
        En = objective(xn, gn);
        accepted = En < E;
        // Optionally require the strong Wolfe conditions (Eq. 18) of the model step too.
        if (accepted && opt.wolfe_model_step)
          accepted = En <= E + opt.c1 * alpha * dphi0 && std::abs(gn.dot(p)) <= -opt.c2 * dphi0;
      }
      if (accepted) {
        ++res.quadratic_steps;
      } else {
        // Fallback: strong Wolfe line search (Eq. 18), from the model step if it was usable.
        const double a0 = (alpha > 0 && std::isfinite(alpha)) ? alpha : alpha_prev;
        LineSearchResult ls = strong_wolfe_search(objective, x, E, g, p, a0, opt.c1, opt.c2,
                                                  opt.max_line_search, xn, gn);
        if (!ls.ok || !(ls.f < E)) {
          if (steepest) break;  // no progress even along -M^{-1} g
          p = -h;
          ++res.restarts;
          steepest = true;
          continue;
        }
        alpha = ls.alpha;
        En = ls.f;
        ++res.wolfe_steps;
      }
      // Optional guard: no step may increase the number of inverted tets.
      if (guard) {
        int fn = sbe.inverted_tets(xn);
        int tries = 0;
        // Halve by the fold count alone (one volume pass); E and g once, at the final step.
        while (fn > folds && tries < 30) {
          alpha *= 0.5;
          xn = x + alpha * p;
          fn = sbe.inverted_tets(xn);
          ++tries;
          ++res.fold_backtracks;
        }
        if (tries > 0) En = objective(xn, gn);
        if (fn > folds || !(En < E)) {
          if (steepest) break;
          p = -h;
          ++res.restarts;
          steepest = true;
          continue;
        }
        folds = fn;
      }
      // Steps 33-37.
      const double delta = E - En;
      x.swap(xn);
      g.swap(gn);
      E = En;
      alpha_prev = alpha;
      ++res.iterations;
      res.energies.push_back(E);
      report(progress, "ball/cg", double(k + 1) / std::max(1, max_iter));
      if (delta < opt.tolerance) {
        res.converged = true;
        break;
      }
      // Pole guard: a boundary vertex close to a pole of the frame -> new frame, restart.
      bool new_frame = false;
      if (opt.rotate_frame) {
        if (min_sin_theta(x) < opt.pole_guard * s_min_chart) {
          Eigen::MatrixXd f;
          sbe.to_map(x, f);
          x = choose_frame(f, s_phi);
          s_min_chart = std::max(1e-3, min_sin_theta(x));
          E = objective(x, g);
          ++res.frame_rotations;
          new_frame = true;
        }
      }
      // Steps 22, 27-30: h = M^{-1} g, beta = lambda / lambda_0 (Eq. 16c), p = -h + beta p.
      precondition(g, h);
      const double lambda0 = lambda;
      lambda = g.dot(h);
      if (opt.preconditioner_refresh > 0 && (k + 1) % opt.preconditioner_refresh == 0) {
        refactor(x);
        new_frame = true;  // restart: M changed
        ++res.preconditioner_refreshes;
        precondition(g, h);
        lambda = g.dot(h);
      }
      if (new_frame) {
        p = -h;
        ++res.restarts;
        steepest = true;
      } else {
        const double beta = lambda / lambda0;
        p = -h + beta * p;
        steepest = false;
      }
    }
  };
  // Boundary-layer barrier on during CG (E, g and the stopping test see E_I + barrier);
  // E is re-evaluated without it afterwards.
  std::vector<int> all_faces(size_t(energy.boundary_faces().rows()));
  std::iota(all_faces.begin(), all_faces.end(), 0);
  auto barrier = [&](bool on) {
    if (opt.boundary_barrier <= 0) return;
    if (on)
      sbe.set_fold_penalty(opt.boundary_barrier, opt.penalty_floor, all_faces);
    else
      sbe.set_fold_penalty(0, 0);
    E = objective(x, g);
  };
  barrier(true);
  cg_loop(opt.max_iterations, opt.prevent_new_folds);
  // A heavily folded VSEM map (long thin parts) can give an L_V(f^(0)) that factors but is
  // nearly singular: M^{-1} g is then huge (measured 1e9 on a pair of glasses) and the model
  // steps tiny, so CG stops early or crawls. A healthy run lowers E_I by an order of
  // magnitude, so when CG left E_I above half its start with inverted tets, CG runs again
  // (MaxIter more iterations) with the L_V(e) preconditioner of the factorization fallback
  // above (measured on a bent thin tube: E_I after CG 6.03 -> 0.279 of 6.20). E is compared
  // without the barrier, like energy_vsem.
  barrier(false);
  if (opt.stall_preconditioner_fallback && !m_is_input_laplacian && E > 0.5 * res.energy_vsem &&
      sbe.inverted_tets(x) > 0) {
    res.preconditioner_fallbacks++;
    factor_blocks(Vp, false);
    m_is_input_laplacian = true;
    res.converged = false;
    barrier(true);
    cg_loop(opt.max_iterations, opt.prevent_new_folds);
    barrier(false);
  }

  res.seconds_cg = since(t_cg);
  res.cpu_seconds_cg = double(std::clock() - c_cg) / CLOCKS_PER_SEC;
  // The cost split reports the CG loop of Algorithm 1 only; the post-step has its own time.
  const double eval_cg = res.seconds_cg_eval, solve_cg = res.seconds_cg_solve;
  Eigen::MatrixXd f;
  sbe.to_map(x, f);
  res.inverted_cg = sbe.inverted_tets(x);
  res.energy_cg = E;
  // Post-step (docs/methods.md): (1) local untangling of the remaining folded tets;
  // (2) if folds remain, L-BFGS on E_I + fold penalty (tets, and boundary faces next to the
  // folds) with the weight raised tenfold per round until none is left; (3) CG polishing
  // (with the boundary barrier if on) in which no step may increase the number of folded
  // tets. Each stage is kept only if it lowers the fold count and its E_I is not above the
  // VSEM start's (or the CG result's, if higher): on a pair of glasses (120k tets) the
  // penalty rounds traded 5080 -> 1847 folds for E_I 4.6 -> 781 with interior vertices at
  // radius 75, which is no ball map.
  auto count_folds = [&](const Eigen::MatrixXd& fm) {
    Eigen::VectorXd vol;
    energy.image_volumes(fm, vol);
    return int((vol.array() <= 0).count());
  };
  // Boundary faces whose image triangle is negatively oriented seen from the origin
  // (reported, not repaired here; see boundary_barrier and docs/methods.md).
  const Eigen::MatrixXi& Fo = energy.boundary_faces();
  res.flipped_boundary_faces_cg = spherical_folded_faces(f, Fo);
  if (res.inverted_cg > 0 && (opt.untangle_rounds > 0 || opt.penalty_rounds > 0)) {
    const auto t_post = Clock::now();
    const bool converged = res.converged;
    const int it0 = res.iterations;
    // E_I bound for the stages (the CG result can exceed E_vsem only with the barrier on).
    const double e_cap = std::max(res.energy_vsem, energy.energy(f));
    int now = res.inverted_cg;
    Eigen::MatrixXd fu = f;
    if (opt.untangle_rounds > 0 && res.inverted_cg > 0) {
      untangle_interior(Tp, nI, opt.untangle_rounds, fu);
      const int k = count_folds(fu);
      if (k < now && energy.energy(fu) <= e_cap) {
        f = fu;
        now = k;
      }
    }
    if (now > 0 && opt.penalty_rounds > 0) {
      x = sbe.from_map(f);
      // Boundary faces at the vertices of folded tets are penalized too (their image
      // orientation on the sphere, same floor): a fold next to a locally folded boundary
      // cannot be removed by the tet term alone (measured: creature seed 2).
      std::vector<int> faces;
      {
        Eigen::VectorXd vol;
        energy.image_volumes(f, vol);
        std::vector<char> near(n, 0);
        for (Eigen::Index t = 0; t < Tp.rows(); ++t)
          if (!(vol(t) > 0))
            for (int c = 0; c < 4; ++c) near[Tp(t, c)] = 1;
        for (Eigen::Index q = 0; q < Fo.rows(); ++q)
          if (near[Fo(q, 0)] || near[Fo(q, 1)] || near[Fo(q, 2)]) faces.push_back(int(q));
      }
      double mu = opt.penalty_weight;
      int k = now;
      for (int r = 0; r < opt.penalty_rounds && k > 0; ++r, mu *= 10) {
        sbe.set_fold_penalty(mu, opt.penalty_floor, faces);
        LbfgsOptions lo;
        lo.max_iterations = opt.polish_iterations;
        lo.grad_tol = 0;
        const LbfgsResult lr = lbfgs_minimize(objective, x, lo);
        res.iterations += lr.iterations;
        sbe.to_map(x, fu);
        k = count_folds(fu);
        ++res.penalty_rounds;
      }
      sbe.set_fold_penalty(0, 0);
      if (k < now && energy.energy(fu) <= e_cap) {
        f = fu;
        now = k;
      }
    }
    if (now < res.inverted_cg && opt.polish_iterations > 0) {
      x = sbe.from_map(f);
      E = objective(x, g);
      barrier(true);
      cg_loop(opt.polish_iterations, true);
      barrier(false);
      sbe.to_map(x, fu);
      if (count_folds(fu) <= now && energy.energy(fu) <= e_cap) f.swap(fu);
    }
    res.polish_iterations = res.iterations - it0;
    res.converged = converged;
    E = energy.energy(f);
    res.seconds_post = since(t_post);
    res.seconds_cg_eval = eval_cg;
    res.seconds_cg_solve = solve_cg;
  }
  res.flipped_boundary_faces_final = spherical_folded_faces(f, Fo);
  res.inverted_final = count_folds(f);
  res.energy_final = E;
  res.f.resize(n, 3);
  for (int i = 0; i < n; ++i) res.f.row(i) = f.row(perm(i));
  report(progress, "ball/cg", 1.0);
  res.seconds_total = since(t_start);
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
