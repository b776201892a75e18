// Untangling a surface map on its target: see untangle.h and docs/methods.md.
#include "shapemap/surface/untangle.h"

#include "shapemap/adjacency.h"
#include "shapemap/error.h"
#include "shapemap/geometry/closest_point.h"
#include <chrono>

#include <Eigen/Dense>
#include <algorithm>
#include <cmath>
#include <limits>
#include <memory>
#include <vector>

namespace shapemap {

double untangle_triangle_energy(const Eigen::Matrix3d& Y, const Eigen::Vector3d& n,
                                const Eigen::Matrix2d& Rinv, double rest_area, double delta,
                                Eigen::Matrix3d* dY) {
  // orthonormal tangent basis (b1, b2) of n; E does not depend on its rotation in the plane
  const Eigen::Vector3d a = std::abs(n(0)) < 0.9 ? Eigen::Vector3d::UnitX() : Eigen::Vector3d::UnitY();
  const Eigen::Vector3d b1 = n.cross(a).normalized();
  const Eigen::Vector3d b2 = n.cross(b1);
  Eigen::Matrix2d D;  // columns: the image edges y1 - y0, y2 - y0 in (b1, b2)
  for (int k = 0; k < 2; ++k) {
    const Eigen::Vector3d e = (Y.row(k + 1) - Y.row(0)).transpose();
    D(0, k) = b1.dot(e);
    D(1, k) = b2.dot(e);
  }
  const Eigen::Matrix2d J = D * Rinv;
  const double F = J.squaredNorm();
  const double s = J.determinant();
  const double r = std::sqrt(s * s + 4 * delta * delta);
  // h = (s + r) / 2, written without the cancellation of s + r when s < 0
  const double h = s >= 0 ? 0.5 * (s + r) : 2 * delta * delta / (r - s);
  const double E = rest_area * F * (1 + 1 / (h * h));
  if (dY) {
    const double dh = h / r;  // = (1 + s / r) / 2
    Eigen::Matrix2d cof;  // d det J / dJ
    cof << J(1, 1), -J(1, 0), -J(0, 1), J(0, 0);
    const Eigen::Matrix2d dJ = rest_area * ((1 + 1 / (h * h)) * 2 * J - F * 2 / (h * h * h) * dh * cof);
    const Eigen::Matrix2d dD = dJ * Rinv.transpose();
    for (int k = 0; k < 2; ++k) {
      const Eigen::Vector3d g = dD(0, k) * b1 + dD(1, k) * b2;
      dY->row(k + 1) = g.transpose();
    }
    dY->row(0) = -(dY->row(1) + dY->row(2));
  }
  return E;
}

double untangle_reversibility_energy(const Eigen::Vector3d& y, const Eigen::Matrix3d& C,
                                     const Eigen::Matrix3d& Qc, const Eigen::Vector3d& x, double w,
                                     Eigen::Vector3d* g) {
  // b_j(y) = (n x (c_{j+2} - c_{j+1})) . (y - c_{j+1}) / |n|^2, n = (c1 - c0) x (c2 - c0): the
  // barycentric coordinates of y's projection onto the face's plane (linear in y)
  const Eigen::Vector3d c[3] = {C.row(0).transpose(), C.row(1).transpose(), C.row(2).transpose()};
  const Eigen::Vector3d n = (c[1] - c[0]).cross(c[2] - c[0]);
  const double a2 = n.squaredNorm();
  if (g) g->setZero();
  if (!(a2 > 0)) return 0;
  Eigen::Vector3d q = Eigen::Vector3d::Zero(), db[3];
  for (int j = 0; j < 3; ++j) {
    db[j] = n.cross(c[(j + 2) % 3] - c[(j + 1) % 3]) / a2;
    q += db[j].dot(y - c[(j + 1) % 3]) * Qc.row(j).transpose();
  }
  const Eigen::Vector3d r = q - x;
  if (g)
    for (int j = 0; j < 3; ++j) *g += 2 * w * r.dot(Qc.row(j).transpose()) * db[j];
  return w * r.squaredNorm();
}

namespace {

constexpr unsigned char kSliver = 3;  // face flag beside fold_counts' 1 (flipped) and 2 (collapsed)

// Vertex -> incident faces (CSR).
struct Incidence : VertexElementsCsr {
  Incidence(const Eigen::MatrixXi& F, int n) : VertexElementsCsr(vertex_elements_csr(F, n)) {}
  int begin(int v) const { return start[v]; }
  int end(int v) const { return start[v + 1]; }
};

struct Untangler {
  const Eigen::MatrixXi &Fs, &Ft;
  Eigen::MatrixXd Xs, Xt, Nt;        // unit-area copies; target unit face normals
  Incidence inc_s, inc_t;
  std::vector<Eigen::Matrix2d> Rinv; // per source face
  Eigen::VectorXd rest_area;
  std::vector<double> edge_len;      // per source vertex: mean rest edge length around it
  BarycentricMap& P;
  Eigen::MatrixXd Y;                 // current images (unit-area target frame)
  Eigen::MatrixXd Y0;                // the images at the start (the tether's anchors)
  std::vector<unsigned char> held;   // per source vertex: its image stays (UntangleOptions::held)
  std::vector<double> tether_w;      // per source vertex: w m_v / l_v^2
  std::vector<double> base_w;        // per source vertex: m_v / l_v^2
  std::vector<std::vector<int>> near_faces;  // per target face, faces_near's cache
  Eigen::MatrixXd Ct;                // per target face: centroid and the radius of the sphere
  Eigen::VectorXd Rt;                //   about it through the farthest corner (project_near)

