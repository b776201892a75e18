// Möbius transformations and stereographic projection (BIM Sec. 4) against exact
// references.
#include "shapemap/surface/mobius.h"
#include <gtest/gtest.h>
#include <random>

using namespace shapemap;

namespace {
Complex rnd(std::mt19937& g) {
  std::normal_distribution<double> N(0, 2);
  return Complex(N(g), N(g));
}
}  // namespace

TEST(BimMobius, ThroughThreePointsExact) {
  std::mt19937 g(3);
  for (int trial = 0; trial < 200; ++trial) {
    Complex z[3], w[3];
    for (int k = 0; k < 3; ++k) z[k] = rnd(g), w[k] = rnd(g);
    Mobius m = Mobius::from_three_points(z, w);
    EXPECT_NEAR(std::abs(m.a * m.d - m.b * m.c - 1.0), 0.0, 1e-10);
    for (int k = 0; k < 3; ++k) EXPECT_LT(std::abs(m(z[k]) - w[k]), 1e-9 * (1 + std::abs(w[k])));
    // Inverse and composition.
    Mobius id = m.inverse() * m;
    Complex p = rnd(g);
    EXPECT_LT(std::abs(id(p) - p), 1e-9 * (1 + std::abs(p)));
    EXPECT_LT(std::abs(m.inverse()(m(p)) - p), 1e-9 * (1 + std::abs(p)));
  }
}

TEST(BimMobius, PointsAtInfinity) {
  // z -> 1/z sends 0 -> ∞, ∞ -> 0, 1 -> 1.
  Homogeneous z[3], w[3];
  z[0] = {0.0, 1.0};
  z[1] = {1.0, 0.0};
  z[2] = {1.0, 1.0};
  w[0] = {1.0, 0.0};
  w[1] = {0.0, 1.0};
  w[2] = {1.0, 1.0};
  Mobius m = Mobius::from_three_points(z, w);
  Complex p(0.3, -0.7);
  EXPECT_LT(std::abs(m(p) - 1.0 / p), 1e-12);
  Eigen::Vector3d north = sphere_from_plane(m(z[0]));
  EXPECT_NEAR(north.z(), 1.0, 1e-12);
}

TEST(BimMobius, StereographicRoundTrip) {
  std::mt19937 g(5);
  std::normal_distribution<double> N(0, 1);
  for (int i = 0; i < 100; ++i) {
    Eigen::Vector3d x(N(g), N(g), N(g));
    x.normalize();
    Eigen::Vector3d y = sphere_from_plane(plane_from_sphere(x));
    EXPECT_LT((x - y).norm(), 1e-12);
  }
  Homogeneous zero;
  EXPECT_NEAR(sphere_from_plane(zero).z(), -1.0, 1e-15);
}

TEST(BimMobius, SphereAreaFactorMatchesFiniteDifferences) {
  std::mt19937 g(7);
  std::normal_distribution<double> N(0, 1);
  for (int trial = 0; trial < 20; ++trial) {
    Complex z[3], w[3];
    for (int k = 0; k < 3; ++k) z[k] = rnd(g), w[k] = rnd(g);
    Mobius m = Mobius::from_three_points(z, w);
    Eigen::Vector3d x(N(g), N(g), N(g));
    x.normalize();
    // A small spherical triangle around x and its image.
    Eigen::Vector3d t1 = x.unitOrthogonal(), t2 = x.cross(t1);
    const double h = 1e-4;
    Eigen::Vector3d a = x, b = (x + h * t1).normalized(), c = (x + h * t2).normalized();
    double A0 = (b - a).cross(c - a).norm();
    Eigen::Vector3d ma = m.apply_sphere(a), mb = m.apply_sphere(b), mc = m.apply_sphere(c);
    double A1 = (mb - ma).cross(mc - ma).norm();
    double J = m.sphere_area_factor(plane_from_sphere(x));
    EXPECT_NEAR(A1 / A0, J, 2e-3 * J);
  }
}
