// Thin-shell energy of elastic correspondence (Eq. 2, 7, 9). See shell_energy.h.
#include "shapemap/surface/shell_energy.h"
#include "shapemap/error.h"

#include <Eigen/Dense>
#include <algorithm>
#include <array>
#include <cmath>
#include <limits>
#include <tuple>
#include <vector>

namespace shapemap {

namespace {
using V3 = Eigen::Vector3d;


inline V3 row3(const double* y, int i) { return V3(y[3 * i], y[3 * i + 1], y[3 * i + 2]); }
}  // namespace

double membrane_density(double t, double d, double lambda, double mu, double eps, double* dW_dt,
                        double* dW_dd) {
  const double c = mu / 2 + lambda / 4;
  double mlog, dmlog;  // -log d with its C^1 linear extension below eps (Sec. 4.1)
  if (d >= eps) {
    mlog = -std::log(d);
    dmlog = -1.0 / d;
  } else {
    mlog = -std::log(eps) - (d - eps) / eps;
    dmlog = -1.0 / eps;
  }
  if (dW_dt) *dW_dt = mu / 2;
  if (dW_dd) *dW_dd = lambda / 4 + c * dmlog;
  return mu / 2 * t + lambda / 4 * d + c * mlog - mu - lambda / 4;
}

namespace {

// Eq. 7's reference metric per face t of X: g^-1 (its three entries), the area a^_t,
// det g^_t and |n^_t|. A degenerate reference triangle carries no membrane term (a^ = 0)
// and no bending: zeros. Returns the unit reference normals (m×3, zero where degenerate).
Eigen::MatrixXd reference_metric(const Eigen::MatrixXd& X, const Eigen::MatrixXi& F, Eigen::MatrixXd& ginv,
                                 Eigen::VectorXd& area, Eigen::VectorXd& detg, Eigen::VectorXd& nref) {
  const int m = int(F.rows());
  ginv.setZero(m, 3);
  area.setZero(m);
  detg.setZero(m);
  nref.setZero(m);
  Eigen::MatrixXd nunit = Eigen::MatrixXd::Zero(m, 3);
  for (int f = 0; f < m; ++f) {
    const V3 x0 = X.row(F(f, 0)), x1 = X.row(F(f, 1)), x2 = X.row(F(f, 2));
    const V3 e1 = x1 - x0, e2 = x2 - x0;
    const V3 N = e1.cross(e2);
    const double g00 = e1.dot(e1), g01 = e1.dot(e2), g11 = e2.dot(e2);
    const double det = N.squaredNorm();  // = g00 g11 - g01^2, computed stably
    nref(f) = std::sqrt(det);
    area(f) = 0.5 * nref(f);
    detg(f) = det;
    if (det > 1e-300 && det > 1e-24 * (g00 * g11)) {
      ginv(f, 0) = g11 / det;
      ginv(f, 1) = -g01 / det;
      ginv(f, 2) = g00 / det;
      nunit.row(f) = (N / nref(f)).transpose();
    } else {
      area(f) = 0;
      detg(f) = 0;
      nref(f) = 0;
    }
  }
  return nunit;
}

// Eq. 9's hinges of the reference: the interior edges (exactly two non-degenerate faces)
// with their faces and end points (E, k×4), cos th^_e and the weight l^_e^2 / d^_e, and per
// face slot (edge opposite corner j) the edge index (or -1) and the face's side of it.
struct ReferenceHinges {
  Eigen::MatrixXi E, face_edge, face_side;
  Eigen::VectorXd cos_ref, weight;
};
ReferenceHinges reference_hinges(const Eigen::MatrixXd& X, const Eigen::MatrixXi& F, const Eigen::VectorXd& area,
                                 const Eigen::VectorXd& nref, const Eigen::MatrixXd& nunit) {
  const int m = int(F.rows());
  // Half-edges (a<b, face, corner) sorted; exactly two faces -> interior edge.
  std::vector<std::tuple<int, int, int, int>> he;
  he.reserve(3 * m);
  for (int f = 0; f < m; ++f)
    for (int j = 0; j < 3; ++j) {
      int a = F(f, (j + 1) % 3), b = F(f, (j + 2) % 3);
      if (a > b) std::swap(a, b);
      he.emplace_back(a, b, f, j);
    }
  std::sort(he.begin(), he.end());
  ReferenceHinges h;
  h.face_edge.setConstant(m, 3, -1);
  h.face_side.setZero(m, 3);
  std::vector<std::array<int, 4>> edges;
  std::vector<double> cosr, w;
  for (size_t i = 0; i < he.size();) {
    size_t j = i;
    while (j < he.size() && std::get<0>(he[j]) == std::get<0>(he[i]) &&
           std::get<1>(he[j]) == std::get<1>(he[i]))
      ++j;
    if (j - i == 2) {
      const int f0 = std::get<2>(he[i]), c0 = std::get<3>(he[i]);
      const int f1 = std::get<2>(he[i + 1]), c1 = std::get<3>(he[i + 1]);
      const int a = std::get<0>(he[i]), b = std::get<1>(he[i]);
      if (nref(f0) > 0 && nref(f1) > 0 && f0 != f1) {
        const int e = int(edges.size());
        edges.push_back({f0, f1, a, b});
        const double l2 = (X.row(a) - X.row(b)).squaredNorm();
        const double d = (area(f0) + area(f1)) / 3.0;
        cosr.push_back(nunit.row(f0).dot(nunit.row(f1)));
        w.push_back(l2 / d);
        h.face_edge(f0, c0) = e;
        h.face_side(f0, c0) = 0;
        h.face_edge(f1, c1) = e;
        h.face_side(f1, c1) = 1;
      }
    }
    i = j;
  }
  const int k = int(edges.size());
  h.E.resize(k, 4);
  h.cos_ref.resize(k);
  h.weight.resize(k);
  for (int e = 0; e < k; ++e) {
    for (int c = 0; c < 4; ++c) h.E(e, c) = edges[e][c];
    h.cos_ref(e) = cosr[e];
    h.weight(e) = w[e];
  }
  return h;
}

// vertex -> (face, corner), CSR over n vertices in increasing face order (a fixed gather
// order, so that the gradient does not depend on threads).
void vertex_face_corners(const Eigen::MatrixXi& F, int n, std::vector<int>& start, std::vector<int>& face,
                         std::vector<int>& corner) {
  const int m = int(F.rows());
  start.assign(n + 1, 0);
  for (int f = 0; f < m; ++f)
    for (int j = 0; j < 3; ++j) start[F(f, j) + 1]++;
  for (int i = 0; i < n; ++i) start[i + 1] += start[i];
  face.resize(3 * m);
  corner.resize(3 * m);
  std::vector<int> fill(start.begin(), start.end() - 1);
  for (int f = 0; f < m; ++f)
    for (int j = 0; j < 3; ++j) {
      const int p = fill[F(f, j)]++;
      face[p] = f;
      corner[p] = j;
    }
}

}  // namespace

ShellEnergy::ShellEnergy(const Eigen::MatrixXd& X, const Eigen::MatrixXi& F,
                         const ShellEnergyOptions& opt)
    : opt_(opt), n_(int(X.rows())), F_(F) {
  if (X.cols() != 3 || F.cols() != 3) throw InputError("shell energy: X must be n×3 and F m×3");
  const int m = int(F.rows());
  if (m > 0 && (F.minCoeff() < 0 || F.maxCoeff() >= n_))
    throw InputError("shell energy: face index out of range");
  const Eigen::MatrixXd nunit = reference_metric(X, F, ginv_, area_, detg_, nref_);
  ReferenceHinges h = reference_hinges(X, F, area_, nref_, nunit);
  E_ = std::move(h.E);
  cos_ref_ = std::move(h.cos_ref);
  weight_ = std::move(h.weight);
  face_edge_ = std::move(h.face_edge);
  face_side_ = std::move(h.face_side);
  vertex_face_corners(F, n_, vf_start_, vf_face_, vf_corner_);
  fdeg_.resize(m);
  fNlen_.resize(m);
  fn_.resize(3 * size_t(m));
  fmem_.resize(6 * size_t(m));
  fenergy_.resize(m);
  fbend_.resize(m);
  fadm_.resize(m);
  // packed per-face edge slots for the evaluation loop
  slots_.assign(3 * size_t(m), Slot{});
  for (int f = 0; f < m; ++f)
    for (int j = 0; j < 3; ++j) {
      const int e = face_edge_(f, j);
      if (e < 0) continue;
      Slot& q = slots_[3 * size_t(f) + j];
      q.e = e;
      q.side = face_side_(f, j);
      q.h = E_(e, 1 - q.side);
      q.cosr = cos_ref_(e);
      q.w = weight_(e);
    }
}

// Pass 1, per face f: normal N_f (unit normal and length stored), degeneracy, membrane
// energy and gradient (Eq. 7) w.r.t. the edge vectors e1 = x1 - x0, e2 = x2 - x0.
void ShellEnergy::membrane_face(int f, const double* y, bool want_grad) const {
  const double alpha = opt_.alpha, lam = opt_.lambda, mu = opt_.mu, eps = opt_.log_eps, tol = opt_.degenerate_tol;
  const V3 x0 = row3(y, F_(f, 0)), x1 = row3(y, F_(f, 1)), x2 = row3(y, F_(f, 2));
  const V3 e1 = x1 - x0, e2 = x2 - x0;
  const V3 N = e1.cross(e2);
  const double Nlen = N.norm();
  fdeg_[f] = !(Nlen > tol * nref_(f)) || nref_(f) == 0;
  fNlen_[f] = Nlen;
  const V3 n = Nlen > 0 ? V3(N / Nlen) : V3::Zero();
  double* nf = fn_.data() + 3 * size_t(f);
  nf[0] = n(0), nf[1] = n(1), nf[2] = n(2);
  double* gm = fmem_.data() + 6 * size_t(f);
  const double a = area_(f);
  if (a == 0) {
    fenergy_(f) = 0;
    if (want_grad) std::fill(gm, gm + 6, 0.0);
    return;
  }
  const double h00 = ginv_(f, 0), h01 = ginv_(f, 1), h11 = ginv_(f, 2);
  const double g00 = e1.dot(e1), g01 = e1.dot(e2), g11 = e2.dot(e2);
  const double t = h00 * g00 + 2 * h01 * g01 + h11 * g11;  // tr(g^-1 g)
  const double d = N.squaredNorm() / detg_(f);              // det(g^-1 g)
  double Wt, Wd;
  fenergy_(f) = a * membrane_density(t, d, lam, mu, eps, &Wt, &Wd);
  if (want_grad) {
    // d t/d e1 = 2(h00 e1 + h01 e2), d t/d e2 = 2(h01 e1 + h11 e2)
    // d d/d e1 = 2 (e2 x N)/det g^, d d/d e2 = 2 (N x e1)/det g^
    const double s = 2 * a * alpha, sd = Wd / detg_(f);
    const V3 g1 = s * (Wt * (h00 * e1 + h01 * e2) + sd * e2.cross(N));
    const V3 g2 = s * (Wt * (h01 * e1 + h11 * e2) + sd * N.cross(e1));
    gm[0] = g1(0), gm[1] = g1(1), gm[2] = g1(2);
    gm[3] = g2(0), gm[4] = g2(1), gm[5] = g2(2);
  }
}

// Pass 2, per face f: the bending terms (Eq. 9) of its interior edges from the stored
// normals; the edge's energy and admissibility are written by its side-0 face only,
// dE/dN_f is pushed to f's corners together with the membrane gradient.
// out: the 9 corner gradients (corner-major).
void ShellEnergy::bending_face(int f, const double* y, bool want_grad, bool do_bend, double* out) const {
  const double eta = opt_.eta;
  const bool frozen = frozen_;
  const double inf = std::numeric_limits<double>::infinity();
  const double* gm = fmem_.data() + 6 * size_t(f);
  V3 g1(gm[0], gm[1], gm[2]), g2(gm[3], gm[4], gm[5]);
  V3 g0 = -g1 - g2;
  if (do_bend) {
    const bool degf = fdeg_[f];
    const double Nlen = fNlen_[f];
    const V3 nf(fn_[3 * size_t(f)], fn_[3 * size_t(f) + 1], fn_[3 * size_t(f) + 2]);
    V3 G = V3::Zero();  // eta dW_bnd/dN_f
    bool any = false;
    double ebend = 0;  // bending energy of the edges whose side-0 face is f
    int nadm = 0;
    const Slot* sl = slots_.data() + 3 * size_t(f);
    for (int j = 0; j < 3; ++j) {
      const Slot& q = sl[j];
      if (q.e < 0) continue;
      const int h = q.h;  // the neighbour across edge q.e
      const bool adm = frozen ? frozen_adm_[q.e] != 0 : !(degf || fdeg_[h]);
      if (!adm) continue;
      if (q.side == 0) ++nadm;
      if (!(Nlen > 0) || !(fNlen_[h] > 0)) {  // frozen-admissible but collapsed: reject
        if (q.side == 0) ebend = inf;
        continue;
      }
      const V3 nh(fn_[3 * size_t(h)], fn_[3 * size_t(h) + 1], fn_[3 * size_t(h) + 2]);
      const double c = q.side == 0 ? nf.dot(nh) : nh.dot(nf);
      const double delta = q.cosr - c;
      if (q.side == 0) ebend += q.w * delta * delta;
      if (want_grad) {
        const double dEdc = -2 * eta * q.w * delta;
        G += (dEdc / Nlen) * (nh - c * nf);
        any = true;
      }
    }
    fbend_[f] = ebend;
    fadm_[f] = char(nadm);
    if (any) {
      // N = e1 x e2: G.dN = de1.(e2 x G) + de2.(G x e1)
      const V3 x0 = row3(y, F_(f, 0));
      const V3 e1 = row3(y, F_(f, 1)) - x0, e2 = row3(y, F_(f, 2)) - x0;
      const V3 b1 = e2.cross(G), b2 = G.cross(e1);
      g0 -= b1 + b2;
      g1 += b1;
      g2 += b2;
    }
  }
  if (want_grad)
    for (int c = 0; c < 3; ++c) {
      out[c] = g0(c);
      out[3 + c] = g1(c);
      out[6 + c] = g2(c);
    }
}

double ShellEnergy::evaluate(const double* y, double* grad, ShellEnergyTerms* terms) const {
  const int m = int(F_.rows()), k = int(E_.rows());
  const double alpha = opt_.alpha, eta = opt_.eta;
  const bool want_grad = grad != nullptr;
  const bool do_bend = eta != 0.0 && k > 0;

  if (m < opt_.parallel_min_faces) {
    // Serial: corner gradients scattered in increasing face order, which adds the same
    // terms in the same order as the parallel gather below (bitwise identical results).
    for (int f = 0; f < m; ++f) membrane_face(f, y, want_grad);
    if (want_grad || do_bend) {
      if (want_grad) std::fill(grad, grad + 3 * size_t(n_), 0.0);
      double out[9];
      for (int f = 0; f < m; ++f) {
        bending_face(f, y, want_grad, do_bend, out);
        if (want_grad)
          for (int c = 0; c < 3; ++c) {
            double* gv = grad + 3 * size_t(F_(f, c));
            gv[0] += out[3 * c];
            gv[1] += out[3 * c + 1];
            gv[2] += out[3 * c + 2];
          }
      }
    }
  } else {
    // Parallel: one region, faces (two passes) then a per-vertex gather of the corner
    // gradients in increasing face order; each element writes only its own slots.
    if (want_grad && fgrad_.size() != 9 * size_t(m)) fgrad_.resize(9 * size_t(m));
#pragma omp parallel
    {
#pragma omp for schedule(static)
      for (int f = 0; f < m; ++f) membrane_face(f, y, want_grad);
      if (want_grad || do_bend) {
        double out[9];
#pragma omp for schedule(static)
        for (int f = 0; f < m; ++f) bending_face(f, y, want_grad, do_bend, want_grad ? fgrad_.data() + 9 * size_t(f) : out);
      }
      if (want_grad) {
#pragma omp for schedule(static)
        for (int i = 0; i < n_; ++i) {
          double gx = 0, gy = 0, gz = 0;
          for (int p = vf_start_[i]; p < vf_start_[i + 1]; ++p) {
            const double* fg = fgrad_.data() + 9 * size_t(vf_face_[p]) + 3 * vf_corner_[p];
            gx += fg[0];
            gy += fg[1];
            gz += fg[2];
          }
          grad[3 * i] = gx;
          grad[3 * i + 1] = gy;
          grad[3 * i + 2] = gz;
        }
      }
    }
  }

  // Serial sums (deterministic).
  double mem = 0, bnd = 0;
  int adm = 0, deg = 0;
  for (int f = 0; f < m; ++f) {
    mem += fenergy_(f);
    deg += fdeg_[f] ? 1 : 0;
  }
  if (do_bend)
    for (int f = 0; f < m; ++f) {
      bnd += fbend_[f];
      adm += fadm_[f];
    }
  const double total = alpha * mem + eta * bnd;
  if (terms) {
    terms->membrane = mem;
    terms->bending = bnd;
    terms->total = total;
    terms->admissible_edges = adm;
    terms->degenerate_faces = deg;
  }
  return total;
}

bool ShellEnergy::freeze_mask(const double* y, bool leave_out_slivers) {
  const int m = int(F_.rows()), k = int(E_.rows());
  frozen_ = false;
  const bool had = frozen_once_;
  std::vector<char>& deg = fdeg_;  // scratch (evaluate() rewrites it)
  const double tol = leave_out_slivers ? std::max(opt_.degenerate_tol, opt_.mask_tol) : opt_.degenerate_tol;
  for (int f = 0; f < m; ++f) {
    const V3 x0 = row3(y, F_(f, 0)), x1 = row3(y, F_(f, 1)), x2 = row3(y, F_(f, 2));
    const double Nlen = (x1 - x0).cross(x2 - x0).norm();
    deg[f] = !(Nlen > tol * nref_(f)) || nref_(f) == 0;
  }
  frozen_adm_.resize(k);
  bool changed = !had;
  for (int e = 0; e < k; ++e) {
    const char adm = !(deg[E_(e, 0)] || deg[E_(e, 1)]);
    changed = changed || adm != frozen_adm_[e];
    frozen_adm_[e] = adm;
  }
  frozen_ = true;
  frozen_once_ = true;
  return changed;
}

double ShellEnergy::evaluate(const Eigen::MatrixXd& Y, Eigen::MatrixXd* G,
                             ShellEnergyTerms* terms) const {
  if (Y.rows() != n_ || Y.cols() != 3) throw InputError("shell energy: Y must be n×3");
  Eigen::Matrix<double, Eigen::Dynamic, 3, Eigen::RowMajor> Yr = Y;
  if (!G) return evaluate(Yr.data(), nullptr, terms);
  Eigen::Matrix<double, Eigen::Dynamic, 3, Eigen::RowMajor> Gr(n_, 3);
  const double E = evaluate(Yr.data(), Gr.data(), terms);
  *G = Gr;
  return E;
}

}  // namespace shapemap