  Untangler(const TriMesh& S, const TriMesh& T, BarycentricMap& map, double tether_weight)
      : Fs(S.F), Ft(T.F), Xs(unit_area_normalization(S).apply(S.V)),
        Xt(unit_area_normalization(T).apply(T.V)), Nt(face_normals(Xt, T.F)),
        inc_s(S.F, int(S.V.rows())), inc_t(T.F, int(T.V.rows())), P(map), near_faces(T.F.rows()) {
    tether = tether_weight;
    const int m = int(Fs.rows()), n = int(Xs.rows());
    Rinv.resize(m);
    rest_area.resize(m);
    edge_len.assign(n, 0.0);
    std::vector<int> cnt(n, 0);
    for (int t = 0; t < m; ++t) {
      const Eigen::Vector3d x0 = Xs.row(Fs(t, 0)), e1 = Eigen::Vector3d(Xs.row(Fs(t, 1))) - x0,
                            e2 = Eigen::Vector3d(Xs.row(Fs(t, 2))) - x0;
      const double l1 = e1.norm(), a2 = e1.cross(e2).norm();
      rest_area(t) = 0.5 * a2;
      Eigen::Matrix2d R;
      R << l1, e1.dot(e2) / std::max(l1, 1e-300), 0, a2 / std::max(l1, 1e-300);
      Rinv[t] = a2 > 0 ? Eigen::Matrix2d(R.inverse()) : Eigen::Matrix2d::Zero();
      for (int j = 0; j < 3; ++j) {
        const int v = Fs(t, j);
        edge_len[v] += (Xs.row(Fs(t, (j + 1) % 3)) - Xs.row(v)).norm();
        ++cnt[v];
      }
    }
    for (int v = 0; v < n; ++v) edge_len[v] /= std::max(1, cnt[v]);
    Y = map_positions(P, Xt, Ft);
    Y0 = Y;
    Ct.resize(Ft.rows(), 3);
    Rt.resize(Ft.rows());
    for (int g = 0; g < Ft.rows(); ++g) {
      Ct.row(g) = (Xt.row(Ft(g, 0)) + Xt.row(Ft(g, 1)) + Xt.row(Ft(g, 2))) / 3.0;
      Rt(g) = 0;
      for (int j = 0; j < 3; ++j) Rt(g) = std::max(Rt(g), (Xt.row(Ft(g, j)) - Ct.row(g)).norm());
    }
    base_w.assign(n, 0.0);
    for (int t = 0; t < m; ++t)
      for (int j = 0; j < 3; ++j) base_w[Fs(t, j)] += rest_area(t) / 3;
    for (int v = 0; v < n; ++v) base_w[v] = edge_len[v] > 0 ? base_w[v] / (edge_len[v] * edge_len[v]) : 0.0;
    tether_w.resize(n);
    for (int v = 0; v < n; ++v) tether_w[v] = tether * base_w[v];
  }
  double tether = 0;
  // reversibility term (opt.reverse_weight, with the reverse map Q): Qpos = Q X (n~×3, the
  // images of the target's vertices on the source, unit-area frame), rev_w[v] = w m_v / l_v^2
  Eigen::MatrixXd Qpos;
  std::vector<double> rev_w;
  void set_reverse(const BarycentricMap& Q, double w) {
    Qpos = map_positions(Q, Xs, Fs);
    rev_w.assign(tether_w.size(), 0.0);
    for (size_t v = 0; v < rev_w.size(); ++v) rev_w[v] = w * base_w[v];
  }

  Eigen::Vector3d target_point(int f, const Eigen::Vector3d& b) const {
    return b(0) * Xt.row(Ft(f, 0)).transpose() + b(1) * Xt.row(Ft(f, 1)).transpose() +
           b(2) * Xt.row(Ft(f, 2)).transpose();
  }

  // The tangent plane a mapped source triangle is measured in: the sum of the target normals at
  // its corners' images.
  Eigen::Vector3d frame_normal(int t) const {
    Eigen::Vector3d n = Eigen::Vector3d::Zero();
    for (int j = 0; j < 3; ++j) n += Nt.row(P.elem(Fs(t, j))).transpose();
    const double l = n.norm();
    return l > 1e-8 ? Eigen::Vector3d(n / l) : Eigen::Vector3d(Nt.row(P.elem(Fs(t, 0))).transpose());
  }

