// Coverage of the target's boundary under moves of the image's vertices (target_coverage.h).
#include "shapemap/volume/target_coverage.h"
#include "shapemap/adjacency.h"
#include "shapemap/geometry/closest_point.h"
#include <algorithm>
#include <cmath>
#include <limits>

namespace shapemap {
namespace {

// Closest point of p on image face f (corners at X.row(rows[.])).
ClosestPointResult on_face(const Eigen::MatrixXd& X, const Eigen::MatrixXi& Fi, const std::vector<int>& rows, int f,
                           const Eigen::Vector3d& p) {
  Eigen::Vector3d v[3];
  for (int c = 0; c < 3; ++c) v[c] = X.row(rows[Fi(f, c)]).transpose();
  ClosestPointResult r = closest_point_on_simplex<3>(p, v, 3);
  r.elem = f;
  return r;
}

}  // namespace

TargetCoverage::TargetCoverage(const Eigen::MatrixXd& X, const Eigen::MatrixXi& Fi, const std::vector<int>& rows,
                               const Eigen::MatrixXd& Vj)
    : Fi_(Fi), rows_(rows), Vj_(Vj) {
  const int ns = int(rows.size()), nt = int(Vj.rows());
  int max_row = -1;
  for (int r : rows) max_row = std::max(max_row, r);
  to_surface_.assign(max_row + 1, -1);
  for (int s = 0; s < ns; ++s) to_surface_[rows[s]] = s;
  vf_.resize(ns);
  ring_.resize(ns);
  by_face_.resize(Fi.rows());
  for (int f = 0; f < Fi.rows(); ++f)
    for (int c = 0; c < 3; ++c) {
      vf_[Fi(f, c)].push_back(f);
      ring_[Fi(f, c)].push_back(Fi(f, (c + 1) % 3));
    }
  Eigen::MatrixXd Xs(ns, 3);
  for (int s = 0; s < ns; ++s) Xs.row(s) = X.row(rows[s]);
  const std::vector<ClosestPointResult> hit = ClosestPoint3(Xs, Fi).query(Vj);
  face_.resize(nt);
  dist_.resize(nt);
  for (int t = 0; t < nt; ++t) {
    face_[t] = hit[t].elem;
    dist_[t] = std::sqrt(std::max(0.0, hit[t].sqdist));
    by_face_[face_[t]].push_back(t);
  }
}

bool TargetCoverage::move(Eigen::MatrixXd& X, int s, const std::function<bool(int)>& move, double allowed) {
  const int row = rows_[s];
  std::vector<int> nearby, local = vf_[s];
  double before = 0;
  for (int f : vf_[s])
    for (int t : by_face_[f]) {
      nearby.push_back(t);
      before = std::max(before, dist_[t]);
    }
  for (int w : ring_[s]) local.insert(local.end(), vf_[w].begin(), vf_[w].end());
  std::sort(local.begin(), local.end());
  local.erase(std::unique(local.begin(), local.end()), local.end());
  const Eigen::RowVector3d x0 = X.row(row);
  if (!move(row)) return false;
  const double limit = std::max(allowed, before);
  std::vector<ClosestPointResult> trial(nearby.size());
  for (size_t q = 0; q < nearby.size(); ++q) {
    trial[q].sqdist = std::numeric_limits<double>::infinity();
    for (int f : local) {
      const ClosestPointResult r = on_face(X, Fi_, rows_, f, Vj_.row(nearby[q]).transpose());
      if (r.sqdist < trial[q].sqdist) trial[q] = r;
    }
    if (std::sqrt(std::max(0.0, trial[q].sqdist)) > limit) {
      X.row(row) = x0;
      return false;
    }
  }
  for (size_t q = 0; q < nearby.size(); ++q) {
    const int t = nearby[q];
    auto& old = by_face_[face_[t]];
    old.erase(std::find(old.begin(), old.end(), t));
    face_[t] = trial[q].elem;
    dist_[t] = std::sqrt(std::max(0.0, trial[q].sqdist));
    by_face_[face_[t]].push_back(t);
  }
  return true;
}

int mark_uncovered(const Eigen::MatrixXd& X, const Eigen::MatrixXi& Fi, const std::vector<int>& rows,
                   const Eigen::MatrixXd& Vj, const Eigen::MatrixXi& Fj, double far, int rings, double reach,
                   std::vector<char>& marked_i, std::vector<char>& marked_j) {
  const int ns = int(rows.size()), nt = int(Vj.rows());
  marked_i.assign(ns, 0);
  marked_j.assign(nt, 0);
  Eigen::MatrixXd Xs(ns, 3);
  for (int s = 0; s < ns; ++s) Xs.row(s) = X.row(rows[s]);
  const std::vector<ClosestPointResult> hit = ClosestPoint3(Xs, Fi).query(Vj);
  std::vector<int> far_vertices, front;
  for (int t = 0; t < nt; ++t)
    if (hit[t].sqdist > far * far) far_vertices.push_back(t), marked_j[t] = 1;
  if (far_vertices.empty()) return 0;
  const std::vector<std::vector<int>> nb = vertex_neighbors(Fj, nt);
  front = far_vertices;
  for (int r = 0; r < rings; ++r) {
    std::vector<int> next;
    for (int t : front)
      for (int u : nb[t])
        if (!marked_j[u]) marked_j[u] = 1, next.push_back(u);
    front.swap(next);
  }
  // Few far vertices (tens on the bench pairs): a scan of the image per far vertex.
  for (int s = 0; s < ns; ++s)
    for (int t : far_vertices)
      if ((Xs.row(s) - Vj.row(t)).squaredNorm() <= reach * reach) {
        marked_i[s] = 1;
        break;
      }
  return int(far_vertices.size());
}

}  // namespace shapemap
