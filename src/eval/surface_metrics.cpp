// BIM benchmark protocol: normalized geodesic errors and their cumulative curve.
#include "shapemap/eval/surface_metrics.h"
#include "shapemap/error.h"
#include "shapemap/geometry/geodesics.h"
#include "shapemap/geometry/mass.h"
#include <algorithm>
#include <cmath>
#include <map>

namespace shapemap {

namespace {

int nearest_corner(const Eigen::MatrixXi& F, int f, const Eigen::RowVectorXd& b) {
  int k = 0;
  for (int j = 1; j < 3; ++j)
    if (b(j) > b(k)) k = j;
  return F(f, k);
}

void summarize(SurfaceErrorCurve& c, const SurfaceErrorOptions& opt) {
  c.count = int(c.errors.size());
  c.thresholds.clear();
  c.fraction.clear();
  int steps = int(std::round(opt.max_threshold / opt.threshold_step));
  for (int s = 0; s <= steps; ++s) {
    double t = s * opt.threshold_step;
    int within = 0;
    for (int i = 0; i < c.count; ++i)
      if (c.errors(i) <= t + 1e-12) ++within;
    c.thresholds.push_back(t);
    c.fraction.push_back(c.count ? double(within) / c.count : 0.0);
  }
  c.mean = c.count ? c.errors.mean() : 0.0;
  c.max = c.count ? c.errors.maxCoeff() : 0.0;
  int w = 0;
  for (int i = 0; i < c.count; ++i)
    if (c.errors(i) <= 0.1 + 1e-12) ++w;
  c.within_0_1 = c.count ? double(w) / c.count : 0.0;
}

// errors(i) = d(source vertex sources[i] field, predicted point i), grouped by source.
Eigen::VectorXd geodesic_errors(const std::vector<int>& target_vertex, const BarycentricMap& map,
                                const std::vector<int>& rows, const Eigen::MatrixXd& V,
                                const Eigen::MatrixXi& F, double t_factor, const ProgressCallback& progress) {
  HeatGeodesics geo(V, F, t_factor);
  std::map<int, std::vector<int>> by_source;  // target vertex -> indices into rows
  for (size_t i = 0; i < rows.size(); ++i) by_source[target_vertex[i]].push_back(int(i));
  std::vector<int> sources;
  for (auto& kv : by_source) sources.push_back(kv.first);
  Eigen::VectorXd err(rows.size());
  const size_t chunk = 64;
  for (size_t s0 = 0; s0 < sources.size(); s0 += chunk) {
    std::vector<int> batch(sources.begin() + s0, sources.begin() + std::min(sources.size(), s0 + chunk));
    Eigen::MatrixXd D = geo.distances(batch);
    for (size_t b = 0; b < batch.size(); ++b)
      for (int i : by_source[batch[b]]) {
        int v = rows[i];
        int f = map.elem(v);
        double d = 0;
        for (int k = 0; k < 3; ++k) d += map.bary(v, k) * D(F(f, k), int(b));
        err(i) = std::max(0.0, d);
      }
    report(progress, "evaluate/geodesics", double(s0 + batch.size()) / sources.size());
  }
  return err;
}

}  // namespace

SurfaceErrorCurve surface_map_error(const BarycentricMap& map, const BarycentricMap& truth,
                                    const Eigen::MatrixXd& V, const Eigen::MatrixXi& F,
                                    const SurfaceErrorOptions& opt, const ProgressCallback& progress) {
  if (map.size() != truth.size())
    throw InputError("truth: has " + std::to_string(truth.size()) + " entries, the map has " +
                     std::to_string(map.size()));
  validate_map(map, map.size(), int(F.rows()), 3, "map");
  validate_map(truth, truth.size(), int(F.rows()), 3, "truth");
  const int n = map.size();
  std::vector<int> rows;
  if (opt.max_points > 0 && opt.max_points < n) {
    for (int i = 0; i < opt.max_points; ++i) rows.push_back(int((long long)i * n / opt.max_points));
  } else {
    for (int i = 0; i < n; ++i) rows.push_back(i);
  }
  std::vector<int> tv(rows.size());
  for (size_t i = 0; i < rows.size(); ++i) tv[i] = nearest_corner(F, truth.elem(rows[i]), truth.bary.row(rows[i]));
  SurfaceErrorCurve c;
  double scale = 1.0 / std::sqrt(surface_area(V, F));
  c.errors = geodesic_errors(tv, map, rows, V, F, opt.heat_t_factor, progress) * scale;
  c.evaluated = Eigen::Map<Eigen::VectorXi>(rows.data(), Eigen::Index(rows.size()));
  summarize(c, opt);
  return c;
}

SurfaceErrorCurve surface_landmark_error(const BarycentricMap& map, const std::vector<int>& ls,
                                         const std::vector<int>& lt, const Eigen::MatrixXd& V,
                                         const Eigen::MatrixXi& F, const SurfaceErrorOptions& opt) {
  if (ls.size() != lt.size())
    throw InputError("landmarks: the two lists have different lengths (" + std::to_string(ls.size()) +
                     " and " + std::to_string(lt.size()) + ")");
  validate_map(map, map.size(), int(F.rows()), 3, "map");
  for (int v : ls)
    if (v < 0 || v >= map.size()) throw InputError("landmarks: source vertex " + std::to_string(v) + " out of range");
  for (int v : lt)
    if (v < 0 || v >= V.rows()) throw InputError("landmarks: target vertex " + std::to_string(v) + " out of range");
  SurfaceErrorCurve c;
  double scale = 1.0 / std::sqrt(surface_area(V, F));
  c.errors = geodesic_errors(lt, map, ls, V, F, opt.heat_t_factor, {}) * scale;
  c.evaluated = Eigen::Map<const Eigen::VectorXi>(ls.data(), Eigen::Index(ls.size()));
  summarize(c, opt);
  return c;
}

Eigen::VectorXd surface_map_confidence(const Eigen::MatrixXd& V, const Eigen::MatrixXi& F,
                                       const Eigen::MatrixXd& X, double target_area, double* integrated) {
  Eigen::VectorXd a0 = triangle_areas(V, F), a1 = triangle_areas(X, F);
  double A0 = a0.sum();
  a0 /= A0;
  a1 /= target_area;
  const int n = int(V.rows());
  Eigen::VectorXd s0 = Eigen::VectorXd::Zero(n), s1 = s0;
  for (int f = 0; f < F.rows(); ++f)
    for (int k = 0; k < 3; ++k) {
      s0(F(f, k)) += a0(f);
      s1(F(f, k)) += a1(f);
    }
  Eigen::VectorXd c(n);
  for (int v = 0; v < n; ++v) {
    double r = s0(v) > 0 ? s1(v) / s0(v) : 0;
    c(v) = (r > 0 && std::isfinite(r)) ? 2 / (r + 1 / r) : 0.0;
  }
  if (integrated) *integrated = c.dot(s0) / s0.sum();
  return c;
}

}  // namespace shapemap