  double face_energy(int t, double delta, Eigen::Matrix3d* dY) const {
    if (!(rest_area(t) > 0)) {
      if (dY) dY->setZero();
      return 0;
    }
    Eigen::Matrix3d Yt;
    for (int j = 0; j < 3; ++j) Yt.row(j) = Y.row(Fs(t, j));
    return untangle_triangle_energy(Yt, frame_normal(t), Rinv[t], rest_area(t), delta, dY);
  }

  // Sum of the energies of the faces around v; g (optional): d/dy_v.
  double vertex_energy(int v, double delta, Eigen::Vector3d* g) const {
    double E = 0;
    if (g) g->setZero();
    Eigen::Matrix3d dY;
    for (int q = inc_s.begin(v); q < inc_s.end(v); ++q) {
      const int t = inc_s.elems[q];
      E += face_energy(t, delta, g ? &dY : nullptr);
      if (g)
        for (int j = 0; j < 3; ++j)
          if (Fs(t, j) == v) *g += dY.row(j).transpose();
    }
    if (tether_w[v] > 0) {
      const Eigen::Vector3d d = (Y.row(v) - Y0.row(v)).transpose();
      E += tether_w[v] * d.squaredNorm();
      if (g) *g += 2 * tether_w[v] * d;
    }
    if (!rev_w.empty() && rev_w[v] > 0) {
      const int f = P.elem(v);
      Eigen::Matrix3d C, Qc;
      for (int j = 0; j < 3; ++j) {
        C.row(j) = Xt.row(Ft(f, j));
        Qc.row(j) = Qpos.row(Ft(f, j));
      }
      Eigen::Vector3d gr;
      E += untangle_reversibility_energy(Y.row(v).transpose(), C, Qc, Xs.row(v).transpose(), rev_w[v],
                                         g ? &gr : nullptr);
      if (g) *g += gr;
    }
    return E;
  }

  // The closest point to x on the target near face f: the closest among the faces within two
  // vertex rings of f, repeated from the face found until it stays (a walk; at most 8 steps).
  // Local, so that an image never jumps to another part of the target that passes close by
  // (a neighbouring leg).
  // The target faces within two vertex rings of f (sorted), gathered on f's first use: the
  // walk below asks for the same faces again and again (sorting them each time was 57% of
  // the untangling's time on cat -> lion).
  const std::vector<int>& faces_near(int f) {
    std::vector<int>& near = near_faces[f];
    if (!near.empty()) return near;
    for (int j = 0; j < 3; ++j)
      for (int q = inc_t.begin(Ft(f, j)); q < inc_t.end(Ft(f, j)); ++q) {
        const int g = inc_t.elems[q];
        for (int k = 0; k < 3; ++k)
          for (int r = inc_t.begin(Ft(g, k)); r < inc_t.end(Ft(g, k)); ++r) near.push_back(inc_t.elems[r]);
      }
    std::sort(near.begin(), near.end());
    near.erase(std::unique(near.begin(), near.end()), near.end());
    near.shrink_to_fit();
    return near;
  }

  ClosestPointResult project_near(int f, const Eigen::Vector3d& x) {
    ClosestPointResult best;
    for (int step = 0; step < 8; ++step) {
      best.sqdist = std::numeric_limits<double>::infinity();
      for (int g : faces_near(f)) {
        // skip faces whose bounding sphere is no closer than the best face so far
        const double out = (x - Ct.row(g).transpose()).norm() - Rt(g);
        if (out > 0 && out * out >= best.sqdist) continue;
        const Eigen::Vector3d c[3] = {Xt.row(Ft(g, 0)).transpose(), Xt.row(Ft(g, 1)).transpose(),
                                      Xt.row(Ft(g, 2)).transpose()};
        ClosestPointResult r = closest_point_on_simplex<3>(x, c, 3);
        if (r.sqdist < best.sqdist) {
          best = r;
          best.elem = g;
        }
      }
      if (best.elem == f) break;
      f = best.elem;
    }
    return best;
  }

  void set_image(int v, int f, const Eigen::Vector3d& b) {
    P.elem(v) = f;
    P.bary.row(v) = b.transpose();
    Y.row(v) = target_point(f, b).transpose();
  }

