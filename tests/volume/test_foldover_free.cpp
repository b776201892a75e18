// The regularized untangling energy (foldover_free.h): its derivative against finite
// differences, its values at rotations, and the untangling of folded box maps, free and
// inside a target tet mesh (the landing's use).
#include "shapemap/volume/foldover_free.h"
#include "shapemap/adjacency.h"
#include "volume_test_util.h"
#include <Eigen/Geometry>
#include <gtest/gtest.h>
#include <random>

using namespace shapemap;
using shapemap::test_volume::grid_box;

namespace {

int inverted(const ArapEnergy& arap, const Eigen::MatrixXd& X) {
  return int((arap.determinants(X).array() <= 0).count());
}

// A box tet mesh, its ARAP energy (the rest tets and weights), boundary and boundary flags.
struct Box {
  TetMesh m;
  ArapEnergy arap;
  TetBoundary b;
  std::vector<char> on_bd;
  explicit Box(const TetMesh& mesh) : m(mesh), arap(mesh.V, mesh.T), b(boundary_surface(mesh)), on_bd(mesh.num_vertices(), 0) {
    for (int i = 0; i < b.to_volume.size(); ++i) on_bd[b.to_volume(i)] = 1;
  }
};

}  // namespace

// dF/dJ against central differences, for positive, flat and inverted J and a large and a
// tiny eps (where chi bends sharply).
TEST(FoldoverFree, DistortionDerivativeMatchesFiniteDifferences) {
  std::mt19937 rng(3);
  std::uniform_real_distribution<double> u(-1.0, 1.0);
  for (int trial = 0; trial < 30; ++trial) {
    Eigen::Matrix3d J = Eigen::Matrix3d::Identity();
    for (int i = 0; i < 3; ++i)
      for (int j = 0; j < 3; ++j) J(i, j) += 0.7 * u(rng);
    if (trial % 3 == 1) J.col(2) = 0.5 * J.col(0) - 0.3 * J.col(1);  // flat
    if (trial % 3 == 2) J.col(2) = -J.col(2);                         // inverted (mostly)
    const double eps = trial % 2 ? 0.3 : 1e-3;
    Eigen::Matrix3d dF;
    foldover_free_distortion(J, eps, 0.5, &dF);
    // Steps well inside chi's bend: chi ~ eps^2 / 4|det J| on inverted J.
    const double h = 1e-3 * std::min(1.0, foldover_chi(J.determinant(), eps)) / (1.0 + J.squaredNorm());
    double err = 0, scale = 1e-12;
    for (int i = 0; i < 3; ++i)
      for (int j = 0; j < 3; ++j) {
        Eigen::Matrix3d Jp = J, Jm = J;
        Jp(i, j) += h;
        Jm(i, j) -= h;
        const double fd = (foldover_free_distortion(Jp, eps, 0.5, nullptr) -
                           foldover_free_distortion(Jm, eps, 0.5, nullptr)) / (2 * h);
        err = std::max(err, std::abs(fd - dF(i, j)));
        scale = std::max(scale, std::abs(dF(i, j)));
      }
    EXPECT_LT(err / scale, 1e-5) << "trial " << trial;
  }
}

// At a rotation with eps -> 0: shape term 3, volume term 2 (theta = 1/2: 2.5); a flat J
// costs more the smaller eps; chi > 0 for every det J.
TEST(FoldoverFree, DistortionAtRotationsAndFlatTets) {
  const Eigen::Matrix3d R = Eigen::AngleAxisd(0.7, Eigen::Vector3d(1, 2, 3).normalized()).toRotationMatrix();
  EXPECT_NEAR(foldover_free_distortion(R, 1e-9, 0.5, nullptr), 2.5, 1e-9);
  Eigen::Matrix3d flat = R;
  flat.col(2).setZero();
  EXPECT_GT(foldover_free_distortion(flat, 1e-3, 0.5, nullptr), foldover_free_distortion(flat, 1e-1, 0.5, nullptr));
  for (double D : {-10.0, -1e-3, 0.0, 1e-3, 10.0}) EXPECT_GT(foldover_chi(D, 1e-4), 0.0);
  double d = 0;
  EXPECT_NEAR(foldover_chi(2.0, 0.0, &d), 2.0, 1e-15);
  EXPECT_NEAR(d, 1.0, 1e-15);
}

