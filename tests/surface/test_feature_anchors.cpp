// Feature anchors (surface/feature_anchors.h, issue 20): on a generated non-isometric pair with
// its ground-truth maps, the anchors are AGD maxima of both sides (BIM's feature points) that
// the truth sends onto each other within the tolerance; a reverse map that is not consistent
// with the forward one (every vertex of B onto one point of A) leaves at most one pair.
#include "shapemap/error.h"
#include "shapemap/generate.h"
#include "shapemap/maps.h"
#include "shapemap/surface/bim.h"
#include "shapemap/surface/feature_anchors.h"

#include <Eigen/Dense>
#include <gtest/gtest.h>
#include <algorithm>
#include <cmath>
#include <vector>

using namespace shapemap;

namespace {
std::vector<int> features_of(const TriMesh& M) {
  TriMesh u = M;
  u.V = unit_area_normalization(M).apply(M.V);
  BIMOptions bo;
  bo.min_features = 0;
  std::vector<int> even, f;
  Eigen::MatrixXd dist;
  Eigen::VectorXd agd;
  bim_sample_features(u, bo, {}, even, dist, agd, f);
  return f;
}
}  // namespace

TEST(FeatureAnchors, TruthMapsAnchorCorrespondingExtremities) {
  const GeneratedPair pair = make_creature_pair(3, PairKind::NonIsometric, 2000);
  // The truth sends A's AGD maxima near B's, not onto them (B's maxima are those of another
  // triangulation, and the creature is not deformed isometrically): a wider tolerance than the
  // default, which is for BIM maps (they send the features of their triplets onto each other).
  FeatureAnchorOptions opt;
  opt.tolerance = 0.05;
  const FeatureAnchors an = mutual_feature_anchors(pair.A, pair.B, pair.truth_AB, pair.truth_BA, opt);
  const std::vector<int> fa = features_of(pair.A), fb = features_of(pair.B);
  EXPECT_EQ(an.features_A, int(fa.size()));
  EXPECT_EQ(an.features_B, int(fb.size()));
  // a creature has a head, a tail and limbs: most of its extremities are anchored
  ASSERT_GE(an.A.size(), 4u);
  ASSERT_EQ(an.A.size(), an.B.size());
  ASSERT_EQ(an.A.size(), an.distance.size());
  const double sb = unit_area_normalization(pair.B).scale;
  const Eigen::MatrixXd PA = map_positions(pair.truth_AB, pair.B.V, pair.B.F);
  for (size_t k = 0; k < an.A.size(); ++k) {
    EXPECT_NE(std::find(fa.begin(), fa.end(), an.A[k]), fa.end());
    EXPECT_NE(std::find(fb.begin(), fb.end(), an.B[k]), fb.end());
    EXPECT_LE(an.distance[k], opt.tolerance);
    // the distance reported is the unit-area one: the input frame's over the scale
    EXPECT_LE((PA.row(an.A[k]) - pair.B.V.row(an.B[k])).norm() * sb, opt.tolerance * (1 + 1e-9));
  }
  // one-to-one
  std::vector<int> a = an.A, b = an.B;
  std::sort(a.begin(), a.end());
  std::sort(b.begin(), b.end());
  EXPECT_EQ(std::unique(a.begin(), a.end()), a.end());
  EXPECT_EQ(std::unique(b.begin(), b.end()), b.end());

  // The default tolerance keeps a subset: the pairs within it.
  const FeatureAnchors tight = mutual_feature_anchors(pair.A, pair.B, pair.truth_AB, pair.truth_BA);
  for (size_t k = 0; k < tight.A.size(); ++k) {
    EXPECT_LE(tight.distance[k], FeatureAnchorOptions{}.tolerance);
    EXPECT_NE(std::find(an.A.begin(), an.A.end(), tight.A[k]), an.A.end());
  }
  size_t within = 0;
  for (double d : an.distance) within += d <= FeatureAnchorOptions{}.tolerance;
  EXPECT_EQ(tight.A.size(), within);

  // A reverse map that sends everything to one vertex of A: only that vertex's nearest feature
  // can be anybody's mutual partner.
  BarycentricMap constant = pair.truth_BA;
  for (int i = 0; i < constant.size(); ++i) {
    constant.elem(i) = 0;
    constant.bary.row(i) << 1, 0, 0;
  }
  EXPECT_LE(mutual_feature_anchors(pair.A, pair.B, pair.truth_AB, constant, opt).A.size(), 1u);
  // and invalid maps are refused
  EXPECT_THROW(mutual_feature_anchors(pair.A, pair.B, pair.truth_AB, BarycentricMap{}, opt), InputError);
}