  // A bridge: v's image on a target face turned more than 90 degrees from its neighbours' side
  // of the target, i.e. on the far side of a thin part (a leg, an ear) from them. Two cases:
  // (a) the mean of the target normals at its neighbours' images is at least half a unit long
  // (they agree: not a rim with neighbours on both sides) and v's normal is turned from it;
  // (b) v is a corner of a flipped or collapsed triangle (`flags`, the faces' classes) whose
  // two other corners' normals are both turned from v's, its neighbours split between the
  // sides (camel-gallop 01 -> 05's face 4601: |mean| 0.45). x: the average image of the
  // neighbours on their side, side: that side's normal.
  bool is_bridge(int v, const std::vector<unsigned char>& flags, Eigen::Vector3d& x, Eigen::Vector3d& side) const {
    const Eigen::Vector3d nv = Nt.row(P.elem(v)).transpose();
    Eigen::Vector3d nbar = Eigen::Vector3d::Zero();
    int k = 0;
    for (int q = inc_s.begin(v); q < inc_s.end(v); ++q)
      for (int j = 0; j < 3; ++j)
        if (Fs(inc_s.elems[q], j) != v) {
          nbar += Nt.row(P.elem(Fs(inc_s.elems[q], j))).transpose();
          ++k;
        }
    if (k == 0) return false;
    nbar /= k;
    Eigen::Vector3d ref = Eigen::Vector3d::Zero();
    if (nbar.norm() >= 0.5 && nv.dot(nbar) < 0) ref = nbar;
    else
      for (int q = inc_s.begin(v); q < inc_s.end(v) && ref.isZero(); ++q) {
        const int t = inc_s.elems[q];
        if (flags[t] == 0 || flags[t] == kSliver) continue;
        Eigen::Vector3d others = Eigen::Vector3d::Zero();
        bool turned = true;
        for (int j = 0; j < 3; ++j)
          if (Fs(t, j) != v) {
            const Eigen::Vector3d n = Nt.row(P.elem(Fs(t, j))).transpose();
            turned = turned && nv.dot(n) < 0;
            others += n;
          }
        if (turned) ref = others;
      }
    if (ref.isZero()) return false;
    Eigen::Vector3d sum = Eigen::Vector3d::Zero();  // the neighbours on ref's side
    int m = 0;
    for (int q = inc_s.begin(v); q < inc_s.end(v); ++q)
      for (int j = 0; j < 3; ++j) {
        const int w = Fs(inc_s.elems[q], j);
        if (w != v && Nt.row(P.elem(w)).dot(ref) > 0) {
          sum += Y.row(w).transpose();
          ++m;
        }
      }
    if (m == 0) return false;
    x = sum / m;
    side = ref;
    return true;
  }

  // The whole target's closest points (reseat_bridge), built on first use.
  std::unique_ptr<ClosestPoint3> target_bvh;

  // A bridge re-seated at the closest point of the whole target to its neighbours' average
  // image on their side, when that point's face is turned their way; the tether's anchor moves
  // with it (the refined image it held is the defect). Returns whether v moved.
  bool reseat_bridge(int v, const std::vector<unsigned char>& flags) {
    Eigen::Vector3d x, side;
    if (held[v] || !is_bridge(v, flags, x, side)) return false;
    if (!target_bvh) target_bvh = std::make_unique<ClosestPoint3>(Xt, Ft);
    // the average lies below their side's surface, nearer the far side where the part is
    // thinner than the ring (camel-gallop 10 -> 04's vertex 4252): lifted off it along the
    // side's normal by up to two mean edge lengths until the closest point is on their side
    ClosestPointResult r;
    for (int lift = 0; lift < 3; ++lift) {
      r = target_bvh->query(Eigen::Vector3d(x + lift * edge_len[v] * side.normalized()));
      if (r.elem >= 0 && Nt.row(r.elem).dot(side) > 0) break;
    }
    if (r.elem < 0 || Nt.row(r.elem).dot(side) <= 0) return false;
    set_image(v, r.elem, r.bary.head<3>());
    Y0.row(v) = Y.row(v);
    return true;
  }

  // Move v's image to the average of its neighbours' images (projected near its face): a
  // Gauss-Seidel sweep of Tutte's embedding, which spreads images that coincide (collapsed
  // triangles, where every rotation-invariant energy of J is stationary).
  void average_vertex(int v) {
    if (held[v]) return;
    Eigen::Vector3d x = Eigen::Vector3d::Zero();
    int k = 0;
    for (int q = inc_s.begin(v); q < inc_s.end(v); ++q)
      for (int j = 0; j < 3; ++j)
        if (Fs(inc_s.elems[q], j) != v) {
          x += Y.row(Fs(inc_s.elems[q], j)).transpose();
          ++k;
        }
    if (k == 0) return;
    const ClosestPointResult r = project_near(P.elem(v), x / k);
    set_image(v, r.elem, r.bary.head<3>());
  }

