// Ball-shaped volume-preserving parameterization (isovolumetric-ball-parameterization.txt,
// Algorithm 1, Eq. 10) and its metrics (Eq. 45).
#include "ball_test_mesh.h"
#include "shapemap/error.h"
#include "shapemap/eval/ball_metrics.h"
#include "shapemap/volume/ball_param.h"
#include "shapemap/volume/sphere_param.h"
#include <gtest/gtest.h>
#include <omp.h>
#include <cmath>
#include <functional>
#include <numeric>
#include <random>

using namespace shapemap;
using namespace shapemap::testing_ball;

namespace {

// Splits the vertices of a mesh into interior and boundary index lists.
void split(const TetMesh& m, Eigen::VectorXi& interior, Eigen::VectorXi& boundary) {
  const TetBoundary tb = boundary_surface(m);
  boundary = tb.to_volume;
  std::vector<int> I;
  for (int i = 0; i < m.num_vertices(); ++i)
    if (tb.to_surface(i) < 0) I.push_back(i);
  interior = Eigen::Map<Eigen::VectorXi>(I.data(), Eigen::Index(I.size()));
}

// A small blob, its E_I, the interior/boundary split and a map f with the boundary on the
// unit sphere (interior rows left at the input positions).
struct SphericalSetup {
  TetMesh m;
  IsovolumetricEnergy E;
  Eigen::VectorXi I, B;
  Eigen::MatrixXd f;
};
SphericalSetup spherical_setup() {
  SphericalSetup s;
  s.m = blob_tets(3, Eigen::Vector3d(1.0, 0.8, 0.7), 0.1);
  s.E.build(s.m.V, s.m.T);
  split(s.m, s.I, s.B);
  s.f = s.m.V;
  for (int k = 0; k < s.B.size(); ++k) s.f.row(s.B(k)).normalize();
  return s;
}

// Max over variables i >= begin of |central difference of fun - g(i)| (step 1e-6); also
// returns max |g(i)| over them in gmax.
double max_fd_error(const std::function<double(const Eigen::VectorXd&)>& fun, const Eigen::VectorXd& x,
                    const Eigen::VectorXd& g, int begin, double& gmax) {
  const double h = 1e-6;
  double err = 0;
  gmax = 0;
  for (int i = begin; i < x.size(); ++i) {
    Eigen::VectorXd xp = x, xm = x;
    xp(i) += h;
    xm(i) -= h;
    err = std::max(err, std::abs((fun(xp) - fun(xm)) / (2 * h) - g(i)));
    gmax = std::max(gmax, std::abs(g(i)));
  }
  return err;
}

}  // namespace

TEST(BallParam, SphericalGradientMatchesFiniteDifferences) {
  SphericalSetup S = spherical_setup();
  const Eigen::VectorXi &I = S.I, &B = S.B;
  ASSERT_GT(I.size(), 0);
  SphericalBallEnergy sbe(S.E, I, B);
  // A point with the boundary on the sphere and a perturbed interior.
  Eigen::MatrixXd& f = S.f;
  for (int k = 0; k < I.size(); ++k) f.row(I(k)) *= 0.8;
  std::mt19937 rng(7);
  std::normal_distribution<double> N(0.0, 1.0);
  for (int frame = 0; frame < 2; ++frame) {
    if (frame == 1) {
      Eigen::Matrix3d Q = Eigen::AngleAxisd(0.9, Eigen::Vector3d(1, -1, 2).normalized()).toRotationMatrix();
      sbe.set_frame(Q);
    }
    Eigen::VectorXd x = sbe.from_map(f);
    for (int i = 0; i < x.size(); ++i) x(i) += 0.02 * N(rng);
    Eigen::VectorXd g;
    const double e0 = sbe.energy_and_gradient(x, g);
    EXPECT_NEAR(e0, sbe.energy(x), 1e-14);
    // Every variable: f_I blocks, theta and phi (Eqs. 10a-10c).
    double gmax = 0;
    const double err = max_fd_error([&](const Eigen::VectorXd& y) { return sbe.energy(y); }, x, g, 0, gmax);
    EXPECT_LT(err, 1e-7 * std::max(1.0, gmax)) << "frame " << frame;
    // Round trip x -> f -> x keeps the map (angles may differ by 2 pi).
    Eigen::MatrixXd f1, f2;
    sbe.to_map(x, f1);
    sbe.to_map(sbe.from_map(f1), f2);
    EXPECT_LT((f1 - f2).cwiseAbs().maxCoeff(), 1e-12);
  }
}

