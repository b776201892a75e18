// Feature anchors for the elastic refinement: see feature_anchors.h.
#include "shapemap/surface/feature_anchors.h"

#include "shapemap/surface/bim.h"

#include <limits>

namespace shapemap {

namespace {
// BIM's feature points (AGD maxima) of a mesh in its unit-area frame.
std::vector<int> feature_points(const TriMesh& unit, const FeatureAnchorOptions& opt) {
  BIMOptions bo;
  bo.num_even = opt.num_even;
  bo.feature_radius = opt.feature_radius;
  bo.max_features = opt.max_features;
  bo.min_features = 0;  // no spread samples: only true maxima are extremities
  bo.seed = opt.seed;
  std::vector<int> even, features;
  Eigen::MatrixXd even_dist;
  Eigen::VectorXd agd;
  bim_sample_features(unit, bo, {}, even, even_dist, agd, features);
  return features;
}

// The feature in `candidates` nearest to point p (rows of V), and its distance.
std::pair<int, double> nearest_feature(const Eigen::RowVector3d& p, const Eigen::MatrixXd& V,
                                       const std::vector<int>& candidates) {
  std::pair<int, double> best{-1, std::numeric_limits<double>::infinity()};
  for (int v : candidates) {
    const double d = (V.row(v) - p).norm();
    if (d < best.second) best = {v, d};
  }
  return best;
}
}  // namespace

FeatureAnchors mutual_feature_anchors(const TriMesh& A, const TriMesh& B, const BarycentricMap& P,
                                      const BarycentricMap& Q, const FeatureAnchorOptions& opt) {
  validate_map(P, A.num_vertices(), B.num_faces(), 3, "feature anchors: map A->B");
  validate_map(Q, B.num_vertices(), A.num_faces(), 3, "feature anchors: map B->A");
  TriMesh ua = A, ub = B;
  ua.V = unit_area_normalization(A).apply(A.V);
  ub.V = unit_area_normalization(B).apply(B.V);
  FeatureAnchors out;
  const std::vector<int> fa = feature_points(ua, opt), fb = feature_points(ub, opt);
  out.features_A = int(fa.size());
  out.features_B = int(fb.size());
  if (fa.empty() || fb.empty()) return out;
  const Eigen::MatrixXd PA = map_positions(P, ub.V, ub.F), QB = map_positions(Q, ua.V, ua.F);
  for (int a : fa) {
    const auto [b, dab] = nearest_feature(PA.row(a), ub.V, fb);
    const auto [back, dba] = nearest_feature(QB.row(b), ua.V, fa);
    if (back != a || dab > opt.tolerance || dba > opt.tolerance) continue;
    out.A.push_back(a);
    out.B.push_back(b);
    out.distance.push_back(std::max(dab, dba));
  }
  return out;
}

}  // namespace shapemap