  // One damped Newton step of v's image in the tangent plane of its face (2×2 Hessian by
  // differences of the gradient), projected back onto the target near the current face; kept
  // only if the energy around v falls. Returns whether the image moved.
  bool relax_vertex(int v, double delta) {
    if (held[v]) return false;
    const int f0 = P.elem(v);
    const Eigen::Vector3d b0 = P.bary.row(v).transpose();
    const Eigen::Vector3d p0 = Y.row(v).transpose();
    const Eigen::Vector3d nv = Nt.row(f0).transpose();
    const Eigen::Vector3d a = std::abs(nv(0)) < 0.9 ? Eigen::Vector3d::UnitX() : Eigen::Vector3d::UnitY();
    const Eigen::Vector3d t1 = nv.cross(a).normalized(), t2 = nv.cross(t1);
    Eigen::Vector3d g;
    const double E0 = vertex_energy(v, delta, &g);
    const Eigen::Vector2d g2(t1.dot(g), t2.dot(g));
    if (!(g2.norm() > 0)) return false;
    const double L = edge_len[v];
    const double hstep = 1e-5 * L;
    Eigen::Matrix2d H;
    for (int k = 0; k < 2; ++k) {
      const Eigen::Vector3d tk = k == 0 ? t1 : t2;
      Y.row(v) = (p0 + hstep * tk).transpose();
      Eigen::Vector3d gk;
      vertex_energy(v, delta, &gk);
      H(0, k) = (t1.dot(gk) - g2(0)) / hstep;
      H(1, k) = (t2.dot(gk) - g2(1)) / hstep;
    }
    Y.row(v) = p0.transpose();
    H = 0.5 * (H + H.transpose()).eval();
    Eigen::Vector2d d;
    Eigen::SelfAdjointEigenSolver<Eigen::Matrix2d> es(H);
    if (es.eigenvalues()(0) > 1e-12 * std::max(1.0, es.eigenvalues()(1))) d = -es.eigenvectors() *
        (es.eigenvectors().transpose() * g2).cwiseQuotient(es.eigenvalues());
    else d = -g2 / g2.norm() * 0.25 * L;
    const double cap = 0.5 * L;
    if (d.norm() > cap) d *= cap / d.norm();
    for (int k = 0; k < 12; ++k, d *= 0.5) {
      const Eigen::Vector3d x = p0 + d(0) * t1 + d(1) * t2;
      const ClosestPointResult r = project_near(f0, x);
      set_image(v, r.elem, r.bary.head<3>());
      const double E1 = vertex_energy(v, delta, nullptr);
      if (E1 < E0 - 1e-14 * std::abs(E0)) return true;
    }
    set_image(v, f0, b0);
    return false;
  }

  // Flipped or collapsed faces around v (fold_counts' classes).
  int folds_around(int v, double degenerate_tol) const {
    int c = 0;
    for (int q = inc_s.begin(v); q < inc_s.end(v); ++q)
      c += fold_class(inc_s.elems[q], Xs, Fs, Y, Nt, Ft, P, degenerate_tol, inc_t) != 0;
    return c;
  }

  // Conformal distortion MIPS - 2 of the mapped face t (surface_distortion.h; +inf when its
  // image has no area, NaN when its rest face has none: never over a limit).
  double face_mips(int t) const {
    const Eigen::Vector3d x0 = Xs.row(Fs(t, 0)), y0 = Y.row(Fs(t, 0));
    return face_conformal_distortion(Eigen::Vector3d(Xs.row(Fs(t, 1))) - x0, Eigen::Vector3d(Xs.row(Fs(t, 2))) - x0,
                                     Eigen::Vector3d(Y.row(Fs(t, 1))) - y0, Eigen::Vector3d(Y.row(Fs(t, 2))) - y0);
  }
  // Per face around v (inc_s order), the MIPS - 2 it may end with when it is not folded:
  // max_mips, or its own now when it is not folded now and above that. A move or a step of v
  // that exceeds one would trade a fold for a triangle squashed flat.
  std::vector<double> mips_limits(int v, double max_mips, double degenerate_tol) const {
    std::vector<double> limits;
    for (int q = inc_s.begin(v); q < inc_s.end(v); ++q) {
      const int t = inc_s.elems[q];
      const bool folded = fold_class(t, Xs, Fs, Y, Nt, Ft, P, degenerate_tol, inc_t) != 0;
      limits.push_back(folded ? max_mips : std::max(max_mips, face_mips(t)));
    }
    return limits;
  }

  // The faces around v: how many are flipped or collapsed, and whether each of the others keeps
  // its MIPS - 2 within its limit (limits: one per face around v, in inc_s order).
  int folds_within(int v, const std::vector<double>& limits, double degenerate_tol, bool* within) const {
    int c = 0;
    *within = true;
    for (int q = inc_s.begin(v), k = 0; q < inc_s.end(v); ++q, ++k) {
      const int t = inc_s.elems[q];
      if (fold_class(t, Xs, Fs, Y, Nt, Ft, P, degenerate_tol, inc_t) != 0) ++c;
      else if (face_mips(t) > limits[size_t(k)]) *within = false;
    }
    return c;
  }

