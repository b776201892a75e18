// Signed SVD: reconstruction, rotations, ordering and sign rules on many random cases.
#include "shapemap/geometry/svd3.h"
#include "geometry/fixtures.h"
#include <Eigen/Dense>
#include <gtest/gtest.h>
#include <cmath>
#include <random>

using namespace shapemap;
using shapemap::testing::random_rotation;

namespace {

// Checks every property of the convention; `scale` is a norm of A.
void check(const Eigen::Matrix3d& A, const SignedSVD3& r, const char* what, int rep) {
  const double scale = std::max(A.norm(), 1e-300);
  SCOPED_TRACE(::testing::Message() << what << " #" << rep << "\nA=\n" << A << "\nS=" << r.S.transpose());
  EXPECT_LE((r.U * r.S.asDiagonal() * r.V.transpose() - A).norm(), 1e-13 * scale);
  EXPECT_LE((r.U.transpose() * r.U - Eigen::Matrix3d::Identity()).norm(), 1e-13);
  EXPECT_LE((r.V.transpose() * r.V - Eigen::Matrix3d::Identity()).norm(), 1e-13);
  EXPECT_NEAR(r.U.determinant(), 1.0, 1e-12);
  EXPECT_NEAR(r.V.determinant(), 1.0, 1e-12);
  EXPECT_GE(r.S(0), r.S(1));
  EXPECT_GE(r.S(1), std::abs(r.S(2)));
  EXPECT_GE(r.S(1), 0.0);
  // The sign rule, whenever det(A) is reliably nonzero.
  const double det = A.determinant();
  if (std::abs(det) > 1e-10 * scale * scale * scale) EXPECT_EQ(det > 0, r.S(2) > 0);
  // Magnitudes equal the ordinary singular values.
  const Eigen::Vector3d s = A.jacobiSvd().singularValues();
  EXPECT_LE((r.S.cwiseAbs() - s).norm(), 1e-13 * scale);
}

}  // namespace

TEST(SignedSVD3, ThousandsOfRandomCases) {
  std::mt19937 rng(12345);
  std::normal_distribution<double> N;
  std::uniform_real_distribution<double> U(0, 1);
  for (int rep = 0; rep < 2000; ++rep) {
    Eigen::Matrix3d A;
    for (int i = 0; i < 9; ++i) A(i) = N(rng);
    check(A, signed_svd3(A), "random", rep);
    // Reflected (det < 0).
    Eigen::Matrix3d B = A;
    if (B.determinant() > 0) B.row(0) = -B.row(0);
    const SignedSVD3 rb = signed_svd3(B);
    check(B, rb, "reflected", rep);
    EXPECT_LT(rb.S(2), 0);
  }
}

TEST(SignedSVD3, StructuredAndDegenerateCases) {
  std::mt19937 rng(777);
  std::uniform_real_distribution<double> U(0.1, 2.0);
  for (int rep = 0; rep < 1000; ++rep) {
    const Eigen::Matrix3d P = random_rotation(rng), Q = random_rotation(rng);
    const double a = U(rng), b = U(rng), c = U(rng);
    const Eigen::Matrix3d cases[] = {
        P * Eigen::Vector3d(a, b, 0).asDiagonal() * Q.transpose(),          // rank 2
        P * Eigen::Vector3d(a, 0, 0).asDiagonal() * Q.transpose(),          // rank 1
        P * Eigen::Vector3d(a, a, a).asDiagonal() * Q.transpose(),          // repeated
        P * Eigen::Vector3d(a, a, -a).asDiagonal() * Q.transpose(),         // repeated, inverted
        P * Eigen::Vector3d(a, b, -1e-9 * c).asDiagonal() * Q.transpose(),  // barely inverted
        P * Eigen::Vector3d(a, b, c).asDiagonal() * Q.transpose() * 1e-150, // tiny
        P * Eigen::Vector3d(a, b, -c).asDiagonal() * Q.transpose() * 1e150, // huge, inverted
        P,                                                                  // rotation
        -P,                                                                 // reflection
        P * Eigen::Vector3d(a, 1e-8 * b, -1e-16 * c).asDiagonal() * Q.transpose(),  // graded
        P * Eigen::Vector3d(a, a * (1 + 1e-9), -b).asDiagonal() * Q.transpose(),    // near-repeated
        P * Eigen::Vector3d(a, 1e-8 * a, 1e-8 * a * (1 + 1e-8)).asDiagonal() * Q.transpose(),
    };
    const char* names[] = {"rank2", "rank1", "repeated", "repeated-inverted", "barely-inverted",
                           "tiny", "huge", "rotation", "reflection", "graded", "near-repeated",
                           "small-pair"};
    for (int k = 0; k < 12; ++k) check(cases[k], signed_svd3(cases[k]), names[k], rep);
    // Rotations: S = (1,1,1) and U V^T = the rotation.
    const SignedSVD3 r = signed_svd3(P);
    EXPECT_LT((r.S - Eigen::Vector3d::Ones()).norm(), 1e-13);
    EXPECT_LT((r.U * r.V.transpose() - P).norm(), 1e-13);
    const SignedSVD3 m = signed_svd3(-P);
    EXPECT_NEAR(m.S(2), -1.0, 1e-13);
  }
  const SignedSVD3 z = signed_svd3(Eigen::Matrix3d::Zero());
  EXPECT_EQ(z.S.norm(), 0.0);
  EXPECT_NEAR(z.U.determinant(), 1.0, 1e-14);
  EXPECT_NEAR(z.V.determinant(), 1.0, 1e-14);
  const Eigen::Matrix3d denormal = Eigen::Matrix3d::Identity() * 1e-310;
  check(denormal, signed_svd3(denormal), "denormal", 0);
}

TEST(SignedSVD3, BatchMatchesSingle) {
  std::mt19937 rng(1);
  std::normal_distribution<double> N;
  std::vector<Eigen::Matrix3d> A(500);
  for (auto& a : A)
    for (int i = 0; i < 9; ++i) a(i) = N(rng);
  std::vector<SignedSVD3> out;
  signed_svd3_batch(A, out);
  ASSERT_EQ(out.size(), A.size());
  for (size_t i = 0; i < A.size(); ++i) {
    const SignedSVD3 r = signed_svd3(A[i]);
    EXPECT_EQ(r.S, out[i].S);
    EXPECT_EQ(r.U, out[i].U);
    EXPECT_EQ(r.V, out[i].V);
  }
}
