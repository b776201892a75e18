// Cotangent Laplacians against analytic identities and brute-force P1 FEM stiffness.
#include "geometry/fixtures.h"
#include "shapemap/geometry/laplacian.h"
#include "shapemap/geometry/mass.h"
#include "shapemap/mesh.h"
#include <Eigen/Dense>
#include <gtest/gtest.h>
#include <cmath>
#include <random>

using namespace shapemap;
using shapemap::testing::flat_grid;
using shapemap::testing::icosphere;
using shapemap::testing::tet_grid;

namespace {

// Brute-force P1 stiffness: K_ij = sum_elements |measure| grad phi_i . grad phi_j, with the
// gradients from the inverse of the element's edge matrix (pseudo-inverse for triangles).
Eigen::MatrixXd fem_stiffness(const Eigen::MatrixXd& V, const Eigen::MatrixXi& E) {
  const int n = int(V.rows()), k = int(E.cols());
  Eigen::MatrixXd K = Eigen::MatrixXd::Zero(n, n);
  for (int e = 0; e < E.rows(); ++e) {
    Eigen::MatrixXd D(3, k - 1);
    for (int c = 1; c < k; ++c) D.col(c - 1) = (V.row(E(e, c)) - V.row(E(e, 0))).transpose();
    // Rows of G (k-1 × 3) are the gradients of phi_1..phi_{k-1}: G D = I, G in span(D).
    const Eigen::MatrixXd G = (D.transpose() * D).inverse() * D.transpose();
    Eigen::MatrixXd grads(k, 3);
    grads.row(0) = -G.colwise().sum();
    grads.bottomRows(k - 1) = G;
    const double measure = k == 3 ? 0.5 * Eigen::Vector3d(D.col(0)).cross(Eigen::Vector3d(D.col(1))).norm()
                                  : std::abs(D.determinant()) / 6.0;
    const Eigen::MatrixXd Ke = measure * grads * grads.transpose();
    for (int a = 0; a < k; ++a)
      for (int b = 0; b < k; ++b) K(E(e, a), E(e, b)) += Ke(a, b);
  }
  return K;
}

double dihedral(const Eigen::Vector3d& k, const Eigen::Vector3d& l, const Eigen::Vector3d& i,
                const Eigen::Vector3d& j) {
  // Interior dihedral angle at edge kl between the faces (k,l,i) and (k,l,j).
  const Eigen::Vector3d e = (l - k).normalized();
  Eigen::Vector3d a = i - k, b = j - k;
  a -= a.dot(e) * e;
  b -= b.dot(e) * e;
  return std::acos(std::clamp(a.normalized().dot(b.normalized()), -1.0, 1.0));
}

}  // namespace

TEST(CotanLaplacian, FlatGridConstantsAndLinearFunctions) {
  Eigen::MatrixXd V;
  Eigen::MatrixXi F;
  std::vector<int> interior;
  flat_grid(12, 9, 0.2, 7, V, F, &interior);
  const Eigen::SparseMatrix<double> L = cotan_laplacian(V, F);
  ASSERT_EQ(L.rows(), V.rows());
  EXPECT_NEAR((Eigen::MatrixXd(L) - Eigen::MatrixXd(L).transpose()).norm(), 0.0, 1e-12);
  const Eigen::VectorXd ones = Eigen::VectorXd::Ones(V.rows());
  EXPECT_LT((L * ones).cwiseAbs().maxCoeff(), 1e-12);
  const Eigen::VectorXd lin = 0.7 * V.col(0) - 1.3 * V.col(1) + Eigen::VectorXd::Constant(V.rows(), 0.4);
  const Eigen::VectorXd Llin = L * lin;
  for (int i : interior) EXPECT_NEAR(Llin(i), 0.0, 1e-12) << "vertex " << i;
  // PSD: x^T L x >= 0 for random x.
  std::mt19937 rng(3);
  std::normal_distribution<double> N;
  for (int r = 0; r < 10; ++r) {
    Eigen::VectorXd x(V.rows());
    for (int i = 0; i < x.size(); ++i) x(i) = N(rng);
    EXPECT_GE(x.dot(L * x), -1e-12);
  }
}

