// Closest points on triangles / tetrahedra in R^D and the BVH that answers nearest-element
// queries (the projection steps of elastic correspondence and symmetric volume maps).
//
// Every simplex test is done in "reduced" form: with a the first vertex, e_i = v_i - a
// and ap = p - a, the squared distance to a + sum_i x_i e_i is
//   f(x) = |ap|^2 - 2 x.b + x' G x,   G_ij = e_i.e_j,  b_i = e_i.ap,
// so only the D-dimensional dot products b_i and |ap|^2 depend on the query; the Gram
// matrix G depends on the element alone and is precomputed (packed_) at build/refit time.
// Faces and edges of a simplex are sub-problems of the same quadratic, expressed with
// entries of G and b, so the fall-backs cost no further D-dimensional work.
#include "shapemap/geometry/closest_point.h"

#include "shapemap/error.h"

#include <algorithm>
#include <cmath>
#include <limits>
#include <string>

namespace shapemap {

namespace {

constexpr double kInf = std::numeric_limits<double>::infinity();
// det(G) / prod(diag G) below this: the simplex is (nearly) degenerate and the interior
// candidate is not trusted alone (the boundary is always examined too).
constexpr double kDegenerate = 1e-8;

inline double clamp01(double x) { return x < 0 ? 0 : (x > 1 ? 1 : x); }

// Closest point of the triangle {a + s e0 + t e1 : s,t >= 0, s+t <= 1} to p in reduced form.
// In: Gram entries e00 = e0.e0, e01, e11; b0 = e0.ap, b1 = e1.ap; c = |ap|^2.
// Out: s, t; returns the squared distance (clamped at 0).
// bound: if the distance to the triangle's plane is already >= bound, returns +inf at once
// (s_out, t_out untouched): the caller has something at least as close.
inline double tri_reduced(double e00, double e01, double e11, double b0, double b1, double c,
                          double& s_out, double& t_out, double bound = kInf) {
  auto f = [&](double s, double t) {
    return c - 2 * (s * b0 + t * b1) + s * s * e00 + 2 * s * t * e01 + t * t * e11;
  };
  double best = kInf, bs = 0, bt = 0;
  const double det = e00 * e11 - e01 * e01;
  // Which edges to examine. If the plane minimizer x has coordinates lambda, the closest
  // point lies on an edge whose opposite coordinate is negative: with q the closest point
  // and p - q = sum_k mu_k (-grad lambda_k) over the constraints active at q (mu >= 0),
  // sum_k mu_k lambda_k(p) = -|sum_k mu_k grad lambda_k|^2 < 0. Without a reliable solve
  // (degenerate triangle), all three.
  bool edge_ab = true, edge_ac = true, edge_bc = true;
  if (det > 0) {
    const double s = (e11 * b0 - e01 * b1) / det;
    const double t = (e00 * b1 - e01 * b0) / det;
    const bool good = det > kDegenerate * e00 * e11;
    // Squared distance to the plane (f at the unconstrained minimizer, G x = b): a lower
    // bound for the distance to the triangle.
    if (good && c - (s * b0 + t * b1) >= bound) return kInf;
    if (good) {
      edge_ab = t < 0;
      edge_ac = s < 0;
      edge_bc = s + t > 1;
    }
    if (s >= 0 && t >= 0 && s + t <= 1) {
      best = f(s, t);
      bs = s;
      bt = t;
      if (good) {  // well conditioned: the interior point is exact
        s_out = bs;
        t_out = bt;
        return best > 0 ? best : 0;
      }
    }
  }
  // The unconstrained minimizer is outside (or the triangle is degenerate): the minimum of
  // the convex quadratic over the triangle lies on its boundary; take the best edge.
  if (edge_ab) {  // edge a-b (t = 0)
    const double s = e00 > 0 ? clamp01(b0 / e00) : 0.0;
    const double v = c - 2 * s * b0 + s * s * e00;
    if (v < best) { best = v; bs = s; bt = 0; }
  }
  if (edge_ac) {  // edge a-c (s = 0)
    const double t = e11 > 0 ? clamp01(b1 / e11) : 0.0;
    const double v = c - 2 * t * b1 + t * t * e11;
    if (v < best) { best = v; bs = 0; bt = t; }
  }
  if (edge_bc) {  // edge b-c: b + u (c - b), i.e. s = 1-u, t = u
    const double e22 = e00 - 2 * e01 + e11;         // |c-b|^2
    const double num = b1 - b0 - e01 + e00;         // (c-b).(p-b)
    const double u = e22 > 0 ? clamp01(num / e22) : 0.0;
    const double v = f(1 - u, u);
    if (v < best) { best = v; bs = 1 - u; bt = u; }
  }
  s_out = bs;
  t_out = bt;
  return best > 0 ? best : 0;
}

// Layout of one packed element (see the header): first vertex a, the edge vectors e_i,
// then the upper triangle of the Gram matrix.
template <int D>
constexpr int tri_stride() { return 3 * D + 3; }
template <int D>
constexpr int tet_stride() { return 4 * D + 13; }  // + G^{-1} (6 entries) and det G

template <int D>
inline void pack_tri(const double* a, const double* b, const double* c, double* out) {
  double* e0 = out + D;
  double* e1 = out + 2 * D;
  double g00 = 0, g01 = 0, g11 = 0;
  for (int d = 0; d < D; ++d) {
    out[d] = a[d];
    e0[d] = b[d] - a[d];
    e1[d] = c[d] - a[d];
    g00 += e0[d] * e0[d];
    g01 += e0[d] * e1[d];
    g11 += e1[d] * e1[d];
  }
  out[3 * D] = g00;
  out[3 * D + 1] = g01;
  out[3 * D + 2] = g11;
}

template <int D>
inline void pack_tet(const double* a, const double* b, const double* c, const double* d4,
                     double* out) {
  double* e0 = out + D;
  double* e1 = out + 2 * D;
  double* e2 = out + 3 * D;
  double g00 = 0, g01 = 0, g02 = 0, g11 = 0, g12 = 0, g22 = 0;
  for (int d = 0; d < D; ++d) {
    out[d] = a[d];
    e0[d] = b[d] - a[d];
    e1[d] = c[d] - a[d];
    e2[d] = d4[d] - a[d];
    g00 += e0[d] * e0[d];
    g01 += e0[d] * e1[d];
    g02 += e0[d] * e2[d];
    g11 += e1[d] * e1[d];
    g12 += e1[d] * e2[d];
    g22 += e2[d] * e2[d];
  }
  double* g = out + 4 * D;
  g[0] = g00; g[1] = g01; g[2] = g02; g[3] = g11; g[4] = g12; g[5] = g22;
  // Inverse Gram matrix by the adjugate (0 if singular), and the determinant.
  const double A00 = g11 * g22 - g12 * g12;
  const double A01 = g02 * g12 - g01 * g22;
  const double A02 = g01 * g12 - g02 * g11;
  const double det = g00 * A00 + g01 * A01 + g02 * A02;
  const double inv = det > 0 ? 1.0 / det : 0.0;
  g[6] = A00 * inv;
  g[7] = A01 * inv;
  g[8] = A02 * inv;
  g[9] = (g00 * g22 - g02 * g02) * inv;
  g[10] = (g01 * g02 - g00 * g12) * inv;
  g[11] = (g00 * g11 - g01 * g01) * inv;
  g[12] = det;
}

// Squared distance and barycentric coordinates (w[0..2]) of p to a packed triangle.
template <int D>
inline double tri_query(const double* p, const double* el, double* w, double bound = kInf) {
  const double* a = el;
  const double* e0 = el + D;
  const double* e1 = el + 2 * D;
  double b0 = 0, b1 = 0, c = 0;
  for (int d = 0; d < D; ++d) {
    const double ap = p[d] - a[d];
    b0 += e0[d] * ap;
    b1 += e1[d] * ap;
    c += ap * ap;
  }
  double s, t;
  const double sq = tri_reduced(el[3 * D], el[3 * D + 1], el[3 * D + 2], b0, b1, c, s, t, bound);
  if (sq == kInf) return sq;
  w[0] = 1 - s - t;
  w[1] = s;
  w[2] = t;
  return sq;
}

// Squared distance and barycentric coordinates (w[0..3]) of p to a packed tetrahedron.
template <int D>
inline double tet_query(const double* p, const double* el, double* w, double bound = kInf) {
  const double* a = el;
  const double* e0 = el + D;
  const double* e1 = el + 2 * D;
  const double* e2 = el + 3 * D;
  double b0 = 0, b1 = 0, b2 = 0, c = 0;
  for (int d = 0; d < D; ++d) {
    const double ap = p[d] - a[d];
    b0 += e0[d] * ap;
    b1 += e1[d] * ap;
    b2 += e2[d] * ap;
    c += ap * ap;
  }
  const double* g = el + 4 * D;
  const double g00 = g[0], g01 = g[1], g02 = g[2], g11 = g[3], g12 = g[4], g22 = g[5];
  double best = kInf;
  // Faces to examine: those whose opposite coordinate of the hull minimizer is negative
  // (the argument of tri_reduced); all four without a reliable solve.
  bool f_abc = true, f_abd = true, f_acd = true, f_bcd = true;
  // Interior: solve the 3×3 normal equations G x = b (precomputed inverse).
  const double det = g[12];
  if (det > 0) {
    const double x0 = g[6] * b0 + g[7] * b1 + g[8] * b2;
    const double x1 = g[7] * b0 + g[9] * b1 + g[10] * b2;
    const double x2 = g[8] * b0 + g[10] * b1 + g[11] * b2;
    // Squared distance to the affine hull (G x = b): a lower bound for the tet.
    const bool good = det > kDegenerate * g00 * g11 * g22;
    if (D > 3 && good && c - (x0 * b0 + x1 * b1 + x2 * b2) >= bound) return kInf;
    if (good) {
      f_abc = x2 < 0;
      f_abd = x1 < 0;
      f_acd = x0 < 0;
      f_bcd = x0 + x1 + x2 > 1;
    }
    if (x0 >= 0 && x1 >= 0 && x2 >= 0 && x0 + x1 + x2 <= 1) {
      double v;
      if (D == 3 && good) {
        v = 0;  // the tet spans R^3: p is inside
      } else {
        v = c - 2 * (x0 * b0 + x1 * b1 + x2 * b2) + x0 * x0 * g00 + x1 * x1 * g11 +
            x2 * x2 * g22 + 2 * (x0 * x1 * g01 + x0 * x2 * g02 + x1 * x2 * g12);
        if (v < 0) v = 0;
      }
      best = v;
      w[0] = 1 - x0 - x1 - x2;
      w[1] = x0;
      w[2] = x1;
      w[3] = x2;
      if (good) return best;
    }
  }
  // Outside (or degenerate): the best of the four faces.
  double s, t, v;
  if (best > bound) best = bound;  // faces no closer than the caller's bound are skipped
  if (f_abc) {
    v = tri_reduced(g00, g01, g11, b0, b1, c, s, t, best);
    if (v < best) { best = v; w[0] = 1 - s - t; w[1] = s; w[2] = t; w[3] = 0; }
  }
  if (f_abd) {
    v = tri_reduced(g00, g02, g22, b0, b2, c, s, t, best);
    if (v < best) { best = v; w[0] = 1 - s - t; w[1] = s; w[2] = 0; w[3] = t; }
  }
  if (f_acd) {
    v = tri_reduced(g11, g12, g22, b1, b2, c, s, t, best);
    if (v < best) { best = v; w[0] = 1 - s - t; w[1] = 0; w[2] = s; w[3] = t; }
  }
  if (f_bcd) {  // face b c d, origin b: edges c-b = e1-e0, d-b = e2-e0, bp = ap - e0
    const double h00 = g11 - 2 * g01 + g00;
    const double h01 = g12 - g01 - g02 + g00;
    const double h11 = g22 - 2 * g02 + g00;
    const double hb0 = b1 - b0 - g01 + g00;
    const double hb1 = b2 - b0 - g02 + g00;
    const double hc = c - 2 * b0 + g00;
    v = tri_reduced(h00, h01, h11, hb0, hb1, hc, s, t, best);
    if (v < best) { best = v; w[0] = 0; w[1] = 1 - s - t; w[2] = s; w[3] = t; }
  }
  return best < bound ? best : kInf;
}

// Barycentric coordinates from rounding may be -1e-17: clamp to >= 0, renormalize to sum 1.
inline void fix_bary(double* w, int n) {
  bool neg = false;
  for (int j = 0; j < n; ++j) neg |= w[j] < 0;
  if (!neg) return;
  double sum = 0;
  for (int j = 0; j < n; ++j) {
    if (w[j] < 0) w[j] = 0;
    sum += w[j];
  }
  for (int j = 0; j < n; ++j) w[j] /= sum;
}

// The reduced formula for the squared distance loses absolute accuracy ~1e-16 |p-a|^2 by
// cancellation; for the answer, recompute it from the point a + sum_i w_i e_i directly
// (exactly 0 for a point on the element, up to the rounding of the point itself).
template <int D>
inline double polished_sqdist(const double* p, const double* el, int nverts, const double* w) {
  double s = 0;
  for (int d = 0; d < D; ++d) {
    double q = el[d];
    for (int j = 1; j < nverts; ++j) q += w[j] * el[j * D + d];
    const double r = p[d] - q;
    s += r * r;
  }
  return s;
}

// Squared distance from p to the box [lo, hi].
template <int D>
inline double box_sqdist(const double* p, const double* lo, const double* hi) {
  double s = 0;
  for (int d = 0; d < D; ++d) {
    const double u = lo[d] - p[d];
    const double v = p[d] - hi[d];
    const double m = u > v ? u : v;
    if (m > 0) s += m * m;
  }
  return s;
}

}  // namespace

template <int D>
ClosestPointResult closest_point_on_simplex(const Eigen::Matrix<double, D, 1>& p,
                                            const Eigen::Matrix<double, D, 1>* verts,
                                            int nverts) {
  ClosestPointResult r;
  double w[4] = {0, 0, 0, 0};
  if (nverts == 3) {
    double el[tri_stride<D>()];
    pack_tri<D>(verts[0].data(), verts[1].data(), verts[2].data(), el);
    r.sqdist = tri_query<D>(p.data(), el, w);
  } else if (nverts == 4) {
    double el[tet_stride<D>()];
    pack_tet<D>(verts[0].data(), verts[1].data(), verts[2].data(), verts[3].data(), el);
    r.sqdist = tet_query<D>(p.data(), el, w);
  } else {
    throw InputError("closest_point_on_simplex: nverts must be 3 or 4, got " +
                     std::to_string(nverts));
  }
  fix_bary(w, nverts);
  {
    double el[tet_stride<D>()];
    if (nverts == 3)
      pack_tri<D>(verts[0].data(), verts[1].data(), verts[2].data(), el);
    else
      pack_tet<D>(verts[0].data(), verts[1].data(), verts[2].data(), verts[3].data(), el);
    if (r.sqdist > 0) r.sqdist = polished_sqdist<D>(p.data(), el, nverts, w);
  }
  r.elem = 0;
  r.bary = Eigen::Vector4d(w[0], w[1], w[2], w[3]);
  return r;
}

template <int D>
void ClosestPointBVH<D>::build(const Eigen::MatrixXd& V, const Eigen::MatrixXi& E) {
  if (V.cols() != D)
    throw InputError("ClosestPointBVH: vertices have " + std::to_string(V.cols()) +
                     " columns, expected " + std::to_string(D));
  if (E.rows() > 0 && E.cols() != 3 && E.cols() != 4)
    throw InputError("ClosestPointBVH: elements must have 3 (triangles) or 4 (tets) columns, got " +
                     std::to_string(E.cols()));
  if (E.size() > 0 && (E.minCoeff() < 0 || E.maxCoeff() >= V.rows()))
    throw InputError("ClosestPointBVH: element vertex index out of range");
  V_ = V;
  E_ = E;
  arity_ = E.rows() > 0 ? int(E.cols()) : 3;
  const int m = int(E.rows());
  nodes_.clear();
  order_.resize(m);
  for (int i = 0; i < m; ++i) order_[i] = i;
  if (m == 0) {
    packed_.clear();
    return;
  }
  std::vector<Point> centroids(m);
  for (int i = 0; i < m; ++i) {
    Point c = Point::Zero();
    for (int j = 0; j < arity_; ++j) c += V_.row(E_(i, j)).transpose();
    centroids[i] = c / arity_;
  }
  nodes_.reserve(2 * ((m + 1) / 2) + 1);
  build_node(0, m, centroids);
  pack();
  for (int n = int(nodes_.size()) - 1; n >= 0; --n) refit_node(n);
}

template <int D>
int ClosestPointBVH<D>::build_node(int begin, int end, std::vector<Point>& centroids) {
  const int id = int(nodes_.size());
  nodes_.emplace_back();
  if (end - begin <= 4) {  // leaf of at most 4 elements
    nodes_[id].begin = begin;
    nodes_[id].end = end;
    return id;
  }
  // Median split on the longest axis of the centroids' box.
  Point lo = centroids[order_[begin]], hi = lo;
  for (int k = begin + 1; k < end; ++k) {
    lo = lo.cwiseMin(centroids[order_[k]]);
    hi = hi.cwiseMax(centroids[order_[k]]);
  }
  int axis;
  (hi - lo).maxCoeff(&axis);
  const int mid = begin + (end - begin) / 2;
  std::nth_element(order_.begin() + begin, order_.begin() + mid, order_.begin() + end,
                   [&](int a, int b) {
                     const double ca = centroids[a](axis), cb = centroids[b](axis);
                     return ca < cb || (ca == cb && a < b);
                   });
  const int l = build_node(begin, mid, centroids);
  const int r = build_node(mid, end, centroids);
  nodes_[id].left = l;
  nodes_[id].right = r;
  nodes_[id].begin = begin;
  nodes_[id].end = end;
  return id;
}

template <int D>
void ClosestPointBVH<D>::pack() {
  const int m = int(order_.size());
  const int stride = arity_ == 3 ? tri_stride<D>() : tet_stride<D>();
  packed_.resize(size_t(m) * stride);
  // Row-major copies of the vertex coordinates are gathered per element.
#pragma omp parallel for schedule(static) if (m > 20000)
  for (int k = 0; k < m; ++k) {
    const int e = order_[k];
    double v[4][D];
    for (int j = 0; j < arity_; ++j)
      for (int d = 0; d < D; ++d) v[j][d] = V_(E_(e, j), d);
    double* out = packed_.data() + size_t(k) * stride;
    if (arity_ == 3)
      pack_tri<D>(v[0], v[1], v[2], out);
    else
      pack_tet<D>(v[0], v[1], v[2], v[3], out);
  }
}

// Box of node n: over its elements for a leaf, the union of the children's boxes otherwise
// (children have larger indices: a reverse sweep over nodes_ is bottom-up).
template <int D>
void ClosestPointBVH<D>::refit_node(int n) {
  Node& node = nodes_[n];
  if (node.left < 0) {
    node.lo.setConstant(kInf);
    node.hi.setConstant(-kInf);
    for (int k = node.begin; k < node.end; ++k) {
      const int e = order_[k];
      for (int j = 0; j < arity_; ++j) {
        const int v = E_(e, j);
        for (int d = 0; d < D; ++d) {
          const double x = V_(v, d);
          if (x < node.lo(d)) node.lo(d) = x;
          if (x > node.hi(d)) node.hi(d) = x;
        }
      }
    }
  } else {
    node.lo = nodes_[node.left].lo.cwiseMin(nodes_[node.right].lo);
    node.hi = nodes_[node.left].hi.cwiseMax(nodes_[node.right].hi);
  }
}

template <int D>
void ClosestPointBVH<D>::refit(const Eigen::MatrixXd& V) {
  if (V.rows() != V_.rows() || V.cols() != D)
    throw InputError("ClosestPointBVH::refit: vertices are " + std::to_string(V.rows()) + "x" +
                     std::to_string(V.cols()) + ", expected " + std::to_string(V_.rows()) +
                     "x" + std::to_string(D));
  V_ = V;
  if (nodes_.empty()) return;
  pack();
  for (int n = int(nodes_.size()) - 1; n >= 0; --n) refit_node(n);
}

template <int D>
inline void ClosestPointBVH<D>::test_elem(const Point& p, int k, ClosestPointResult& best) const {
  double w[4];
  double sq;
  if (arity_ == 3) {
    sq = tri_query<D>(p.data(), packed_.data() + size_t(k) * tri_stride<D>(), w, best.sqdist);
    w[3] = 0;
  } else {
    sq = tet_query<D>(p.data(), packed_.data() + size_t(k) * tet_stride<D>(), w, best.sqdist);
  }
  if (sq < best.sqdist) {
    best.sqdist = sq;
    best.elem = order_[k];
    best.bary = Eigen::Vector4d(w[0], w[1], w[2], w[3]);
  }
}

template <int D>
inline void ClosestPointBVH<D>::test_leaf(const Point& p, const Node& node,
                                          ClosestPointResult& best) const {
  for (int k = node.begin; k < node.end; ++k) test_elem(p, k, best);
}

template <int D>
ClosestPointResult ClosestPointBVH<D>::query(const Point& p, int hint) const {
  ClosestPointResult best;
  best.sqdist = kInf;
  if (nodes_.empty()) return best;
  if (hint >= 0 && hint < E_.rows()) {
    Point verts[4];
    for (int j = 0; j < arity_; ++j) verts[j] = V_.row(E_(hint, j)).transpose();
    ClosestPointResult r = closest_point_on_simplex<D>(p, verts, arity_);
    best = r;
    best.elem = hint;
  }
  // Branch and bound, nearest child first, explicit stack of (node, lower bound).
  // The median split keeps the tree balanced, so its depth is about log2(m/4) < 64.
  constexpr int kStack = 128;
  int stack_node[kStack];
  double stack_bound[kStack];
  int sp = 0;
  const double* pd = p.data();
  stack_node[sp] = 0;
  stack_bound[sp++] = box_sqdist<D>(pd, nodes_[0].lo.data(), nodes_[0].hi.data());
  while (sp > 0) {
    --sp;
    if (stack_bound[sp] >= best.sqdist) continue;
    const Node& node = nodes_[stack_node[sp]];
    if (node.left < 0) {
      test_leaf(p, node, best);
      if (best.sqdist <= 0) break;  // cannot do better than touching
      continue;
    }
    const Node& L = nodes_[node.left];
    const Node& R = nodes_[node.right];
    const double dl = box_sqdist<D>(pd, L.lo.data(), L.hi.data());
    const double dr = box_sqdist<D>(pd, R.lo.data(), R.hi.data());
    // Push the farther child first so the nearer one is popped next.
    if (dl <= dr) {
      if (dr < best.sqdist) { stack_node[sp] = node.right; stack_bound[sp++] = dr; }
      if (dl < best.sqdist) { stack_node[sp] = node.left; stack_bound[sp++] = dl; }
    } else {
      if (dl < best.sqdist) { stack_node[sp] = node.left; stack_bound[sp++] = dl; }
      if (dr < best.sqdist) { stack_node[sp] = node.right; stack_bound[sp++] = dr; }
    }
  }
  // Polish the answer: exact simplex of barycentric coordinates, direct distance.
  if (best.elem >= 0) {
    double w[4] = {best.bary(0), best.bary(1), best.bary(2), best.bary(3)};
    fix_bary(w, arity_);
    best.bary = Eigen::Vector4d(w[0], w[1], w[2], w[3]);
    if (best.sqdist > 0) {
      double el[tet_stride<D>()];
      Point verts[4];
      for (int j = 0; j < arity_; ++j) verts[j] = V_.row(E_(best.elem, j)).transpose();
      if (arity_ == 3)
        pack_tri<D>(verts[0].data(), verts[1].data(), verts[2].data(), el);
      else
        pack_tet<D>(verts[0].data(), verts[1].data(), verts[2].data(), verts[3].data(), el);
      best.sqdist = polished_sqdist<D>(pd, el, arity_, w);
    }
  }
  return best;
}

template <int D>
ClosestPointResult ClosestPointBVH<D>::query(const Point& p) const {
  return query(p, -1);
}

template <int D>
void ClosestPointBVH<D>::query(const Eigen::MatrixXd& P, std::vector<ClosestPointResult>& out,
                               bool use_hints, const std::vector<char>* skip) const {
  if (P.cols() != D)
    throw InputError("ClosestPointBVH::query: points have " + std::to_string(P.cols()) +
                     " columns, expected " + std::to_string(D));
  const int k = int(P.rows());
  if (use_hints && int(out.size()) != k)
    throw InputError("ClosestPointBVH::query: " + std::to_string(out.size()) +
                     " hints for " + std::to_string(k) + " points");
  if (skip && int(skip->size()) != k)
    throw InputError("ClosestPointBVH::query: " + std::to_string(skip->size()) + " skip flags for " +
                     std::to_string(k) + " points");
  out.resize(k);
#pragma omp parallel for schedule(dynamic, 64)
  for (int i = 0; i < k; ++i) {
    if (skip && (*skip)[i]) continue;
    const Point p = P.row(i).transpose();
    out[i] = query(p, use_hints ? out[i].elem : -1);
  }
}

template <int D>
std::vector<ClosestPointResult> ClosestPointBVH<D>::query(const Eigen::MatrixXd& P) const {
  std::vector<ClosestPointResult> out;
  query(P, out, false);
  return out;
}

template class ClosestPointBVH<2>;
template class ClosestPointBVH<3>;
template class ClosestPointBVH<6>;
template ClosestPointResult closest_point_on_simplex<2>(const Eigen::Matrix<double, 2, 1>&,
                                                        const Eigen::Matrix<double, 2, 1>*, int);
template ClosestPointResult closest_point_on_simplex<3>(const Eigen::Matrix<double, 3, 1>&,
                                                        const Eigen::Matrix<double, 3, 1>*, int);
template ClosestPointResult closest_point_on_simplex<6>(const Eigen::Matrix<double, 6, 1>&,
                                                        const Eigen::Matrix<double, 6, 1>*, int);

// ---------------------------------------------------------------------------------------

void TetLocator::build(const Eigen::MatrixXd& V, const Eigen::MatrixXi& T) {
  if (V.cols() != 3) throw InputError("TetLocator: vertices must be n×3");
  if (T.rows() > 0 && T.cols() != 4) throw InputError("TetLocator: tets must be m×4");
  bvh_.build(V, T);
}

ClosestPointResult TetLocator::locate(const Eigen::Vector3d& p) const { return bvh_.query(p); }

ClosestPointResult TetLocator::locate(const Eigen::Vector3d& p, int hint) const { return bvh_.query(p, hint); }

std::vector<ClosestPointResult> TetLocator::locate(const Eigen::MatrixXd& P) const {
  return bvh_.query(P);
}

}  // namespace shapemap