// A box map with interior vertices pushed through their neighbours (many folded tets),
// boundary held: untangled, and only the region's vertices move.
TEST(FoldoverFree, UntanglesFoldsWithTheBoundaryHeld) {
  const Box box(grid_box(5, 4, 4, 1.0, 0.8, 0.8));
  Eigen::MatrixXd Y = box.m.V;
  std::mt19937 rng(5);
  std::uniform_real_distribution<double> u(-0.25, 0.25);
  std::vector<int> free, tets;
  for (int v = 0; v < box.m.num_vertices(); ++v)
    if (!box.on_bd[v]) {
      free.push_back(v);
      for (int c = 0; c < 3; ++c) Y(v, c) += u(rng);
    }
  for (int k = 0; k < box.m.num_tets(); ++k) tets.push_back(k);
  ASSERT_GT(inverted(box.arap, Y), 10);
  const FoldoverFreeResult r = untangle_foldover_free(box.arap, tets, free, {}, FoldoverFreeOptions{}, Y);
  EXPECT_EQ(inverted(box.arap, Y), 0);
  EXPECT_GT(r.min_det, 1e-3);
  for (int v = 0; v < box.m.num_vertices(); ++v)
    if (box.on_bd[v]) EXPECT_EQ((Y.row(v) - box.m.V.row(v)).norm(), 0.0);
}

// The landing's use: a map of a box onto the same box with a fold, including boundary
// vertices slid along a face past their neighbours; untangle_in_target unfolds it, every
// image stays in the target (to the spring's tolerance) and the boundary near dM_j.
TEST(FoldoverFree, UntanglesInTheTargetWithBoundaryVerticesSliding) {
  const Box box(grid_box(6, 5, 4, 1.0, 0.8, 0.6));
  Eigen::MatrixXd Y = box.m.V;
  // Vertices on the top face (z = 0.6) with x near 0.5 slide +0.25 in x: past the next row.
  int slid = 0;
  for (int v = 0; v < box.m.num_vertices(); ++v)
    if (std::abs(box.m.V(v, 2) - 0.6) < 1e-12 && std::abs(box.m.V(v, 0) - 0.5) < 0.1 && box.m.V(v, 1) > 0.1 && box.m.V(v, 1) < 0.7) {
      Y(v, 0) += 0.25;
      ++slid;
    }
  ASSERT_GT(slid, 0);
  const int before = inverted(box.arap, Y);
  ASSERT_GT(before, 0);
  const ClosestPoint3 surface(box.b.surface.V, box.b.surface.F);
  const TetLocator locator(box.m.V, box.m.T);
  untangle_in_target(box.arap, vertex_neighbors(box.m.T, box.m.num_vertices()), box.on_bd, InTarget{box.m, box.b.surface, surface, locator},
                     2, 1e-6, FoldoverFreeOptions{}, Y);
  EXPECT_EQ(inverted(box.arap, Y), 0) << "before: " << before;
  const double lo = -1e-3, hi = 1e-3;  // the springs' tolerance, in units of the box
  EXPECT_GT(Y.col(0).minCoeff(), lo);
  EXPECT_LT(Y.col(0).maxCoeff(), 1.0 + hi);
  EXPECT_GT(Y.col(2).minCoeff(), lo);
  EXPECT_LT(Y.col(2).maxCoeff(), 0.6 + hi);
  for (int i = 0; i < box.b.to_volume.size(); ++i) {
    const Eigen::Vector3d y = Y.row(box.b.to_volume(i)).transpose();
    EXPECT_LT(std::sqrt(surface.query(y).sqdist), 0.02) << "boundary vertex " << box.b.to_volume(i);
  }
}
