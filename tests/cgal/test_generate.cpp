// Generated creatures and pairs: topology, size, determinism, and the ground truth
// against the deformation it is built from.
#include "shapemap/checks.h"
#include "shapemap/generate.h"
#include "shapemap/maps.h"
#include "shapemap/mesh.h"
#include <gtest/gtest.h>
#include <algorithm>
#include <cmath>

using namespace shapemap;

namespace {

double bbox_diag(const Eigen::MatrixXd& V) {
  return (V.colwise().maxCoeff() - V.colwise().minCoeff()).norm();
}

void expect_closed_genus0(const TriMesh& m, const std::string& what) {
  MeshReport r = check_surface(m);
  EXPECT_TRUE(r.ok()) << what << ": " << (r.problems.empty() ? "" : r.problems[0]);
  EXPECT_TRUE(r.closed) << what;
  EXPECT_EQ(r.components, 1) << what;
  EXPECT_EQ(r.genus, 0) << what;
  EXPECT_GT(enclosed_volume(m.V, m.F), 0) << what << ": not outward";
}

Eigen::MatrixXd deform(const Deformation& d, const Eigen::MatrixXd& V) {
  Eigen::MatrixXd out(V.rows(), 3);
  for (int i = 0; i < V.rows(); ++i) out.row(i) = d.apply(V.row(i).transpose()).transpose();
  return out;
}

void expect_valid_map(const BarycentricMap& m, int n, int target_faces) {
  ASSERT_EQ(m.size(), n);
  ASSERT_EQ(m.arity(), 3);
  EXPECT_GE(m.elem.minCoeff(), 0);
  EXPECT_LT(m.elem.maxCoeff(), target_faces);
  EXPECT_GT(m.bary.minCoeff(), -1e-9);
  EXPECT_LT((m.bary.rowwise().sum().array() - 1).abs().maxCoeff(), 1e-9);
}

}  // namespace

TEST(Creature, ClosedGenus0AboutTargetSize) {
  for (std::uint64_t seed : {1, 2, 3, 4}) {
    const int n = 2000;
    TriMesh m = make_creature(seed, n);
    expect_closed_genus0(m, "creature seed " + std::to_string(seed));
    EXPECT_NEAR(double(m.num_vertices()) / n, 1.0, 0.25) << "seed " << seed;
  }
}

TEST(Creature, DeterministicPerSeed) {
  TriMesh a = make_creature(7, 1500), b = make_creature(7, 1500), c = make_creature(8, 1500);
  ASSERT_EQ(a.num_vertices(), b.num_vertices());
  ASSERT_EQ(a.num_faces(), b.num_faces());
  EXPECT_EQ((a.V - b.V).cwiseAbs().maxCoeff(), 0.0);
  EXPECT_TRUE((a.F.array() == b.F.array()).all());
  EXPECT_TRUE(a.num_vertices() != c.num_vertices() ||
              (a.V - c.V).cwiseAbs().maxCoeff() > 1e-3);  // another seed, another creature
}

TEST(Creature, DeformationKinds) {
  TriMesh a = make_creature(5, 2000);
  for (PairKind kind : {PairKind::NearIsometric, PairKind::NonIsometric}) {
    Deformation d = creature_deformation(5, kind);
    Eigen::MatrixXd X = deform(d, a.V);
    ASSERT_TRUE(X.allFinite());
    // Deterministic and smooth: the same field twice, small steps give small moves.
    Deformation d2 = creature_deformation(5, kind);
    EXPECT_EQ((deform(d2, a.V) - X).cwiseAbs().maxCoeff(), 0.0);
    Eigen::Vector3d p = a.V.row(0), h(1e-4, -2e-4, 1e-4);
    EXPECT_LT((d.apply(p + h) - d.apply(p)).norm(), 50 * h.norm());
    // Edge-length distortion over the creature surface.
    std::vector<double> ratio;
    for (int f = 0; f < a.num_faces(); ++f)
      for (int k = 0; k < 3; ++k) {
        int i = a.F(f, k), j = a.F(f, (k + 1) % 3);
        ratio.push_back((X.row(i) - X.row(j)).norm() / (a.V.row(i) - a.V.row(j)).norm());
      }
    std::sort(ratio.begin(), ratio.end());
    double p05 = ratio[ratio.size() / 20], p95 = ratio[ratio.size() * 19 / 20];
    // The deformed surface keeps its orientation (no inversion of the shape).
    EXPECT_GT(enclosed_volume(X, a.F), 0);
    if (kind == PairKind::NearIsometric) {
      EXPECT_GT(p05, 0.85);
      EXPECT_LT(p95, 1.15);
    } else {
      EXPECT_GT(p95 / p05, 1.25);  // really not isometric
    }
    // It moves something: limbs bend.
    EXPECT_GT((X - a.V).rowwise().norm().maxCoeff(), 0.05 * bbox_diag(a.V));
  }
}

TEST(CreaturePair, GroundTruthIsExactUpToRemeshing) {
  for (PairKind kind : {PairKind::NearIsometric, PairKind::NonIsometric}) {
    GeneratedPair p = make_creature_pair(11, kind, 2000);
    expect_closed_genus0(p.A, "A");
    expect_closed_genus0(p.B, "B");
    EXPECT_NEAR(double(p.B.num_vertices()) / p.A.num_vertices(), 1.0, 0.3);
    expect_valid_map(p.truth_AB, p.A.num_vertices(), p.B.num_faces());
    expect_valid_map(p.truth_BA, p.B.num_vertices(), p.A.num_faces());
    Eigen::MatrixXd X = deform(p.deformation, p.A.V);
    const double diag = bbox_diag(X);
    // A -> B: deformed A vertices are within the remeshing error of B.
    Eigen::MatrixXd onB = map_positions(p.truth_AB, p.B.V, p.B.F);
    double errAB = (onB - X).rowwise().norm().maxCoeff();
    EXPECT_LT(errAB, 0.01 * diag);
    // B -> A: B's vertices lie on deform(A); the truth points reproduce them exactly.
    Eigen::MatrixXd onA = map_positions(p.truth_BA, X, p.A.F);
    double errBA = (onA - p.B.V).rowwise().norm().maxCoeff();
    EXPECT_LT(errBA, 1e-6 * diag);
    // B is a different tessellation (not A's vertices moved).
    EXPECT_NE(p.A.num_faces() == p.B.num_faces() && (p.A.F.array() == p.B.F.array()).all(), true);
  }
}
