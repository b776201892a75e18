// Elastic correspondence, Algorithm 1 (Eq. 4, 6). See elastic.h and docs/methods.md.
#include "shapemap/surface/elastic.h"

#include "shapemap/adjacency.h"
#include "shapemap/splitmix.h"
#include "shapemap/timing.h"
#include "shapemap/eval/surface_distortion.h"

#include "shapemap/error.h"
#include "shapemap/geometry/closest_point.h"
#include "shapemap/geometry/mass.h"
#include "shapemap/optim/lbfgs_memory.h"
#include "shapemap/mesh.h"
#include "shapemap/surface/elastic_preconditioner.h"
#include "shapemap/surface/shell_energy.h"

#include <Eigen/Geometry>
#include <omp.h>

#include <algorithm>
#include <exception>
#include <system_error>
#include <functional>
#include <thread>
#include <utility>
#include <limits>
#include <chrono>
#include <cmath>

namespace shapemap {

namespace {

using RowMat3 = Eigen::Matrix<double, Eigen::Dynamic, 3, Eigen::RowMajor>;

// Loops of Algorithm 1 over vertices run in parallel only from this size on: on the shared
// 2-core machine a parallel region inside the alternating loop cost more than it saved for
// 5k-vertex meshes (threads waiting for a descheduled partner); at 10k vertices on an idle
// one the parallel projections save ~9% of the run (docs/methods.md, "Speed"). Results do
// not depend on it (each row is independent).
constexpr int kParallelMinRows = 1 << 13;

// Total area, summed in face order (the unit-area scale of Sec. 5.2).
double total_area(const Eigen::MatrixXd& V, const Eigen::MatrixXi& F) {
  const Eigen::VectorXd A = triangle_areas(V, F);
  double s = 0;
  for (Eigen::Index f = 0; f < A.size(); ++f) s += A(f);
  return s;
}

// Clamp tiny negative coordinates and renormalize (projection round-off).
void sanitize(BarycentricMap& map) {
  for (int i = 0; i < map.size(); ++i) {
    double s = 0;
    for (int j = 0; j < 3; ++j) {
      double& b = map.bary(i, j);
      if (!(b > 0)) b = 0;
      s += b;
    }
    if (s > 0) map.bary.row(i) /= s;
    else map.bary.row(i) << 1.0, 0.0, 0.0;
  }
}

// out = P * V (rows: sum_j bary(i,j) V(F(elem(i), j)))
void apply_map(const BarycentricMap& P, const Eigen::MatrixXi& F, const Eigen::MatrixXd& V,
               RowMat3& out) {
  out.resize(P.size(), 3);
#pragma omp parallel for schedule(static) if (P.size() >= kParallelMinRows)
  for (int i = 0; i < P.size(); ++i) {
    const int f = P.elem(i);
    out.row(i) = P.bary(i, 0) * V.row(F(f, 0)) + P.bary(i, 1) * V.row(F(f, 1)) +
                 P.bary(i, 2) * V.row(F(f, 2));
  }
}

// L-BFGS of the Y / Y~ steps: the curvature memory and two-loop recursion of
// optim/lbfgs_memory.h (shared with lbfgs_minimize) with an Armijo backtracking of its own,
// so that (a) all vectors live in the side and are allocated once per run, (b) the
// curvature pairs can be kept from one outer iteration to the next (warm start,
// ElasticOptions::lbfgs_warm_start), and (c) the parts of the energy at the accepted point
// come from the last evaluation.
struct ElasticLbfgs {
  LbfgsMemory H;                 // curvature pairs (optim/lbfgs_memory.h)
  Eigen::VectorXd x, x0, g, d, x_new, g_new;
  void init(Eigen::Index n, int memory) {
    H.init(n, memory);
    for (Eigen::VectorXd* v : {&x, &x0, &g, &d, &x_new, &g_new}) v->resize(n);
  }
  void reset() { H.reset(); }
};

// One side of the alternating scheme: the deformation Y of the source (X, F) toward
// the target (Xt, Ft), with P its projection and Q the reverse projection.
struct Side {
  Eigen::MatrixXd X;            // source vertices (normalized frame), n×3
  Eigen::MatrixXi F;
  Eigen::VectorXd mass;         // lumped mass of the source
  ShellEnergy shell;
  BarycentricMap P;             // source vertices -> target faces
  RowMat3 Y;                    // deformation of the source, n×3
  RowMat3 PXt;                  // P X~ (targets of the mismatch term)
  ClosestPointBVH<6> bvh6;      // target triangulation in R^6 (bijective)
  ClosestPointBVH<3> bvh3;      // target triangulation in R^3 (injective)
  bool built = false;
  // projection scratch (allocated once): A (n~×6), B (n×6) and the query results, whose
  // elements are the hints (previous P) of the next projection.
  Eigen::MatrixXd projA, projB;
  std::vector<ClosestPointResult> proj;
  ElasticLbfgs lbfgs;           // Y-step L-BFGS buffers and (warm-start) curvature pairs
  // The shell part (Eq. 2) at Y where the last Y step ended: its value, its gradient (shell_g;
  // shell_g_new is the trial point's), valid until Y or the admissible edges change. The next
  // Y step starts at that Y, so its first evaluation needs only the terms P and Q changed.
  Eigen::VectorXd shell_g, shell_g_new;
  double shell_W = 0;
  bool shell_valid = false;
  // The reversibility term's rows gamma m~_j |Q_j Y - X~_j|^2 of the Y step (Q = the other
  // side's P, fixed during the step), packed: corners of Q_j's face, its barycentric
  // coordinates, X~_j and m~_j, read in order by every evaluation (pack_reversibility_rows).
  struct ReversibilityRow {
    int c[3];
    double b[3], x[3], m;
  };
  std::vector<ReversibilityRow> rev_rows;
  // H0 = (theta K)^-1 of the Y steps (ElasticOptions::precondition_stiffness): K, its
  // diagonal's scratch and the scale theta of the newest curvature pair
  ElasticPreconditioner pre;
  Eigen::VectorXd pre_diag;
  double pre_theta = 1;
  // the last accepted step of an L-BFGS iteration with curvature pairs, kept across Y steps
  // (ElasticOptions::interpolate_initial_step)
  double alpha_last = 1;
  // safe projection (ElasticOptions::safe_projection): the previous P, the target's unit face
  // normals, per-face flags, and how many rows kept their previous value so far
  BarycentricMap P_prev;
  Eigen::MatrixXd target_normals;
  std::vector<unsigned char> fold_prev;
  long long rows_kept = 0;
  int sliver_mask_steps = 0;  // Y steps that left slivers out of the bending set (mask_tol)
  // ElasticOptions::anchors, this side's view: source vertex, target vertex, a target face
  // with its corner at that vertex (the fixed P row), and the weight of the Y-step term
  std::vector<int> anchor_src, anchor_dst, anchor_face, anchor_corner;
  std::vector<char> anchor_on;  // holding (ElasticAnchors::activation)
  double anchor_weight = 0, anchor_activation = 0;
};

// Side s's anchors src[k] -> dst[k] onto the target side t (ElasticAnchors).
void set_anchors(Side& s, const Side& t, const std::vector<int>& src, const std::vector<int>& dst, double weight,
                 double activation) {
  if (src.size() != dst.size()) throw InputError("elastic: anchors: the two lists have different lengths");
  const int n = int(s.X.rows()), nt = int(t.X.rows());
  std::vector<int> face(nt, -1), corner(nt, -1);
  for (int f = 0; f < t.F.rows(); ++f)
    for (int c = 0; c < 3; ++c)
      if (face[t.F(f, c)] < 0) face[t.F(f, c)] = f, corner[t.F(f, c)] = c;
  s.anchor_src.clear(), s.anchor_dst.clear(), s.anchor_face.clear(), s.anchor_corner.clear();
  for (size_t k = 0; k < src.size(); ++k) {
    if (src[k] < 0 || src[k] >= n || dst[k] < 0 || dst[k] >= nt)
      throw InputError("elastic: anchor " + std::to_string(k) + " out of range");
    if (face[dst[k]] < 0) continue;  // a vertex in no face: nothing to fix the row to
    s.anchor_src.push_back(src[k]);
    s.anchor_dst.push_back(dst[k]);
    s.anchor_face.push_back(face[dst[k]]);
    s.anchor_corner.push_back(corner[dst[k]]);
  }
  s.anchor_weight = weight;
  s.anchor_activation = activation;
  s.anchor_on.assign(s.anchor_src.size(), activation > 0 ? 0 : 1);
}

// ElasticAnchors::release_after_ramp: the anchors let go (and are not taken up again); how many
// held is recorded first.
void release_anchors(Side& a, Side& b, ElasticResult& res) {
  for (char on : a.anchor_on) res.anchors_holding_AB += on;
  for (char on : b.anchor_on) res.anchors_holding_BA += on;
  res.anchors_released = !a.anchor_on.empty() || !b.anchor_on.empty();
  for (Side* s : {&a, &b}) {
    std::fill(s->anchor_on.begin(), s->anchor_on.end(), 0);
    s->anchor_activation = std::numeric_limits<double>::infinity();
  }
}

// ElasticAnchors::activation: an anchor starts holding when the P step's row of its vertex
// lands farther than the activation distance from its partner (the refinement pulls the pair
// apart), and holds from then on.
void activate_anchors(Side& s, const Side& t) {
  for (size_t k = 0; k < s.anchor_src.size(); ++k) {
    if (s.anchor_on[k]) continue;
    const int i = s.anchor_src[k], f = s.P.elem(i);
    Eigen::RowVector3d x = Eigen::RowVector3d::Zero();
    for (int c = 0; c < 3; ++c) x += s.P.bary(i, c) * t.X.row(t.F(f, c));
    if ((x - t.X.row(s.anchor_dst[k])).norm() > s.anchor_activation) s.anchor_on[k] = 1;
  }
}

// Mapped triangle f of the source under P is folded: collapsed (area below 1e-6 of its rest
// area) or flipped (normal against the target's at its corners' images).
bool mapped_face_folds(const Side& s, const Side& t, const BarycentricMap& P, int f) {
  Eigen::Vector3d y[3];
  Eigen::Vector3d nt = Eigen::Vector3d::Zero();
  for (int j = 0; j < 3; ++j) {
    const int v = s.F(f, j), e = P.elem(v);
    y[j] = (P.bary(v, 0) * t.X.row(t.F(e, 0)) + P.bary(v, 1) * t.X.row(t.F(e, 1)) +
            P.bary(v, 2) * t.X.row(t.F(e, 2))).transpose();
    nt += s.target_normals.row(e).transpose();
  }
  const Eigen::Vector3d x0 = s.X.row(s.F(f, 0));
  const double nref = (Eigen::Vector3d(s.X.row(s.F(f, 1))) - x0).cross(Eigen::Vector3d(s.X.row(s.F(f, 2))) - x0).norm();
  const Eigen::Vector3d n = (y[1] - y[0]).cross(y[2] - y[0]);
  return !(n.norm() > 1e-6 * nref) || n.dot(nt) < 0;
}

// Issue 20 (ElasticOptions::safe_projection). The P step's energy is a sum over rows, so a
// row may keep its previous value and E still does not increase (the previous P was the one
// the last Y step was computed with). Rows of corners of a mapped triangle that the new rows
// fold and the previous ones did not keep their previous value; repeated until no such
// triangle is left (rows are only reverted, in face order: deterministic). Returns the count.
int keep_rows_that_fold(Side& s, const Side& t) {
  const int m = int(s.F.rows());
  if (s.target_normals.rows() != t.F.rows()) s.target_normals = face_normals(t.X, t.F);
  // fold_prev: the flags of P_prev = the P this function returned last time. A face that was
  // fine before that call is fine after it (else the loop below would not have ended), so
  // only the faces flagged then need a new test (the flags depend on P and fixed data only).
  if (int(s.fold_prev.size()) != m) s.fold_prev.assign(m, 1);
  for (int f = 0; f < m; ++f)
    if (s.fold_prev[f]) s.fold_prev[f] = mapped_face_folds(s, t, s.P_prev, f);
  int kept = 0;
  for (bool changed = true; changed;) {
    changed = false;
    for (int f = 0; f < m; ++f) {
      if (s.fold_prev[f] || !mapped_face_folds(s, t, s.P, f)) continue;
      for (int j = 0; j < 3; ++j) {
        const int v = s.F(f, j);
        if (s.P.elem(v) == s.P_prev.elem(v) && s.P.bary.row(v) == s.P_prev.bary.row(v)) continue;
        s.P.elem(v) = s.P_prev.elem(v);
        s.P.bary.row(v) = s.P_prev.bary.row(v);
        ++kept;
        changed = true;
      }
    }
  }
  return kept;
}

// P step: rows of B = [sqrt(beta) Y, sqrt(gamma) X] onto the target triangulation with
// vertex coordinates A = [sqrt(beta) X~, sqrt(gamma) Y~] (Sec. 5.1 "Mapping optimization").
// The BVH is built once and refit afterwards; every query starts from the previous face
// of that vertex as a hint (the same exact closest point, fewer boxes visited).
void projection_step(Side& s, const Side& t, double beta, double gamma, bool bijective,
                     bool safe) {
  const int n = int(s.X.rows());
  if (int(s.proj.size()) != n) {
    s.proj.assign(n, ClosestPointResult{});
    for (int i = 0; i < n; ++i) s.proj[i].elem = s.P.elem(i);
  }
  if (bijective) {
    const double sb = std::sqrt(beta), sg = std::sqrt(gamma);
    s.projA.resize(t.X.rows(), 6);
    s.projB.resize(n, 6);
    s.projA.leftCols(3) = sb * t.X;
    s.projA.rightCols(3) = sg * t.Y;
    s.projB.leftCols(3) = sb * s.Y;
    s.projB.rightCols(3) = sg * s.X;
    if (!s.built) {
      s.bvh6.build(s.projA, t.F);
      s.built = true;
    } else {
      s.bvh6.refit(s.projA);
    }
    const Eigen::MatrixXd& B = s.projB;
#pragma omp parallel for schedule(dynamic, 64) if (n >= kParallelMinRows)
    for (int i = 0; i < n; ++i)
      s.proj[i] = s.bvh6.query(ClosestPoint6::Point(B.row(i).transpose()), s.proj[i].elem);
  } else {
    if (!s.built) {
      s.bvh3.build(t.X, t.F);  // beta scales both sides alike: project Y onto X~ in R^3
      s.built = true;
    }
#pragma omp parallel for schedule(dynamic, 64) if (n >= kParallelMinRows)
    for (int i = 0; i < n; ++i)
      s.proj[i] = s.bvh3.query(ClosestPoint3::Point(s.Y.row(i).transpose()), s.proj[i].elem);
  }
  if (safe) s.P_prev = s.P;
  for (int i = 0; i < n; ++i) {
    if (s.proj[i].elem < 0) {  // keep the previous row (cannot happen on valid input)
      s.proj[i].elem = s.P.elem(i);
      continue;
    }
    s.P.elem(i) = s.proj[i].elem;
    s.P.bary.row(i) = s.proj[i].bary.head<3>().transpose();
  }
  activate_anchors(s, t);
  for (size_t k = 0; k < s.anchor_src.size(); ++k) {  // anchored rows stay at their vertex
    if (!s.anchor_on[k]) continue;
    const int i = s.anchor_src[k];
    s.P.elem(i) = s.proj[i].elem = s.anchor_face[k];
    s.P.bary.row(i).setZero();
    s.P.bary(i, s.anchor_corner[k]) = 1;
  }
  sanitize(s.P);
  if (safe) s.rows_kept += keep_rows_that_fold(s, t);
  apply_map(s.P, t.F, t.X, s.PXt);
}

struct EnergyParts {
  double deformation = 0, mismatch = 0, reversibility = 0;
};

// Side s's reversibility rows for a Y step against side t (Side::rev_rows): once per step
// instead of gathering Q's rows, faces and X~ from three column-major arrays per evaluation.
void pack_reversibility_rows(Side& s, const Side& t) {
  const BarycentricMap& Q = t.P;
  s.rev_rows.resize(size_t(Q.size()));
  for (int j = 0; j < Q.size(); ++j) {
    Side::ReversibilityRow& r = s.rev_rows[size_t(j)];
    const int f = Q.elem(j);
    for (int k = 0; k < 3; ++k) {
      r.c[k] = s.F(f, k);
      r.b[k] = Q.bary(j, k);
      r.x[k] = t.X(j, k);
    }
    r.m = t.mass(j);
  }
}

// Terms of E (Eq. 6) that involve the side's Y:
//   W_def(X, Y) + beta |P X~ - Y|_X^2 + gamma |Q Y - X~|_X~^2
// with Q = the target side's projection (target vertices -> source faces).
// Evaluation writes the parts of the last evaluation into `last`.
class DeformationObjective {
 public:
  DeformationObjective(const Side& s, const Side& t, double beta, double gamma, bool bijective)
      : s_(s), t_(t), beta_(beta), gamma_(gamma), bij_(bijective) {}
  // E at x and its gradient g. With gs (3n values) the shell part's gradient is also left
  // in gs, and with shell_given the shell part is not evaluated: its value is *shell_given
  // and its gradient is already in gs (the Y step's first evaluation, at the point where
  // the previous Y step of this side ended, under the same admissible edges).
  double operator()(const Eigen::VectorXd& x, Eigen::VectorXd& g, double* gs = nullptr,
                    const double* shell_given = nullptr) {
    const int n = int(s_.X.rows());
    const double* y = x.data();
    double* gr = g.data();
    double Wd;
    if (gs) {
      Wd = shell_given ? *shell_given : s_.shell.evaluate(y, gs);
      std::copy(gs, gs + 3 * size_t(n), gr);
    } else {
      Wd = s_.shell.evaluate(y, gr);
    }
    // beta |P X~ - Y|_X^2 (Eq. 3 norm), gradient 2 beta M (Y - P X~)
    double mis = 0;
    const double* pxt = s_.PXt.data();
    for (int i = 0; i < n; ++i) {
      const double r0 = y[3 * i] - pxt[3 * i], r1 = y[3 * i + 1] - pxt[3 * i + 1],
                   r2 = y[3 * i + 2] - pxt[3 * i + 2];
      const double mi = s_.mass(i), w = 2 * beta_ * mi;
      mis += mi * (r0 * r0 + r1 * r1 + r2 * r2);
      gr[3 * i] += w * r0;
      gr[3 * i + 1] += w * r1;
      gr[3 * i + 2] += w * r2;
    }
    // anchors: weight |Y_a - X~_b|^2 in the same mass norm (ElasticAnchors)
    for (size_t k = 0; k < s_.anchor_src.size(); ++k) {
      if (!s_.anchor_on[k]) continue;
      const int i = s_.anchor_src[k], j = s_.anchor_dst[k];
      const double mi = s_.anchor_weight * s_.mass(i), w = 2 * beta_ * mi;
      for (int c = 0; c < 3; ++c) {
        const double r = y[3 * i + c] - t_.X(j, c);
        mis += mi * r * r;
        gr[3 * i + c] += w * r;
      }
    }
    mis *= beta_;
    double rev = 0;
    if (bij_) {
      // gamma |Q Y - X~|_X~^2 with Q = the target's map (its vertices j -> our faces),
      // gradient 2 gamma Q^T M~ (Q Y - X~): per row j, gather Q Y, scatter to the face's
      // corners (serial, fixed order).
      for (const Side::ReversibilityRow& q : s_.rev_rows) {
        const double b0 = q.b[0], b1 = q.b[1], b2 = q.b[2];
        const double* y0 = y + 3 * q.c[0];
        const double* y1 = y + 3 * q.c[1];
        const double* y2 = y + 3 * q.c[2];
        double r[3];
        for (int k = 0; k < 3; ++k) r[k] = b0 * y0[k] + b1 * y1[k] + b2 * y2[k] - q.x[k];
        const double mj = q.m, w = 2 * gamma_ * mj;
        rev += mj * (r[0] * r[0] + r[1] * r[1] + r[2] * r[2]);
        double* g0 = gr + 3 * q.c[0];
        double* g1 = gr + 3 * q.c[1];
        double* g2 = gr + 3 * q.c[2];
        for (int k = 0; k < 3; ++k) {
          const double wr = w * r[k];
          g0[k] += b0 * wr;
          g1[k] += b1 * wr;
          g2[k] += b2 * wr;
        }
      }
      rev *= gamma_;
    }
    last = {Wd, mis, rev};
    return Wd + mis + rev;
  }
  EnergyParts last;