// The fold penalty of the post-step (SphericalBallEnergy::set_fold_penalty) on a map with
// inverted and thin tets: value against a brute-force sum, gradient against central
// differences in every variable.
TEST(BallParam, FoldPenaltyGradientMatchesFiniteDifferences) {
  SphericalSetup S = spherical_setup();
  const IsovolumetricEnergy& E = S.E;
  const Eigen::VectorXi &I = S.I, &B = S.B;
  ASSERT_GT(I.size(), 0);
  SphericalBallEnergy sbe(E, I, B);
  Eigen::MatrixXd& f = S.f;
  std::mt19937 rng(11);
  std::normal_distribution<double> N(0.0, 1.0);
  for (int k = 0; k < I.size(); ++k) f.row(I(k)) = 0.8 * f.row(I(k)) + 0.25 * Eigen::RowVector3d(N(rng), N(rng), N(rng));
  const double mu = 3.0, floor = 0.5;
  Eigen::VectorXd x = sbe.from_map(f);
  // Move the boundary too, so that some boundary faces fall below the floor.
  for (int i = 3 * int(I.size()); i < x.size(); ++i) x(i) += 0.15 * N(rng);
  Eigen::MatrixXd fx;
  sbe.to_map(x, fx);
  // Brute force: sum over tets below the floor.
  Eigen::VectorXd vol;
  E.image_volumes(fx, vol);
  const double scale = floor * (4.0 * M_PI / 3.0) / E.domain_volume();
  double P = 0;
  int below = 0, inverted = 0;
  for (int t = 0; t < vol.size(); ++t) {
    const double gap = scale * E.domain_volumes()(t) - vol(t);
    if (gap > 0) {
      P += mu * gap * gap / E.domain_volumes()(t);
      ++below;
    }
    inverted += vol(t) <= 0;
  }
  ASSERT_GT(inverted, 0);            // the test map has folds ...
  ASSERT_LT(below, int(vol.size()));  // ... and tets above the floor
  // Boundary faces (every other one) with their orientation term.
  const Eigen::MatrixXi& Fb = E.boundary_faces();
  std::vector<int> faces;
  const double target = 2.0 * 4.0 * M_PI / double(Fb.rows());
  int faces_below = 0;
  for (int q = 0; q < Fb.rows(); q += 2) {
    faces.push_back(q);
    const Eigen::Vector3d a = fx.row(Fb(q, 0)), b = fx.row(Fb(q, 1)), c = fx.row(Fb(q, 2));
    const double gap = floor * target - a.dot(b.cross(c));
    if (gap > 0) {
      P += mu * gap * gap / target;
      ++faces_below;
    }
  }
  ASSERT_GT(faces_below, 0);
  ASSERT_LT(faces_below, int(faces.size()));
  EXPECT_NEAR(sbe.energy(x) + 0.0, E.energy(fx), 1e-12);  // mu = 0: plain E_I
  sbe.set_fold_penalty(mu, floor, faces);
  EXPECT_NEAR(sbe.fold_penalty(fx, nullptr), P, 1e-12 * std::max(1.0, P));
  EXPECT_NEAR(sbe.energy(x), E.energy(fx) + P, 1e-12 * std::max(1.0, P));
  Eigen::VectorXd g;
  const double e0 = sbe.energy_and_gradient(x, g);
  EXPECT_NEAR(e0, sbe.energy(x), 1e-12 * std::max(1.0, e0));
  double gmax = 0;
  const double err = max_fd_error([&](const Eigen::VectorXd& y) { return sbe.energy(y); }, x, g, 0, gmax);
  EXPECT_LT(err, 1e-6 * std::max(1.0, gmax));
  // The boundary-face term alone (it is small next to the folded tets' term): difference of
  // the energies with and without the faces.
  SphericalBallEnergy no_faces(E, I, B);
  no_faces.set_fold_penalty(mu, floor);
  Eigen::VectorXd g0;
  no_faces.energy_and_gradient(x, g0);
  const Eigen::VectorXd d = g - g0;
  double dmax = 0;
  const double derr = max_fd_error([&](const Eigen::VectorXd& y) { return sbe.energy(y) - no_faces.energy(y); },
                                   x, d, 3 * int(I.size()), dmax);
  EXPECT_GT(d.cwiseAbs().maxCoeff(), 0.0);
  EXPECT_LT(derr, 1e-6 * std::max(1e-3, d.cwiseAbs().maxCoeff()));
}

TEST(BallParam, PoleAvoidingFrameKeepsPolesEmpty) {
  const TetMesh m = blob_tets(6, Eigen::Vector3d(1, 1, 1), 0.0);
  const TetBoundary tb = boundary_surface(m);
  Eigen::MatrixXd Y = tb.surface.V.rowwise().normalized();
  const Eigen::Matrix3d Q = pole_avoiding_frame(Y, tb.surface.F);
  EXPECT_NEAR(Q.determinant(), 1.0, 1e-12);
  EXPECT_LT((Q * Q.transpose() - Eigen::Matrix3d::Identity()).norm(), 1e-12);
  const Eigen::Vector3d pole = Q.row(2).transpose();
  double smin = 1;
  for (int b = 0; b < Y.rows(); ++b)
    smin = std::min(smin, std::sqrt(std::max(0.0, 1 - std::pow(pole.dot(Y.row(b).transpose()), 2))));
  // The cube-sphere grid has vertices exactly at +-z; the chosen poles avoid all vertices
  // by a sizeable fraction of the mean edge angle (2/6 of a quarter circle ~ 0.26 rad).
  EXPECT_GT(smin, 0.05);
}