  // The re-seating search of one corner (UntangleOptions::search_sweeps): its image tried at
  // each point of a barycentric grid on the target faces within `rings` rings (even) of its own
  // and its neighbours' images, kept at the best by (folds around it, energy). Returns the folds
  // removed (0 when it did not move or moved at equal folds).
  int search_vertex(int v, int grid, int rings, double delta, double degenerate_tol, double max_mips) {
    if (held[v]) return 0;
    const int bad0 = folds_around(v, degenerate_tol);
    if (bad0 == 0) return 0;
    const std::vector<double> limits = mips_limits(v, max_mips, degenerate_tol);
    const int f0 = P.elem(v);
    const Eigen::Vector3d b0 = P.bary.row(v).transpose();
    std::vector<int> faces = faces_near(f0);
    for (int q = inc_s.begin(v); q < inc_s.end(v); ++q)
      for (int j = 0; j < 3; ++j) {
        const std::vector<int>& near = faces_near(P.elem(Fs(inc_s.elems[q], j)));
        faces.insert(faces.end(), near.begin(), near.end());
      }
    std::sort(faces.begin(), faces.end());
    faces.erase(std::unique(faces.begin(), faces.end()), faces.end());
    for (int r = 2; r < rings; r += 2) {  // two rings more around what is gathered
      std::vector<int> more = faces;
      for (int g : faces) {
        const std::vector<int>& near = faces_near(g);
        more.insert(more.end(), near.begin(), near.end());
      }
      std::sort(more.begin(), more.end());
      more.erase(std::unique(more.begin(), more.end()), more.end());
      faces.swap(more);
    }
    int best_bad = bad0, best_f = f0;
    double best_E = vertex_energy(v, delta, nullptr);
    const double E0 = best_E;
    Eigen::Vector3d best_b = b0;
    for (int g : faces)
      for (int i = 0; i <= grid; ++i)
        for (int j = 0; i + j <= grid; ++j) {
          const Eigen::Vector3d b(double(i) / grid, double(j) / grid, double(grid - i - j) / grid);
          set_image(v, g, b);
          bool within = true;
          const int bad = folds_within(v, limits, degenerate_tol, &within);
          if (bad > best_bad || !within) continue;
          const double E = vertex_energy(v, delta, nullptr);
          if (bad < best_bad || E < best_E) {
            best_bad = bad;
            best_E = E;
            best_f = g;
            best_b = b;
          }
        }
    if (best_bad < bad0 || (best_bad == bad0 && best_E < E0 - 1e-14 * std::abs(E0))) {
      set_image(v, best_f, best_b);
      return bad0 - best_bad;
    }
    set_image(v, f0, b0);
    return 0;
  }
};

// Per face of S: 0 fine, 1 flipped, 2 collapsed (fold_counts), kSliver (opt.sliver_mips).
// Returns the fold counts; *slivers: the faces marked kSliver.
FoldCounts classify_faces(const Untangler& U, const TriMesh& S, const TriMesh& T, const BarycentricMap& P,
                          const UntangleOptions& opt, std::vector<unsigned char>& flags, int* slivers) {
  const FoldCounts c = fold_counts(U.Xs, S.F, U.Y, U.Nt, T.F, P, opt.degenerate_tol, &flags, &U.inc_t);
  *slivers = 0;
  if (opt.sliver_mips > 0) {
    const Eigen::VectorXd mips = conformal_distortion(U.Xs, U.Y, S.F);
    for (int t = 0; t < S.F.rows(); ++t)
      if (flags[t] == 0 && mips(t) > opt.sliver_mips) {
        flags[t] = kSliver;
        ++*slivers;
      }
  }
  return c;
}

// The round's regions: the corners of the seeding faces (slivers, and folds when
// opt.seed_folds) and `rings` rings around them, split into connected components (each
// sorted, in ascending order of their least vertex).
std::vector<std::vector<int>> free_regions(const Untangler& U, const Eigen::MatrixXi& F, int n,
                                           const std::vector<unsigned char>& flags, bool seed_folds, int rings) {
  const int m = int(F.rows());
  std::vector<unsigned char> fr(n, 0);
  for (int t = 0; t < m; ++t)
    if (flags[t] == kSliver || (flags[t] && seed_folds))
      for (int j = 0; j < 3; ++j) fr[F(t, j)] = 1;
  for (int k = 0; k < rings; ++k) {
    std::vector<unsigned char> next = fr;
    for (int t = 0; t < m; ++t)
      if (fr[F(t, 0)] || fr[F(t, 1)] || fr[F(t, 2)])
        for (int j = 0; j < 3; ++j) next[F(t, j)] = 1;
    fr.swap(next);
  }
  std::vector<int> comp(n, -1);
  std::vector<std::vector<int>> regions;
  for (int s = 0; s < n; ++s) {
    if (!fr[s] || comp[s] >= 0) continue;
    std::vector<int> R{s};
    comp[s] = int(regions.size());
    for (size_t q = 0; q < R.size(); ++q) {
      const int v = R[q];
      for (int i = U.inc_s.begin(v); i < U.inc_s.end(v); ++i)
        for (int j = 0; j < 3; ++j) {
          const int w = F(U.inc_s.elems[i], j);
          if (fr[w] && comp[w] < 0) {
            comp[w] = comp[s];
            R.push_back(w);
          }
        }
    }
    std::sort(R.begin(), R.end());
    regions.push_back(std::move(R));
  }
  return regions;
}

// Bad faces among `faces`: all, folds alone, and those marked hopeless.
struct Tally {
  int bad = 0, folds = 0, hopeless = 0;
  int slivers() const { return bad - folds; }
};
Tally tally(const std::vector<int>& faces, const std::vector<unsigned char>& flags,
            const std::vector<unsigned char>& hopeless) {
  Tally c;
  for (int t : faces) {
    c.bad += flags[t] != 0;
    c.folds += flags[t] != 0 && flags[t] != kSliver;
    c.hopeless += flags[t] != 0 && hopeless[t];
  }
  return c;
}

// The bridges among the corners of the region's folds re-seated (opt.reseat_bridges), Tutte
// sweeps over the corners of its collapsed (or flipped) triangles, then the energy's sweeps
// over all its vertices with delta shrinking geometrically.
void relax_region(Untangler& U, const std::vector<int>& R, const std::vector<unsigned char>& flags,
                  const UntangleOptions& opt) {
  if (opt.reseat_bridges)
    for (int v : R) U.reseat_bridge(v, flags);
  std::vector<int> seeds;
  for (int v : R)
    for (int i = U.inc_s.begin(v); i < U.inc_s.end(v); ++i)
      if (flags[U.inc_s.elems[i]] != kSliver && flags[U.inc_s.elems[i]] >= opt.smooth_min_flag) {
        seeds.push_back(v);
        break;
      }
  for (int s = 0; s < opt.smooth_sweeps; ++s)
    for (int v : seeds) U.average_vertex(v);
  for (int s = 0; s < opt.sweeps; ++s) {
    const double w = opt.sweeps > 1 ? double(s) / (opt.sweeps - 1) : 1.0;
    const double delta = opt.delta_start * std::pow(opt.delta_end / opt.delta_start, w);
    for (int v : R) U.relax_vertex(v, delta);
  }
}

// The re-seating search (UntangleOptions::search_sweeps): sweeps over the corners of the folded
// faces while a sweep removes folds. Every move leaves the folds around its vertex no more than
// they were, and only the faces around it change, so the map's fold count never rises.
void search_folds(Untangler& U, const TriMesh& S, const TriMesh& T, BarycentricMap& P, const UntangleOptions& opt,
                  std::vector<unsigned char>& flags, std::vector<unsigned char>& moved, UntangleResult& res) {
  const int m = int(S.F.rows());
  for (int sweep = 0; sweep < opt.search_sweeps && res.after.bad() > 0; ++sweep) {
    std::vector<int> corners;
    for (int t = 0; t < m; ++t)
      if (flags[t] == 1 || flags[t] == 2)
        for (int j = 0; j < 3; ++j) corners.push_back(S.F(t, j));
    std::sort(corners.begin(), corners.end());
    corners.erase(std::unique(corners.begin(), corners.end()), corners.end());
    int removed = 0;
    std::vector<int> polish;  // the moved corners and their neighbours
    for (int v : corners) {
      const int f0 = P.elem(v);
      const Eigen::Vector3d b0 = P.bary.row(v).transpose();
      removed += U.search_vertex(v, opt.search_grid, opt.search_rings, opt.delta_end, opt.degenerate_tol,
                                  opt.search_max_mips);
      if (P.elem(v) == f0 && P.bary.row(v).transpose() == b0) continue;
      moved[v] = 1;
      for (int q = U.inc_s.begin(v); q < U.inc_s.end(v); ++q)
        for (int j = 0; j < 3; ++j) polish.push_back(S.F(U.inc_s.elems[q], j));
    }
    // A grid point is where the folds fall, not where the triangles are shapely: the moved
    // corners and their neighbours relax (the energy's barrier opens the slivers), each step
    // kept only where the folds around its vertex do not rise and no face there passes its
    // MIPS limit.
    std::sort(polish.begin(), polish.end());
    polish.erase(std::unique(polish.begin(), polish.end()), polish.end());
    for (int s = 0; s < opt.sweeps; ++s)
      for (int w : polish) {
        const int f0 = P.elem(w), bad0 = U.folds_around(w, opt.degenerate_tol);
        const Eigen::Vector3d b0 = P.bary.row(w).transpose();
        const std::vector<double> limits = U.mips_limits(w, opt.search_max_mips, opt.degenerate_tol);
        if (!U.relax_vertex(w, opt.delta_end)) continue;
        bool within = true;
        if (U.folds_within(w, limits, opt.degenerate_tol, &within) > bad0 || !within) U.set_image(w, f0, b0);
        else moved[w] = 1;
      }
    ++res.regions;
    int unused = 0;
    res.after = classify_faces(U, S, T, P, opt, flags, &unused);
    if (removed == 0) break;
  }
  res.slivers_after = res.slivers_before;
}

}  // namespace

UntangleResult untangle_surface_map(const TriMesh& S, const TriMesh& T, BarycentricMap& P,
                                    const UntangleOptions& opt, const BarycentricMap* Q) {
  const auto t_start = std::chrono::steady_clock::now();
  UntangleResult res;
  Untangler U(S, T, P, opt.tether);
  U.held.assign(S.V.rows(), 0);
  for (int v : opt.held) {
    if (v < 0 || v >= S.V.rows()) throw InputError("untangle: held vertex " + std::to_string(v) + " out of range");
    U.held[v] = 1;
  }
  if (Q && Q->size() == T.V.rows() && opt.reverse_weight > 0) U.set_reverse(*Q, opt.reverse_weight);
  const int n = int(S.V.rows()), m = int(S.F.rows());
  std::vector<unsigned char> flags, fl;
  res.before = res.after = classify_faces(U, S, T, P, opt, flags, &res.slivers_before);
  res.slivers_after = res.slivers_before;
  std::vector<unsigned char> moved(n, 0);
  if (opt.search_sweeps > 0) {
    search_folds(U, S, T, P, opt, flags, moved, res);
    for (int v = 0; v < n; ++v) res.vertices_moved += moved[v];
    res.seconds = std::chrono::duration<double>(std::chrono::steady_clock::now() - t_start).count();
    return res;
  }
  // faces that were bad in a region whose try ended worse than it started: a fold that the
  // region's vertices cannot undo (typically a whole patch mapped mirrored); a larger region
  // made only of such faces is not tried again.
  std::vector<unsigned char> hopeless(m, 0);
  int rings = opt.rings;
  for (int round = 0; round < opt.rounds && (opt.seed_folds ? res.after.bad() : 0) + res.slivers_after > 0;
       ++round, rings *= 2) {
    for (const std::vector<int>& R : free_regions(U, S.F, n, flags, opt.seed_folds, rings)) {
      // the faces the region's images touch, and how many of them are bad now
      std::vector<int> faces;
      for (int v : R)
        for (int i = U.inc_s.begin(v); i < U.inc_s.end(v); ++i) faces.push_back(U.inc_s.elems[i]);
      std::sort(faces.begin(), faces.end());
      faces.erase(std::unique(faces.begin(), faces.end()), faces.end());
      const Tally before = tally(faces, flags, hopeless);
      if (before.bad == 0 || before.hopeless == before.bad) continue;
      ++res.regions;
      BarycentricMap saved;
      saved.elem.resize(int(R.size()));
      saved.bary.resize(int(R.size()), 3);
      // the tether's anchors, which only a re-seated bridge moves (stage 5)
      Eigen::MatrixXd saved_anchors(opt.reseat_bridges ? R.size() : 0, 3);
      for (size_t i = 0; i < R.size(); ++i) {
        saved.elem(int(i)) = P.elem(R[i]);
        saved.bary.row(int(i)) = P.bary.row(R[i]);
        if (opt.reseat_bridges) saved_anchors.row(int(i)) = U.Y0.row(R[i]);
      }
      relax_region(U, R, flags, opt);
      int unused = 0;
      classify_faces(U, S, T, P, opt, fl, &unused);
      const Tally after = tally(faces, fl, hopeless);
      // folds first, then slivers: a region never trades a fold for slivers or back
      const bool better = after.folds < before.folds || (after.folds == before.folds && after.slivers() < before.slivers());
      const bool worse = after.folds > before.folds || (after.folds == before.folds && after.slivers() > before.slivers());
      if (better) {
        ++res.regions_kept;
        for (size_t i = 0; i < R.size(); ++i)
          if (P.elem(R[i]) != saved.elem(int(i)) || P.bary.row(R[i]) != saved.bary.row(int(i))) moved[R[i]] = 1;
      } else {
        if (worse)
          for (int t : faces)
            if (flags[t]) hopeless[t] = 1;
        for (size_t i = 0; i < R.size(); ++i) {
          U.set_image(R[i], saved.elem(int(i)), saved.bary.row(int(i)).transpose());
          if (opt.reseat_bridges) U.Y0.row(R[i]) = saved_anchors.row(int(i));
        }
      }
    }
    res.after = classify_faces(U, S, T, P, opt, flags, &res.slivers_after);
  }
  for (int v = 0; v < n; ++v) res.vertices_moved += moved[v];
  res.seconds = std::chrono::duration<double>(std::chrono::steady_clock::now() - t_start).count();
  return res;
}

}  // namespace shapemap