 private:
  const Side& s_;
  const Side& t_;
  double beta_, gamma_;
  bool bij_;
};

// True when some triangle of Y that is not collapsed at y0 has, at y1, a normal turned by
// more than 90 degrees from its normal at y0: on the segment y0 -> y1 its area (nearly)
// vanished, a point the unbounded membrane barrier (log_eps = 0) must not be stepped over.
bool turns_a_triangle(const Eigen::MatrixXi& F, const double* y0, const double* y1) {
  for (int f = 0; f < F.rows(); ++f) {
    const int i = 3 * F(f, 0), j = 3 * F(f, 1), k = 3 * F(f, 2);
    const Eigen::Vector3d a0(y0[i], y0[i + 1], y0[i + 2]), b0(y0[j], y0[j + 1], y0[j + 2]),
        c0(y0[k], y0[k + 1], y0[k + 2]);
    const Eigen::Vector3d a1(y1[i], y1[i + 1], y1[i + 2]), b1(y1[j], y1[j + 1], y1[j + 2]),
        c1(y1[k], y1[k + 1], y1[k + 2]);
    const Eigen::Vector3d n0 = (b0 - a0).cross(c0 - a0), n1 = (b1 - a1).cross(c1 - a1);
    if (n0.squaredNorm() > 0 && !(n0.dot(n1) > 0)) return true;
  }
  return false;
}

// Factors K = kappa L_X + diag(2 beta m + 2 gamma Q^T m~) of side s for this Y step
// (ElasticOptions::precondition_stiffness; the pattern is analyzed once per run).
void update_preconditioner(Side& s, const Side& t, double beta, double gamma, bool bijective,
                           const ElasticOptions& opt) {
  const int n = int(s.X.rows());
  if (s.pre.num_vertices() != n)
    s.pre = ElasticPreconditioner(s.X, s.F, opt.precondition_stiffness * s.shell.options().alpha * opt.mu);
  s.pre_diag = 2 * beta * s.mass;  // exact Hessian of the mismatch term (Eq. 3/4)
  for (size_t k = 0; k < s.anchor_src.size(); ++k)  // ... and of the anchors' term
    if (s.anchor_on[k]) s.pre_diag(s.anchor_src[k]) += 2 * beta * s.anchor_weight * s.mass(s.anchor_src[k]);
  if (bijective) {  // row sums of 2 gamma Q^T M~ Q = 2 gamma Q^T m~ (rows of Q sum to 1)
    const BarycentricMap& Q = t.P;
    for (int j = 0; j < Q.size(); ++j) {
      const int f = Q.elem(j);
      for (int c = 0; c < 3; ++c) s.pre_diag(s.F(f, c)) += 2 * gamma * Q.bary(j, c) * t.mass(j);
    }
  }
  // a vertex in no face has no mass: keep K positive definite
  const double floor = 1e-12 * s.pre_diag.cwiseAbs().maxCoeff();
  s.pre_diag = s.pre_diag.cwiseMax(floor > 0 ? floor : 1e-300);
  s.pre.update_diagonal(s.pre_diag, opt.precondition_refactor_tol);
}

// The Y step's Armijo backtracking along s.lbfgs.d from s.lbfgs.x (c1 = 1e-4), starting at
// alpha; true with the accepted point in x_new, g_new (shell part in s.shell_g_new), f_new
// and parts_new. Gives up after the first trial once the predicted decrease alpha |g.d| is
// below min_decrease, or after 40 trials.
bool backtrack(DeformationObjective& obj, Side& s, bool keep_orientation, double f, double gd,
               double min_decrease, double& alpha, double& f_new, EnergyParts& parts_new, int& evaluations) {
  ElasticLbfgs& L = s.lbfgs;
  const double c1 = 1e-4;
  for (int k = 0; k < 40 && gd < 0; ++k) {
    if (k > 0 && alpha * -gd < min_decrease) break;
    L.x_new.noalias() = L.x + alpha * L.d;
    if (keep_orientation && turns_a_triangle(s.F, L.x.data(), L.x_new.data())) {
      alpha *= 0.5;  // the step would pass a triangle through zero area: shorten it
      continue;
    }
    f_new = obj(L.x_new, L.g_new, s.shell_g_new.data());
    ++evaluations;
    if (std::isfinite(f_new) && f_new <= f + c1 * alpha * gd) {
      parts_new = obj.last;
      return true;
    }
    double next = 0.5 * alpha;
    if (std::isfinite(f_new)) {
      const double curv = f_new - f - alpha * gd;  // > 0: Armijo failed
      if (curv > 0) next = std::clamp(-gd * alpha * alpha / (2 * curv), 0.1 * alpha, 0.5 * alpha);
    }
    alpha = next;
  }
  return false;
}

// A Y step stalled at the bending term's slivers (ElasticOptions::mask_tol): the admissible
// set frozen again without their edges; false when there are none. The energy changed with
// the set, so f, the gradient and parts are evaluated again and L-BFGS starts over.
bool leave_out_slivers(DeformationObjective& obj, Side& s, const ElasticOptions& opt, double& f,
                       EnergyParts& parts, int& evaluations) {
  ElasticLbfgs& L = s.lbfgs;
  if (!(opt.mask_tol > 0) || !s.shell.freeze_mask(L.x.data(), true)) return false;
  ++s.sliver_mask_steps;
  f = obj(L.x, L.g, s.shell_g.data());
  ++evaluations;
  parts = obj.last;
  L.reset();
  return true;
}

int deformation_step(Side& s, const Side& t, double beta, double gamma, bool bijective,
                     const ElasticOptions& opt, double f_tol, EnergyParts& parts, int& evaluations) {
  const int n = int(s.X.rows());
  if (bijective) pack_reversibility_rows(s, t);
  DeformationObjective obj(s, t, beta, gamma, bijective);
  ElasticLbfgs& L = s.lbfgs;
  if (L.x.size() != 3 * n) L.init(3 * n, opt.lbfgs_memory);
  if (!opt.lbfgs_warm_start) L.reset();
  L.x = Eigen::Map<const Eigen::VectorXd>(s.Y.data(), 3 * n);
  L.x0 = L.x;
  // Admissible edges fixed for this inner solve (continuous energy along line searches),
  // recomputed at the start of every Y step (docs/methods.md).
  const bool mask_changed = s.shell.freeze_mask(L.x.data());
  if (s.shell_g.size() != 3 * n) {
    s.shell_g.resize(3 * n);
    s.shell_g_new.resize(3 * n);
    s.shell_valid = false;
  }
  const bool reuse_shell = s.shell_valid && !mask_changed;
  s.shell_valid = false;
  const bool pre = opt.precondition_stiffness > 0;
  if (pre) update_preconditioner(s, t, beta, gamma, bijective, opt);
  auto direction = [&]() {  // d = -H g
    if (pre)
      L.H.direction(L.g, L.d, [&](Eigen::VectorXd& v) {
        s.pre.apply(v.data(), v.data());
        v *= s.pre_theta;
      });
    else
      L.H.direction(L.g, L.d);
  };
  double f = obj(L.x, L.g, s.shell_g.data(), reuse_shell ? &s.shell_W : nullptr);
  if (!reuse_shell) ++evaluations;
  parts = obj.last;
  int iterations = 0;
  double last_decrease = 0;  // f_{k-1} - f_k of the last accepted step (0: none yet in this Y step)
  bool restarted = false;  // the last direction was steepest descent after a reset
  bool slivers_out = false;  // the set frozen again without slivers (ElasticOptions::mask_tol)
  if (std::isfinite(f) && L.g.lpNorm<Eigen::Infinity>() >= opt.inner_tol) {
    while (iterations < opt.inner_max_iterations) {
      direction();
      double gd = L.g.dot(L.d);
      if (!(gd < 0)) {  // not a descent direction (rounding): steepest descent (or -K^-1 g)
        L.reset();
        if (pre) direction();
        else L.d = -L.g;
        gd = L.g.dot(L.d);
      }
      // Armijo backtracking (Sec. 5.1); first step without curvature information: unit length.
      // Backtracking by safeguarded quadratic interpolation (Nocedal & Wright Sec. 3.5:
      // the minimizer of the quadratic through f(0), f'(0), f(alpha), kept in
      // [0.1, 0.5] alpha). After the first trial the search gives up once the predicted
      // decrease alpha |g.d| is below the inner stalled-progress tolerance (an accepted step
      // would end the solve on that criterion anyway) instead of halving down to rounding
      // noise (up to 40 evaluations, then as many again from steepest descent).
      double alpha = L.H.stored() == 0 && !pre ? std::min(1.0, 1.0 / std::sqrt(-gd)) : 1.0;
      // ElasticOptions::interpolate_initial_step: the larger of the last accepted step and
      // the step that repeats the last decrease (N&W Eq. 3.60), at most 1
      const bool from_memory = L.H.stored() > 0;
      if (opt.interpolate_initial_step)
        alpha = std::min(alpha, std::max(s.alpha_last, last_decrease > 0 ? 1.01 * 2 * last_decrease / -gd : 1.0));
      const double min_decrease =
          f_tol > 0 ? f_tol * std::max(1.0, std::abs(f)) : 0.0;
      double f_new = f;
      EnergyParts p_new;
      const bool ok = backtrack(obj, s, opt.keep_orientation, f, gd, min_decrease, alpha, f_new, p_new, evaluations);
      if (!ok) {
        if (L.H.stored() > 0 && !restarted) {  // retry once from steepest descent
          L.reset();
          restarted = true;
          continue;
        }
        if (slivers_out || !leave_out_slivers(obj, s, opt, f, parts, evaluations)) break;
        slivers_out = true;
        restarted = false;
        last_decrease = 0;
        if (!std::isfinite(f) || L.g.lpNorm<Eigen::Infinity>() < opt.inner_tol) break;
        continue;
      }
      restarted = false;
      // steps without curvature pairs (H0 alone) may need a long backtrack: not a guide
      if (from_memory) s.alpha_last = alpha;
      L.H.add_pair(L.x, L.x_new, L.g, L.g_new);
      if (pre && opt.precondition_scaling) {  // theta' = s'Ks / s'y, s = alpha d: H0 = theta' K^-1 fits the pair
        const double sy = alpha * L.d.dot(L.g_new - L.g);
        const double sKs = alpha * alpha * s.pre.quadratic_form(L.d.data());
        if (sy > 0 && sKs > 0) s.pre_theta = std::min(opt.precondition_theta_max, sKs / sy);
      }
      const double f_old = f;
      last_decrease = f - f_new;
      L.x.swap(L.x_new);
      L.g.swap(L.g_new);
      s.shell_g.swap(s.shell_g_new);
      f = f_new;
      parts = p_new;
      ++iterations;
      if (L.g.lpNorm<Eigen::Infinity>() < opt.inner_tol) break;
      if (f_tol > 0 && f_old - f < f_tol * std::max(1.0, std::abs(f))) break;
    }
  }
  s.shell.unfreeze_mask();
  if (!L.x.allFinite() || !std::isfinite(f)) {  // never hand on NaN: keep the previous Y
    L.x = L.x0;
    obj(L.x, L.g);
    parts = obj.last;
    L.reset();
  } else {
    s.shell_W = parts.deformation;  // shell_g holds its gradient at L.x
    s.shell_valid = true;
  }
  s.Y = Eigen::Map<const RowMat3>(L.x.data(), n, 3);
  return iterations;
}

// Deterministic tiny perturbation of vertices of collapsed triangles of Y: at an exactly
// collapsed triangle the membrane gradient vanishes (det G is quadratic in its normal),
// so a minimizer would never open it. Magnitude 1e-6 of the mean reference edge length.
int unstick_collapsed(Side& s) {
  const int m = int(s.F.rows());
  double h = 0;
  for (int f = 0; f < m; ++f) h += (s.X.row(s.F(f, 0)) - s.X.row(s.F(f, 1))).norm();
  h = 1e-6 * h / std::max(1, m);
  int count = 0;
  for (int f = 0; f < m; ++f) {
    const Eigen::Vector3d a = s.Y.row(s.F(f, 0)), b = s.Y.row(s.F(f, 1)), c = s.Y.row(s.F(f, 2));
    const Eigen::Vector3d xa = s.X.row(s.F(f, 0)), xb = s.X.row(s.F(f, 1)), xc = s.X.row(s.F(f, 2));
    const double nref = (xb - xa).cross(xc - xa).norm();
    if ((b - a).cross(c - a).norm() > 1e-8 * nref) continue;
    ++count;
    for (int j = 0; j < 3; ++j) {
      const unsigned v = unsigned(s.F(f, j));
      for (int k = 0; k < 3; ++k) {
        // hash of (vertex, coordinate) -> [-1, 1]
        const std::uint64_t z = splitmix64_hash(std::uint64_t(v) * 3 + k);
        s.Y(v, k) += h * (double(z >> 11) / double(1ull << 53) * 2.0 - 1.0);
      }
    }
  }
  return count;
}

int count_degenerate(const Side& s, double tol) {
  int c = 0;
  for (int f = 0; f < s.F.rows(); ++f) {
    const Eigen::Vector3d a = s.Y.row(s.F(f, 0)), b = s.Y.row(s.F(f, 1)), cc = s.Y.row(s.F(f, 2));
    const Eigen::Vector3d xa = s.X.row(s.F(f, 0)), xb = s.X.row(s.F(f, 1)), xc = s.X.row(s.F(f, 2));
    if (!((b - a).cross(cc - a).norm() > tol * (xb - xa).cross(xc - xa).norm())) ++c;
  }
  return c;
}

// Issue 20 bookkeeping for one direction (A -> B: P and Y; B -> A: Q and Y~): fold counts of
// the map and of the shell on unit-area copies, the first collapse of each, and the iterate
// the collapse guard would return.
struct DirectionLog {
  const TriMesh* S = nullptr;      // source (input coordinates, for the event centroid)
  Eigen::MatrixXd Xs, Xt, Nt;      // unit-area source, target, and the target's unit face normals
  Eigen::MatrixXi Ft;
  VertexElementsCsr target_faces;  // around each target vertex, for fold_counts (once, not per call)
  Normalization to_unit_target;    // working frame of Y -> unit-area target frame (partial mode)
  bool working_is_unit = true;
  FoldCounts map0, shell0;         // at the start
  std::vector<unsigned char> map0_faces, shell0_faces, faces;
  int keep_iteration = -1;         // latest iterate with no more bad triangles than the start
  BarycentricMap keep_P;
  Eigen::MatrixXd keep_Y;          // in the working frame