TEST(BallParam, SphericalAreaPreservingMapIsBijectiveAndEquiareal) {
  const TetMesh m = blob_tets(8, Eigen::Vector3d(1.0, 0.7, 0.5), 0.15);
  const TriMesh s = boundary_surface(m).surface;
  const SphereParamResult r = spherical_area_preserving_map(s);
  EXPECT_EQ(r.folded_faces, 0);
  EXPECT_LT((r.S.rowwise().norm().array() - 1.0).abs().maxCoeff(), 1e-12);
  EXPECT_GT(r.conformal_iterations + r.stretch_iterations, 0);
  EXPECT_LT(r.stretch_energy, r.stretch_energy_initial);
  // Area shares: the mean relative deviation of the image area shares is small.
  const Eigen::VectorXd a = triangle_areas(s.V, s.F), b = triangle_areas(r.S, s.F);
  double dev = 0;
  for (int f = 0; f < a.size(); ++f) dev += std::abs((b(f) / b.sum()) / (a(f) / a.sum()) - 1.0);
  dev /= double(a.size());
  EXPECT_LT(dev, 0.15);  // measured ~0.04 on this mesh
}

TEST(BallParam, EndToEndOnGeneratedBlob) {
  const TetMesh m = blob_tets(10, Eigen::Vector3d(1.0, 0.7, 0.5), 0.15);  // 1331 v, 6000 t
  const BallParamResult r = ball_parameterization(m);
  const BallMetrics b = ball_metrics(m, r.f);
  const BallMetrics v = ball_metrics(m, r.f_vsem);
  EXPECT_EQ(b.folded_tets, 0);
  EXPECT_EQ(b.negative_tets, 0);
  EXPECT_LE(b.boundary_sphere_error, 1e-9);
  EXPECT_LE(b.max_radius, 1.0 + 1e-9);
  // Measured: mean D_V 3.0e-3 after CG (VSEM: 1.6e-2); E_I 5.5e-5 (VSEM: 1.2e-3).
  EXPECT_LT(b.dv_mean, 1e-2);
  EXPECT_LT(b.dv_p95, 3e-2);
  EXPECT_NEAR(r.energy_vsem, v.energy, 1e-9 * std::max(1.0, v.energy));
  EXPECT_NEAR(r.energy_final, b.energy, 1e-9);
  EXPECT_LE(r.energy_final, 0.5 * r.energy_vsem);
  EXPECT_LT(b.dv_mean, v.dv_mean);
  EXPECT_GT(r.iterations, 0);
  EXPECT_EQ(int(r.energies.size()), r.iterations);
  for (size_t k = 1; k < r.energies.size(); ++k) EXPECT_LE(r.energies[k], r.energies[k - 1]);
}

TEST(BallParam, DeterministicAcrossThreadCounts) {
  // 6000 tets: above the serial threshold of the element loops, so 2 threads run in parallel.
  const TetMesh m = blob_tets(10, Eigen::Vector3d(1.0, 0.8, 0.6), 0.2);
  BallParamOptions o;
  o.max_iterations = 15;
  const int saved = omp_get_max_threads();
  omp_set_num_threads(1);
  const BallParamResult a = ball_parameterization(m, o);
  omp_set_num_threads(2);
  const BallParamResult b = ball_parameterization(m, o);
  omp_set_num_threads(saved);
  EXPECT_EQ(a.iterations, b.iterations);
  EXPECT_EQ((a.f - b.f).cwiseAbs().maxCoeff(), 0.0);
}

TEST(BallParam, PaperVariantWithoutPoleHandlingStillRuns) {
  const TetMesh m = blob_tets(6, Eigen::Vector3d(1.0, 0.8, 0.6), 0.1);
  BallParamOptions o;
  o.rotate_frame = false;
  o.metric_phi_preconditioner = false;
  o.anisotropic_scaling = false;
  const BallParamResult r = ball_parameterization(m, o);
  const BallMetrics b = ball_metrics(m, r.f);
  EXPECT_LE(b.boundary_sphere_error, 1e-9);
  // CG in the paper's fixed frame still does its job: E_I well below the VSEM start (CG
  // never raises E_I, so only a real decrease is worth asserting), no folded tet.
  EXPECT_LT(r.energy_final, 0.5 * r.energy_vsem);
  EXPECT_EQ(b.folded_tets, 0);
}

