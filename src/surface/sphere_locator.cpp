// Point location on a triangulated sphere by walking.
#include "shapemap/surface/sphere_locator.h"
#include "shapemap/adjacency.h"
#include "shapemap/error.h"
#include <cmath>

namespace shapemap {

void SphereLocator::build(const Eigen::MatrixXd& S, const Eigen::MatrixXi& F) {
  const int n = int(S.rows()), m = int(F.rows());
  if (m == 0) throw Error("SphereLocator: no faces");
  S_.resize(n);
  for (int i = 0; i < n; ++i) S_[i] = S.row(i).transpose();
  F_ = F;
  Eigen::MatrixXi FE;
  Eigen::MatrixXi E = unique_edges(F, &FE);
  Eigen::MatrixXi EF = edge_faces(F, E, FE);
  TT_.resize(m, 3);
  for (int f = 0; f < m; ++f)
    for (int k = 0; k < 3; ++k) {
      int e = FE(f, k);
      TT_(f, k) = EF(e, 0) == f ? EF(e, 2) : EF(e, 0);
    }
  vertex_face_.assign(n, 0);
  for (int f = m - 1; f >= 0; --f)
    for (int k = 0; k < 3; ++k) vertex_face_[F(f, k)] = f;
  max_steps_ = 8 * int(std::sqrt(double(m))) + 64;
  // Cube-map grid: each cell stores the face containing its centre (coherent walks).
  grid_ = std::max(8, std::min(128, int(std::sqrt(m / 6.0))));
  grid_face_.assign(size_t(6) * grid_ * grid_, 0);
  int f = 0;
  for (int c = 0; c < 6; ++c)
    for (int iu = 0; iu < grid_; ++iu)
      for (int iv0 = 0; iv0 < grid_; ++iv0) {
        int iv = (iu % 2) ? grid_ - 1 - iv0 : iv0;  // serpentine order
        double u = -1 + 2 * (iu + 0.5) / grid_, v = -1 + 2 * (iv + 0.5) / grid_;
        int axis = c / 2;
        double sgn = (c % 2) ? -1.0 : 1.0;
        Eigen::Vector3d d;
        d(axis) = sgn;
        d((axis + 1) % 3) = u;
        d((axis + 2) % 3) = v;
        f = walk_or_scan(d, f);
        grid_face_[(size_t(c) * grid_ + iu) * grid_ + iv] = f;
      }
  fallbacks_ = 0;
}

int SphereLocator::cell_of(const Eigen::Vector3d& x) const {
  int axis = 0;
  for (int k = 1; k < 3; ++k)
    if (std::abs(x(k)) > std::abs(x(axis))) axis = k;
  int c = 2 * axis + (x(axis) < 0 ? 1 : 0);
  double a = std::abs(x(axis));
  if (!(a > 0)) return 0;
  double u = x((axis + 1) % 3) / a, v = x((axis + 2) % 3) / a;
  int iu = std::clamp(int((u + 1) * 0.5 * grid_), 0, grid_ - 1);
  int iv = std::clamp(int((v + 1) * 0.5 * grid_), 0, grid_ - 1);
  return (c * grid_ + iu) * grid_ + iv;
}

namespace {
// x's unnormalized barycentric coordinates in the spherical face (a, b, c): the triple
// products det[x, b, c], det[x, c, a], det[x, a, b], each computed as det[x, b - x, c - x]
// etc. (the same determinant). The differences are small and exact to a few ulps when x is
// near the face, so the coordinates keep their relative precision in faces far smaller than
// the rounding of a unit vector: x . (b x c) directly loses everything below ~1e-16 (the
// camels' flattened feet have sphere edges of 1e-10 and triple products of 1e-20).
inline Eigen::Vector3d triple_coords(const Eigen::Vector3d& x, const Eigen::Vector3d& a, const Eigen::Vector3d& b,
                                     const Eigen::Vector3d& c) {
  const Eigen::Vector3d p = a - x, q = b - x, r = c - x;
  return Eigen::Vector3d(x.dot(q.cross(r)), x.dot(r.cross(p)), x.dot(p.cross(q)));
}
}  // namespace

int SphereLocator::walk_or_scan(const Eigen::Vector3d& x, int start) const {
  return locate_from(x, start, max_steps_, nullptr).face;
}

SphereLocator::Location SphereLocator::scan(const Eigen::Vector3d& x) const {
  // The face whose worst normalized coordinate is largest.
  Location best;
  double best_score = -1e300;
  for (int f = 0; f < F_.rows(); ++f) {
    const Eigen::Vector3d &a = S_[F_(f, 0)], &b = S_[F_(f, 1)], &c = S_[F_(f, 2)];
    const Eigen::Vector3d l = triple_coords(x, a, b, c);
    double s = l.sum();
    if (!(s > 0)) continue;
    double score = l.minCoeff() / s;
    if (score > best_score) {
      best_score = score;
      best.face = f;
      best.bary = l / s;
    }
  }
  if (best.face < 0) {
    best.face = 0;
    best.bary = Eigen::Vector3d::Constant(1.0 / 3);
  }
  best.bary = best.bary.cwiseMax(0.0);
  best.bary /= best.bary.sum();
  return best;
}

SphereLocator::Location SphereLocator::locate(const Eigen::Vector3d& x, int start_face,
                                              int* steps) const {
  int s1 = 0, s2 = 0;
  if (start_face >= 0 && start_face < F_.rows()) {
    Location r = walk(x, start_face, 6, &s1);
    if (r.face >= 0) {
      if (steps) *steps = s1;
      return r;
    }
  }
  Location r = walk(x, grid_face_.empty() ? 0 : grid_face_[cell_of(x)], max_steps_, &s2);
  if (steps) *steps = s1 + s2;
  if (r.face >= 0) return r;
#pragma omp atomic
  ++fallbacks_;
  return scan(x);
}

SphereLocator::Location SphereLocator::locate_from(const Eigen::Vector3d& x, int start, int cap,
                                                   int* steps) const {
  Location r = walk(x, start, cap, steps);
  return r.face >= 0 ? r : scan(x);
}

SphereLocator::Location SphereLocator::walk(const Eigen::Vector3d& x, int f, int cap, int* steps) const {
  int prev = -1;
  for (int step = 0; step < cap; ++step) {
    const Eigen::Vector3d &a = S_[F_(f, 0)], &b = S_[F_(f, 1)], &c = S_[F_(f, 2)];
    const Eigen::Vector3d l = triple_coords(x, a, b, c);
    const double l0 = l(0), l1 = l(1), l2 = l(2);
    // Scale-free tolerance for points on edges.
    double tol = -1e-14 * (std::abs(l0) + std::abs(l1) + std::abs(l2));
    int k = -1;
    double lk[3] = {l0, l1, l2};
    // Leave through an edge with negative coordinate, never back where we came from
    // when another choice exists; alternate between two candidates to avoid cycles.
    int cand[3], nc = 0;
    for (int j = 0; j < 3; ++j)
      if (lk[j] < tol) cand[nc++] = j;
    if (nc == 0) {
      double s = l0 + l1 + l2;
      if (s > 0) {
        if (steps) *steps = step;
        Location r;
        r.face = f;
        r.bary = Eigen::Vector3d(l0, l1, l2).cwiseMax(0.0);
        r.bary /= r.bary.sum();
        return r;
      }
      break;  // antipodal degenerate: scan
    }
    if (nc == 1) {
      k = cand[0];
    } else {
      int c0 = cand[(step) % nc], c1 = cand[(step + 1) % nc];
      k = (TT_(f, c0) == prev) ? c1 : c0;
    }
    prev = f;
    f = TT_(f, k);
    if (f < 0) break;
  }
  if (steps) *steps = cap;
  return Location{};  // face -1: not arrived
}

}  // namespace shapemap