  FoldCounts map_folds(const BarycentricMap& P, std::vector<unsigned char>* out) const {
    return fold_counts(Xs, S->F, map_positions(P, Xt, Ft), Nt, Ft, P,
                       SurfaceDistortionOptions{}.degenerate_tol, out, &target_faces);
  }
  FoldCounts shell_folds(const RowMat3& Y, const BarycentricMap& P,
                         std::vector<unsigned char>* out) const {
    const Eigen::MatrixXd Yu = working_is_unit ? Eigen::MatrixXd(Y) : to_unit_target.apply(Eigen::MatrixXd(Y));
    return fold_counts(Xs, S->F, Yu, Nt, Ft, P, SurfaceDistortionOptions{}.degenerate_tol, out, &target_faces);
  }
  // Faces bad now and fine at the start -> the event (iteration k, 1-based).
  void record(ElasticCollapseEvent& ev, int k, const std::vector<unsigned char>& now,
              const std::vector<unsigned char>& start, const Side& s) const {
    ev.iteration = k;
    ev.faces.clear();
    double w = 0;
    Eigen::RowVector3d c = Eigen::RowVector3d::Zero();
    Eigen::VectorXd dist(s.X.rows());
    for (int i = 0; i < s.X.rows(); ++i) dist(i) = (s.Y.row(i) - s.PXt.row(i)).norm();
    double dsum = 0;
    int dcount = 0;
    for (int f = 0; f < int(now.size()); ++f) {
      if (!now[f] || start[f]) continue;
      if (ev.faces.size() < 64) ev.faces.push_back(f);
      const Eigen::RowVector3d p0 = S->V.row(S->F(f, 0)), p1 = S->V.row(S->F(f, 1)),
                               p2 = S->V.row(S->F(f, 2));
      const double a = 0.5 * (p1 - p0).cross(p2 - p0).norm();
      c += a * (p0 + p1 + p2) / 3.0;
      w += a;
      for (int j = 0; j < 3; ++j) dsum += dist(S->F(f, j)), ++dcount;
    }
    ev.centroid = w > 0 ? Eigen::RowVector3d(c / w) : c;
    ev.mismatch_at_faces = dcount ? dsum / dcount : 0;
    ev.mismatch_mean = dist.size() ? dist.mean() : 0;
  }
  // After outer iteration k (1-based): counts into it, first events, guard snapshot.
  void after_iteration(const Side& s, int k, bool keep, FoldCounts& map_c, FoldCounts& shell_c,
                       ElasticCollapseEvent& map_ev, ElasticCollapseEvent& shell_ev) {
    map_c = map_folds(s.P, &faces);
    if (map_ev.iteration == 0 && map_c.bad() > map0.bad()) record(map_ev, k, faces, map0_faces, s);
    if (keep && map_c.bad() <= map0.bad()) {
      keep_iteration = k;
      keep_P = s.P;
      keep_Y = s.Y;
    }
    shell_c = shell_folds(s.Y, s.P, &faces);
    if (shell_ev.iteration == 0 && shell_c.bad() > shell0.bad()) record(shell_ev, k, faces, shell0_faces, s);
  }
};

}  // namespace

namespace {

// Bookkeeping run on a second thread while this one carries on (issue 20 speed): the fold
// counts of one side (DirectionLog::after_iteration, about 7% of a 10k-vertex run when they
// ran in turn) overlap the other side's Y step, which is serial. The job only reads its side,
// which that Y step does not write. In turn (no thread) when OpenMP has one thread, so that
// --threads 1 keeps to one core.
class OverlappedJob {
 public:
  void start(std::function<void()> job) {
    if (omp_get_max_threads() < 2) {
      job();
      return;
    }
    auto run = [this, job] {
      omp_set_num_threads(1);  // its loops in this thread: no second OpenMP team
      try {
        job();
      } catch (...) {
        error_ = std::current_exception();
      }
    };
    try {
      thread_ = std::thread(run);
    } catch (const std::system_error&) {  // no thread to be had: in turn
      job();
    }
  }
  void wait() {
    if (thread_.joinable()) thread_.join();
    if (error_) std::rethrow_exception(std::exchange(error_, nullptr));
  }
  ~OverlappedJob() { join(); }
  void join() {
    if (thread_.joinable()) thread_.join();
  }