TEST(BallParam, PoleGuardDoesNotDependOnThePhiPreconditionerBlock) {
  // The pole guard compares the smallest sin(theta) with its value at the last frame
  // choice; with the phi block S L_BB S switched off it once compared with 1 instead and
  // re-chose the frame (restarting CG) almost every iteration.
  const TetMesh m = blob_tets(8, Eigen::Vector3d(1.0, 0.8, 0.6), 0.1);
  BallParamOptions o;
  o.max_iterations = 60;
  o.tolerance = 0;
  const BallParamResult a = ball_parameterization(m, o);
  o.metric_phi_preconditioner = false;
  const BallParamResult b = ball_parameterization(m, o);
  EXPECT_LE(b.frame_rotations, a.frame_rotations + 3);
  EXPECT_LE(b.restarts, a.restarts + 5);
}

TEST(BallParam, RejectsNonBallInput) {
  for (int which = 0; which < 2; ++which) {
    const TetMesh m = which == 0 ? two_cubes(2) : hollow_cube(4);
    try {
      ball_parameterization(m, {}, {}, "blob.vtk");
      ADD_FAILURE() << "no InputError for case " << which;
    } catch (const InputError& e) {
      const std::string msg = e.what();
      EXPECT_EQ(msg.rfind("blob.vtk: ", 0), 0u) << msg;
      EXPECT_EQ(msg.find('\n'), std::string::npos);
    }
  }
}

TEST(BallMetricsTest, DistortionFoldsAndSphereError) {
  const TetMesh m = blob_tets(3, Eigen::Vector3d(1.0, 0.9, 0.8), 0.0);
  // A uniform scaling is volume-preserving: D_V = 0 everywhere, E_I = 0.
  const BallMetrics s = ball_metrics(m, 0.5 * m.V);
  EXPECT_LT(s.dv_max, 1e-12);
  EXPECT_NEAR(s.energy, 0.0, 1e-12);
  EXPECT_EQ(s.folded_tets, 0);
  // A mirror flips every tet: the smaller count (positive) is 0 foldings.
  Eigen::MatrixXd mir = m.V;
  mir.col(0) *= -1;
  const BallMetrics r = ball_metrics(m, mir);
  EXPECT_EQ(r.negative_tets, m.num_tets());
  EXPECT_EQ(r.folded_tets, 0);
  // D_V against closed-form values: tests/eval/test_metrics_closed_form.cpp.
  // Boundary vertices of the cube-sphere blob with radii ~1 are off the sphere.
  EXPECT_GT(s.boundary_sphere_error, 0.1);
  // Flipped boundary faces: none for the blob (star-shaped about the origin) and its mirror
  // image; sending one boundary vertex to its antipode flips some of its faces, never others.
  EXPECT_EQ(s.flipped_boundary_faces, 0);
  EXPECT_EQ(r.flipped_boundary_faces, 0);
  const TetBoundary tb = boundary_surface(m);
  const int v = tb.to_volume(0);
  int star = 0;
  for (Eigen::Index q = 0; q < tb.surface.F.rows(); ++q)
    star += (tb.surface.F.row(q).array() == 0).any();
  Eigen::MatrixXd a = m.V;
  a.row(v) = -m.V.row(v);
  const BallMetrics w = ball_metrics(m, a);
  EXPECT_GT(w.flipped_boundary_faces, 0);
  EXPECT_LE(w.flipped_boundary_faces, star);
  // Coverage of the ball: the half-size blob is covered once, the rest of the ball not at
  // all (uncovered share ~ 1 - blob volume / ball volume); pulling one interior vertex
  // through its neighbours makes image tets overlap.
  double over = 0, none = 0;
  int ns = 0;
  const Eigen::MatrixXd half = 0.5 * m.V;
  ball_coverage(half, m.T, 20000, over, none, ns);
  EXPECT_GT(ns, 15000);
  EXPECT_EQ(over, 0.0);
  const double blob = 0.125 * tet_volumes(m.V, m.T).sum() / (4.0 * M_PI / 3.0);
  EXPECT_NEAR(none, 1.0 - blob, 0.02);
  EXPECT_NEAR(s.overlap_fraction, 0.0, 0.0);
  int inner = -1;
  for (int i = 0; i < m.num_vertices(); ++i)
    if (tb.to_surface(i) < 0 && (inner < 0 || m.V.row(i).norm() < m.V.row(inner).norm())) inner = i;
  ASSERT_GE(inner, 0);
  Eigen::MatrixXd pulled = half;
  pulled(inner, 0) += 0.3;
  ball_coverage(pulled, m.T, 20000, over, none, ns);
  EXPECT_GT(over, 0.0);
}