TEST(CotanLaplacian, EqualsP1StiffnessOnRandomSurface) {
  // Exact identity: the cotan Laplacian is the P1 FEM stiffness matrix.
  Eigen::MatrixXd V;
  Eigen::MatrixXi F;
  icosphere(1, 1.0, V, F);
  std::mt19937 rng(11);
  std::uniform_real_distribution<double> U(-0.1, 0.1);
  for (int i = 0; i < V.rows(); ++i) V.row(i) += Eigen::RowVector3d(U(rng), U(rng), U(rng));
  const Eigen::MatrixXd L = Eigen::MatrixXd(cotan_laplacian(V, F));
  const Eigen::MatrixXd K = fem_stiffness(V, F);
  EXPECT_LT((L - K).cwiseAbs().maxCoeff(), 1e-12 * K.cwiseAbs().maxCoeff());
}

TEST(CotanLaplacian, SphereCoordinatesGiveMeanCurvatureNormal) {
  // L x = 2 H n M with H = 1/r on a sphere of radius r.
  const double r = 2.5;
  Eigen::MatrixXd V;
  Eigen::MatrixXi F;
  icosphere(4, r, V, F);
  ASSERT_GT(enclosed_volume(V, F), 0);
  const Eigen::SparseMatrix<double> L = cotan_laplacian(V, F);
  const Eigen::VectorXd M = voronoi_mass(V, F);
  const Eigen::MatrixXd LV = L * V;
  double max_rel = 0, max_angle = 0;
  for (int i = 0; i < V.rows(); ++i) {
    const Eigen::Vector3d hn = LV.row(i).transpose() / (2 * M(i));
    const Eigen::Vector3d n = V.row(i).normalized().transpose();
    max_rel = std::max(max_rel, std::abs(hn.dot(n) * r - 1.0));
    max_angle = std::max(max_angle, (hn - hn.dot(n) * n).norm() * r);
  }
  // Measured on this level-4 icosphere: normal part max |H r - 1| = 2e-13 (for vertices on
  // a sphere and non-obtuse triangles x_i.(L x)_i = 2 M_ii |x_i|^2 holds exactly), tangential
  // part max 4.2e-3 (relative to 1/r; 8.3e-3 at level 3, 2.1e-3 at level 5).
  EXPECT_LT(max_rel, 0.03);
  EXPECT_LT(max_angle, 0.01);
}

TEST(TetLaplacian, WeightsMatchDihedralAngleFormula) {
  std::mt19937 rng(5);
  std::uniform_real_distribution<double> U(-1, 1);
  const int E[6][2] = {{0, 1}, {0, 2}, {0, 3}, {1, 2}, {1, 3}, {2, 3}};
  for (int rep = 0; rep < 200; ++rep) {
    Eigen::MatrixXd V(4, 3);
    for (int i = 0; i < 4; ++i) V.row(i) << U(rng), U(rng), U(rng);
    Eigen::MatrixXi T(1, 4);
    T << 0, 1, 2, 3;
    const Eigen::Vector3d a = (V.row(1) - V.row(0)).transpose(), b = (V.row(2) - V.row(0)).transpose(),
                          c = (V.row(3) - V.row(0)).transpose();
    const double det = a.dot(b.cross(c));
    if (std::abs(det) < 1e-2) continue;
    const Eigen::MatrixXd W = tet_cotan_weights(V, T);
    for (int e = 0; e < 6; ++e) {
      const int i = E[e][0], j = E[e][1];
      int kl[2], q = 0;
      for (int v = 0; v < 4; ++v)
        if (v != i && v != j) kl[q++] = v;
      const Eigen::Vector3d pk = V.row(kl[0]), pl = V.row(kl[1]), pi = V.row(i), pj = V.row(j);
      const double theta = dihedral(pk, pl, pi, pj);
      const double expected = (pl - pk).norm() / std::tan(theta) / 6.0;
      EXPECT_NEAR(W(0, e), expected, 1e-9 * (1 + std::abs(expected)));
    }
    // Orientation does not matter: the inverted tet has the same weights.
    Eigen::MatrixXi Tinv(1, 4);
    Tinv << 0, 2, 1, 3;
    const Eigen::MatrixXd Winv = tet_cotan_weights(V, Tinv);
    // Edge (0,2) of Tinv is edge (0,1) of T, etc.
    const int map[6] = {1, 0, 2, 3, 5, 4};
    for (int e = 0; e < 6; ++e) EXPECT_NEAR(Winv(0, e), W(0, map[e]), 1e-12 * (1 + std::abs(W(0, map[e]))));
  }
}