 private:
  std::thread thread_;
  std::exception_ptr error_;
};

// One outer iteration of Algorithm 1: P step, Y step and (bijective) Q step, Y~ step, with
// the energy terms at its end and the time of each kind of step. log_b_previous (may be
// empty) runs during the Y step, log_a during the Y~ step (after the Y step when injective).
ElasticIterate alternate_once(Side& a, Side& b, double beta, double gamma, bool bij, const ElasticOptions& opt,
                              double f_tol, bool safe, OverlappedJob& job, std::function<void()> log_b_previous,
                              const std::function<void(ElasticIterate&)>& log_a) {
  ElasticIterate it;
  struct JoinOnExit {  // a job never outlives what it reads, also when a step throws
    OverlappedJob& j;
    ~JoinOnExit() { j.join(); }
  } join_on_exit{job};
  it.beta = beta;
  EnergyParts pa, pb;
  auto t0 = Clock::now();
  projection_step(a, b, beta, gamma, bij, safe);  // P step
  it.time_projection += seconds_since(t0);
  if (log_b_previous) job.start(std::move(log_b_previous));
  t0 = Clock::now();
  it.inner_iterations += deformation_step(a, b, beta, gamma, bij, opt, f_tol, pa, it.inner_evaluations);  // Y step
  it.time_deformation += seconds_since(t0);
  job.wait();
  if (!bij) log_a(it);
  if (bij) {
    t0 = Clock::now();
    projection_step(b, a, beta, gamma, bij, safe);  // Q step
    it.time_projection += seconds_since(t0);
    job.start([&] { log_a(it); });
    t0 = Clock::now();
    it.inner_iterations += deformation_step(b, a, beta, gamma, bij, opt, f_tol, pb, it.inner_evaluations);  // Y~ step
    it.time_deformation += seconds_since(t0);
    job.wait();
    it.deformation = pa.deformation + pb.deformation;
    it.mismatch = pa.mismatch + pb.mismatch;
    // Q changed after side a's step: recompute gamma |Q Y - X~| with the final Q.
    {
      RowMat3 QY;
      apply_map(b.P, a.F, Eigen::MatrixXd(a.Y), QY);
      double r = 0;
      for (int j = 0; j < QY.rows(); ++j) r += b.mass(j) * (QY.row(j) - b.X.row(j)).squaredNorm();
      it.reversibility = gamma * r + pb.reversibility;
    }
  } else {
    it.deformation = pa.deformation;
    it.mismatch = pa.mismatch;
  }
  it.energy = it.deformation + it.mismatch + it.reversibility;
  return it;
}

// Collapse guard: per direction the last iterate, or the latest one with no more flipped or
// collapsed triangles than the start, or the start (ElasticOptions::keep_no_worse).
void collapse_guard(const DirectionLog& L, const Side& s, const BarycentricMap& init, const TriMesh& T,
                    const Normalization& nt, bool keep_no_worse, int outer_iterations, ElasticGuard& g,
                    BarycentricMap& P_out, Eigen::MatrixXd& Y_out, BarycentricMap& last_out) {
  g.initial_bad = L.map0.bad();
  g.last_bad = L.map_folds(s.P, nullptr).bad();
  g.iteration = outer_iterations;
  g.returned = ElasticReturned::Last;
  g.returned_bad = g.last_bad;
  P_out = s.P;
  Y_out = nt.undo(Eigen::MatrixXd(s.Y));
  if (!keep_no_worse || g.last_bad <= g.initial_bad) return;
  last_out = s.P;
  if (L.keep_iteration > 0) {
    g.returned = ElasticReturned::EarlierIterate;
    g.iteration = L.keep_iteration;
    P_out = L.keep_P;
    Y_out = nt.undo(L.keep_Y);
    g.returned_bad = L.map_folds(P_out, nullptr).bad();
  } else {
    g.returned = ElasticReturned::Initial;
    g.iteration = 0;
    P_out = init;
    Y_out = map_positions(init, T.V, T.F);
    g.returned_bad = g.initial_bad;
  }
}

// The fold logs of both directions (issue 20: fold counts per outer iteration, first
// collapses, the collapse guard), on unit-area copies so that the counts are the ones
// report.json shows.
void setup_direction_logs(const TriMesh& A, const TriMesh& B, const BarycentricMap& init_AB,
                          const BarycentricMap& init_BA, const Side& a, const Side& b, bool bij,
                          bool normalize_area, DirectionLog& logA, DirectionLog& logB) {
  const Normalization ua = unit_area_normalization(A), ub = unit_area_normalization(B);
  const Eigen::MatrixXd XA = ua.apply(A.V), XB = ub.apply(B.V);
  const Eigen::MatrixXd NA = face_normals(XA, A.F), NB = face_normals(XB, B.F);
  auto setup = [&](DirectionLog& L, const TriMesh& S, const Eigen::MatrixXd& Xs,
                   const Eigen::MatrixXd& Xt, const Eigen::MatrixXi& Ft, const Eigen::MatrixXd& Nt,
                   const Normalization& ut, const BarycentricMap& init, const Side& side) {
    L.S = &S;
    L.Xs = Xs;
    L.Xt = Xt;
    L.Ft = Ft;
    L.target_faces = vertex_elements_csr(Ft, int(Xt.rows()));
    L.Nt = Nt;
    L.to_unit_target = ut;
    L.working_is_unit = normalize_area;
    L.map0 = L.map_folds(init, &L.map0_faces);  // the user's map, as the CLI reports it
    L.shell0 = L.shell_folds(side.Y, side.P, &L.shell0_faces);
  };
  setup(logA, A, XA, XB, B.F, NB, ub, init_AB, a);
  if (bij) setup(logB, B, XB, XA, A.F, NA, ua, init_BA, b);
}

}  // namespace

namespace {
// The inputs of elastic_correspondence: non-empty finite meshes, maps that fit them.
void check_elastic_inputs(const TriMesh& A, const TriMesh& B, const BarycentricMap& init_AB,
                          const BarycentricMap& init_BA, const ElasticOptions& opt, bool bij) {
  if (A.V.rows() < 3 || A.F.rows() < 1) throw InputError("A: empty mesh");
  if (B.V.rows() < 3 || B.F.rows() < 1) throw InputError("B: empty mesh");
  if (!A.V.allFinite()) throw InputError("A: non-finite vertex coordinates");
  if (!B.V.allFinite()) throw InputError("B: non-finite vertex coordinates");
  validate_map(init_AB, A.num_vertices(), B.num_faces(), 3, "initial map A->B");
  if (bij) validate_map(init_BA, B.num_vertices(), A.num_faces(), 3, "initial map B->A");
  if (opt.max_outer_iterations < 0 || opt.inner_max_iterations < 0)
    throw InputError("elastic: negative iteration count");
}

// Algorithm 1's start: P, Q from the initial maps, Y <- P X~, Y~ <- Q X.
void start_from_maps(Side& a, Side& b, const BarycentricMap& init_AB, const BarycentricMap& init_BA, bool bij) {
  a.P = init_AB;
  sanitize(a.P);
  apply_map(a.P, b.F, b.X, a.PXt);
  a.Y = a.PXt;
  if (bij) {
    b.P = init_BA;
    sanitize(b.P);
    apply_map(b.P, a.F, a.X, b.PXt);
    b.Y = b.PXt;
  } else {
    b.Y = b.X;  // unused
  }
}
}  // namespace

ElasticResult elastic_correspondence(const TriMesh& A, const TriMesh& B,
                                     const BarycentricMap& init_AB,
                                     const BarycentricMap& init_BA, const ElasticOptions& opt) {
  const auto t_start = Clock::now();
  const bool bij = opt.model == ElasticModel::Bijective;
  check_elastic_inputs(A, B, init_AB, init_BA, opt, bij);

  // Sec. 5.2 global scale (or Sec. 6.2 partial matching: no scaling, rescaled weights).
  Normalization na, nb;
  double alphaA = opt.alpha, alphaB = opt.alpha, wscale = 1.0;
  if (opt.normalize_area) {
    na = unit_area_normalization(A);
    nb = unit_area_normalization(B);
  } else {
    const double s = total_area(A.V, A.F), st = total_area(B.V, B.F);
    if (!(s > 0) || !(st > 0)) throw InputError("elastic: zero-area mesh");
    alphaA = opt.alpha / s;
    alphaB = opt.alpha / st;
    wscale = 1.0 / (s * st);
  }
  Side a, b;
  a.X = na.apply(A.V);
  a.F = A.F;
  b.X = nb.apply(B.V);
  b.F = B.F;
  a.mass = lumped_mass(a.X, a.F);  // M_ii = incident face areas / 3 (Eq. 3)
  b.mass = lumped_mass(b.X, b.F);
  ShellEnergyOptions so = shell_energy_options(opt);
  so.alpha = alphaA;
  a.shell = ShellEnergy(a.X, a.F, so);
  so.alpha = alphaB;
  if (bij) b.shell = ShellEnergy(b.X, b.F, so);
  if (!opt.anchors.A.empty()) {
    set_anchors(a, b, opt.anchors.A, opt.anchors.B, opt.anchors.weight, opt.anchors.activation);
    if (bij) set_anchors(b, a, opt.anchors.B, opt.anchors.A, opt.anchors.weight, opt.anchors.activation);
  }
  start_from_maps(a, b, init_AB, init_BA, bij);

  ElasticResult res;
  res.degenerate_faces_initial =
      count_degenerate(a, opt.degenerate_tol) + (bij ? count_degenerate(b, opt.degenerate_tol) : 0);
  unstick_collapsed(a);
  if (bij) unstick_collapsed(b);

  // Issue 20: fold counts per outer iteration, first collapses, and the collapse guard. The
  // counts are taken on unit-area copies so that they are the ones report.json shows.
  DirectionLog logA, logB;
  setup_direction_logs(A, B, init_AB, init_BA, a, b, bij, opt.normalize_area, logA, logB);
  res.time_setup = seconds_since(t_start);
  res.initial_fold_fraction = double(logA.map0.bad()) / double(std::max<Eigen::Index>(1, A.F.rows()));
  if (bij)
    res.initial_fold_fraction = std::max(res.initial_fold_fraction,
                                         double(logB.map0.bad()) / double(std::max<Eigen::Index>(1, B.F.rows())));
  res.tight_start = opt.inner_f_tol_start > 0 && opt.inner_f_tol_start_iterations > 0 &&
                    res.initial_fold_fraction >= opt.inner_f_tol_start_min_folds;

  const double gamma_full = opt.gamma * wscale;
  double E_prev = 0;
  const int K = opt.max_outer_iterations;
  OverlappedJob job;
  std::function<void()> log_b_pending;
  for (int k = 0; k < K; ++k) {
    const int ramp = std::max(1, opt.beta_ramp_iterations);
    const double frac = std::min(1.0, double(k) / double(ramp));
    const double beta = (opt.beta_start + (opt.beta_end - opt.beta_start) * frac) * wscale;
    const double gamma = opt.gamma_ramp ? gamma_full * frac : gamma_full;
    const double f_tol = k < opt.inner_f_tol_start_iterations && res.tight_start ? opt.inner_f_tol_start
                         : k < opt.beta_ramp_iterations && opt.inner_f_tol_ramp > 0 ? opt.inner_f_tol_ramp
                                                                                     : opt.inner_f_tol;
    if (k == opt.beta_ramp_iterations && opt.anchors.release_after_ramp) release_anchors(a, b, res);
    const bool safe = opt.safe_projection && (opt.safe_projection_in_ramp || k >= opt.beta_ramp_iterations);
    ElasticIterate it = alternate_once(a, b, beta, gamma, bij, opt, f_tol, safe, job, std::move(log_b_pending),
                                       [&](ElasticIterate& i) {
                                         logA.after_iteration(a, k + 1, opt.keep_no_worse, i.P_folds, i.Y_folds,
                                                              res.first_P_collapse, res.first_Y_collapse);
                                       });
    log_b_pending = nullptr;
    if (bij)  // side b's counts of this iteration: during the next Y step, or after the loop
      log_b_pending = [&, k] {
        ElasticIterate& i = res.history[size_t(k)];
        logB.after_iteration(b, k + 1, opt.keep_no_worse, i.Q_folds, i.Yt_folds, res.first_Q_collapse,
                             res.first_Yt_collapse);
      };
    res.time_projection += it.time_projection;
    res.time_deformation += it.time_deformation;
    res.history.push_back(it);
    res.outer_iterations = k + 1;
    report(opt.progress, "elastic", double(k + 1) / K);
    if (k > 0 && k >= opt.beta_ramp_iterations && opt.energy_tol > 0 &&
        std::abs(it.energy - E_prev) < opt.energy_tol * std::abs(it.energy)) {
      res.converged = true;
      break;
    }
    E_prev = it.energy;
  }
  if (log_b_pending) log_b_pending();
  if (K == 0) {  // no iterations: the initial maps, projected once
    projection_step(a, b, opt.beta_start * wscale, opt.gamma_ramp ? 0.0 : gamma_full, bij, opt.safe_projection);
    if (bij) projection_step(b, a, opt.beta_start * wscale, opt.gamma_ramp ? 0.0 : gamma_full, bij, opt.safe_projection);
  }
  res.degenerate_faces_final =
      count_degenerate(a, opt.degenerate_tol) + (bij ? count_degenerate(b, opt.degenerate_tol) : 0);
  res.projection_rows_kept = a.rows_kept + b.rows_kept;
  res.sliver_mask_steps = a.sliver_mask_steps + b.sliver_mask_steps;
  if (!res.anchors_released) {
    for (char on : a.anchor_on) res.anchors_holding_AB += on;
    for (char on : b.anchor_on) res.anchors_holding_BA += on;
  }
  collapse_guard(logA, a, init_AB, B, nb, opt.keep_no_worse, res.outer_iterations, res.guard_AB, res.map_AB, res.Y,
                 res.last_AB);
  if (bij)
    collapse_guard(logB, b, init_BA, A, na, opt.keep_no_worse, res.outer_iterations, res.guard_BA, res.map_BA,
                   res.Ytilde, res.last_BA);
  res.time_total = seconds_since(t_start);
  return res;
}

ShellEnergyOptions shell_energy_options(const ElasticOptions& opt) {
  ShellEnergyOptions so;
  so.alpha = opt.alpha;
  so.eta = opt.eta;
  so.lambda = opt.lambda;
  so.mu = opt.mu;
  so.log_eps = opt.log_eps;
  so.degenerate_tol = opt.degenerate_tol;
  so.mask_tol = opt.mask_tol;
  return so;
}

BendingWeightChoice bending_weight_for_initial_maps(const TriMesh& A, const TriMesh& B,
                                                    const BarycentricMap& P,
                                                    const BarycentricMap& Q,
                                                    double eta_clean) {
  BendingWeightChoice c;
  const SurfaceDistortion dp = surface_distortion(A, B, P);
  c.flipped = dp.flipped;
  c.degenerate = dp.degenerate;
  if (Q.size() > 0) {
    const SurfaceDistortion dq = surface_distortion(B, A, Q);
    c.flipped += dq.flipped;
    c.degenerate += dq.degenerate;
  }
  c.eta = c.flipped + c.degenerate > 0 ? ElasticOptions::degenerate_init().eta : eta_clean;
  return c;
}

double elastic_energy(const Eigen::MatrixXd& X, const Eigen::MatrixXi& F,
                      const Eigen::MatrixXd& Xt, const Eigen::MatrixXi& Ft,
                      const BarycentricMap& P, const BarycentricMap& Q,
                      const Eigen::MatrixXd& Y, const Eigen::MatrixXd& Yt, double beta,
                      double gamma, const ShellEnergyOptions& shell, Eigen::MatrixXd* gY,
                      Eigen::MatrixXd* gYt, ElasticEnergyTerms* terms, const ElasticAnchors* anchors) {
  const bool bij = Q.size() > 0;
  validate_map(P, int(X.rows()), int(Ft.rows()), 3, "elastic_energy: P");
  if (bij) validate_map(Q, int(Xt.rows()), int(F.rows()), 3, "elastic_energy: Q");
  if (Y.rows() != X.rows() || Y.cols() != 3) throw InputError("elastic_energy: Y must be n×3");
  if (bij && (Yt.rows() != Xt.rows() || Yt.cols() != 3))
    throw InputError("elastic_energy: Y~ must be n~×3");
  Side a, b;
  a.X = X;
  a.F = F;
  a.mass = lumped_mass(X, F);
  a.shell = ShellEnergy(X, F, shell);
  a.P = P;
  a.Y = Y;
  b.X = Xt;
  b.F = Ft;
  b.mass = lumped_mass(Xt, Ft);
  apply_map(a.P, b.F, b.X, a.PXt);
  if (anchors && !anchors->A.empty()) {
    set_anchors(a, b, anchors->A, anchors->B, anchors->weight, 0.0);  // all holding
    if (bij) set_anchors(b, a, anchors->B, anchors->A, anchors->weight, 0.0);
  }
  if (bij) {
    b.shell = ShellEnergy(Xt, Ft, shell);
    b.P = Q;
    b.Y = Yt;
    apply_map(b.P, a.F, a.X, b.PXt);
  }
  EnergyParts pa, pb;
  Eigen::VectorXd x = Eigen::Map<const Eigen::VectorXd>(a.Y.data(), a.Y.size()), g(x.size());
  if (bij) pack_reversibility_rows(a, b);
  DeformationObjective oa(a, b, beta, gamma, bij);
  double E = oa(x, g);
  pa = oa.last;
  if (gY) *gY = Eigen::Map<const RowMat3>(g.data(), a.Y.rows(), 3);
  if (bij) {
    Eigen::VectorXd xt = Eigen::Map<const Eigen::VectorXd>(b.Y.data(), b.Y.size()), gt(xt.size());
    pack_reversibility_rows(b, a);
    DeformationObjective ob(b, a, beta, gamma, bij);
    E += ob(xt, gt);
    pb = ob.last;
    if (gYt) *gYt = Eigen::Map<const RowMat3>(gt.data(), b.Y.rows(), 3);
  }
  if (terms) {
    terms->total = E;
    terms->deformation = pa.deformation + pb.deformation;
    terms->mismatch = pa.mismatch + pb.mismatch;
    terms->reversibility = pa.reversibility + pb.reversibility;
  }
  return E;
}

}  // namespace shapemap