TEST(TetLaplacian, CubeGridKernelHarmonicLinearAndFemStiffness) {
  Eigen::MatrixXd V;
  Eigen::MatrixXi T;
  std::vector<int> interior;
  tet_grid(4, 0.2, 13, V, T, &interior);
  ASSERT_GT(tet_volumes(V, T).minCoeff(), 0);
  const Eigen::SparseMatrix<double> L = tet_cotan_laplacian(V, T);
  const Eigen::MatrixXd Ld = Eigen::MatrixXd(L);
  EXPECT_LT((Ld - Ld.transpose()).cwiseAbs().maxCoeff(), 1e-13);
  EXPECT_LT((L * Eigen::VectorXd::Ones(V.rows())).cwiseAbs().maxCoeff(), 1e-12);
  const Eigen::VectorXd lin = 0.3 * V.col(0) - 2.0 * V.col(1) + 1.1 * V.col(2);
  const Eigen::VectorXd Llin = L * lin;
  for (int i : interior) EXPECT_NEAR(Llin(i), 0.0, 1e-12) << "vertex " << i;
  const Eigen::MatrixXd K = fem_stiffness(V, T);
  EXPECT_LT((Ld - K).cwiseAbs().maxCoeff(), 1e-12 * K.cwiseAbs().maxCoeff());
  // x^T L x = sum_t |vol_t| |grad x|^2 for a linear x: = volume * |a|^2.
  EXPECT_NEAR(lin.dot(L * lin), (0.09 + 4.0 + 1.21) * signed_volume(V, T), 1e-10);
}

TEST(TetLaplacian, AssemblyReusesPatternAndMatchesTriplets) {
  Eigen::MatrixXd V;
  Eigen::MatrixXi T;
  tet_grid(3, 0.1, 2, V, T);
  const int n = int(V.rows());
  std::mt19937 rng(9);
  std::uniform_real_distribution<double> U(-1, 1);
  const int E[6][2] = {{0, 1}, {0, 2}, {0, 3}, {1, 2}, {1, 3}, {2, 3}};
  Eigen::SparseMatrix<double> L;
  for (int rep = 0; rep < 3; ++rep) {
    Eigen::MatrixXd W(T.rows(), 6);
    for (int t = 0; t < W.rows(); ++t)
      for (int e = 0; e < 6; ++e) W(t, e) = U(rng);
    const double* pattern_before = rep > 0 ? L.valuePtr() : nullptr;
    assemble_tet_laplacian(T, W, n + 2, L);  // two isolated vertices at the end
    if (rep > 0) EXPECT_EQ(pattern_before, L.valuePtr()) << "pattern was rebuilt";
    std::vector<Eigen::Triplet<double>> trip;
    for (int t = 0; t < T.rows(); ++t)
      for (int e = 0; e < 6; ++e) {
        const int a = T(t, E[e][0]), b = T(t, E[e][1]);
        trip.emplace_back(a, b, -W(t, e));
        trip.emplace_back(b, a, -W(t, e));
        trip.emplace_back(a, a, W(t, e));
        trip.emplace_back(b, b, W(t, e));
      }
    Eigen::SparseMatrix<double> R(n + 2, n + 2);
    R.setFromTriplets(trip.begin(), trip.end());
    ASSERT_EQ(L.rows(), n + 2);
    EXPECT_LT((Eigen::MatrixXd(L) - Eigen::MatrixXd(R)).cwiseAbs().maxCoeff(), 1e-12);
    // Diagonal stored for every vertex (also isolated ones), so L + eps I factors.
    EXPECT_EQ(L.coeff(n + 1, n + 1), 0.0);
  }
  // A matrix with some other pattern is overwritten with the right one.
  Eigen::SparseMatrix<double> other(n, n);
  other.setIdentity();
  const Eigen::MatrixXd W = tet_cotan_weights(V, T);
  assemble_tet_laplacian(T, W, n, other);
  EXPECT_LT((Eigen::MatrixXd(other) - Eigen::MatrixXd(tet_cotan_laplacian(V, T))).cwiseAbs().maxCoeff(), 1e-14);
}

TEST(TetLaplacian, RejectsBadInput) {
  Eigen::MatrixXd V = Eigen::MatrixXd::Random(4, 3);
  Eigen::MatrixXi T(1, 4);
  T << 0, 1, 2, 4;
  EXPECT_THROW(tet_cotan_weights(V, T), std::runtime_error);
  Eigen::SparseMatrix<double> L;
  T << 0, 1, 2, 3;
  EXPECT_THROW(assemble_tet_laplacian(T, Eigen::MatrixXd::Zero(2, 6), 4, L), std::runtime_error);
}
