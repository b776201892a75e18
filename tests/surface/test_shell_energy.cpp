// Thin-shell energy of elastic correspondence (Eq. 2, 7, 9): zero at the identity and
// rigid motions, exact gradients (finite differences), in the linear-extension region,
// on inverted and collapsed triangles, and with masked edges.
#include "shapemap/surface/shell_energy.h"

#include <Eigen/Geometry>
#include <gtest/gtest.h>
#include <omp.h>
#include <cmath>
#include <map>
#include <random>

using namespace shapemap;

namespace {

// A closed octahedron-like bumpy sphere: subdivided icosahedron, radius perturbed.
void test_sphere(Eigen::MatrixXd& V, Eigen::MatrixXi& F, int subdiv = 1) {
  const double t = (1.0 + std::sqrt(5.0)) / 2.0;
  V.resize(12, 3);
  V << -1, t, 0, 1, t, 0, -1, -t, 0, 1, -t, 0, 0, -1, t, 0, 1, t, 0, -1, -t, 0, 1, -t, t, 0, -1, t, 0,
      1, -t, 0, -1, -t, 0, 1;
  F.resize(20, 3);
  F << 0, 11, 5, 0, 5, 1, 0, 1, 7, 0, 7, 10, 0, 10, 11, 1, 5, 9, 5, 11, 4, 11, 10, 2, 10, 7, 6, 7, 1,
      8, 3, 9, 4, 3, 4, 2, 3, 2, 6, 3, 6, 8, 3, 8, 9, 4, 9, 5, 2, 4, 11, 6, 2, 10, 8, 6, 7, 9, 8, 1;
  for (int s = 0; s < subdiv; ++s) {
    std::map<std::pair<int, int>, int> mid;
    std::vector<Eigen::RowVector3d> verts;
    for (int i = 0; i < V.rows(); ++i) verts.push_back(V.row(i));
    auto midpoint = [&](int a, int b) {
      auto key = std::make_pair(std::min(a, b), std::max(a, b));
      auto it = mid.find(key);
      if (it != mid.end()) return it->second;
      verts.push_back(0.5 * (verts[a] + verts[b]));
      mid[key] = int(verts.size()) - 1;
      return int(verts.size()) - 1;
    };
    Eigen::MatrixXi F2(4 * F.rows(), 3);
    for (int f = 0; f < F.rows(); ++f) {
      int a = F(f, 0), b = F(f, 1), c = F(f, 2);
      int ab = midpoint(a, b), bc = midpoint(b, c), ca = midpoint(c, a);
      F2.row(4 * f) << a, ab, ca;
      F2.row(4 * f + 1) << b, bc, ab;
      F2.row(4 * f + 2) << c, ca, bc;
      F2.row(4 * f + 3) << ab, bc, ca;
    }
    F = F2;
    V.resize(verts.size(), 3);
    for (size_t i = 0; i < verts.size(); ++i) V.row(i) = verts[i];
  }
  for (int i = 0; i < V.rows(); ++i) {
    const double r = 1.0 + 0.15 * std::sin(3 * V(i, 0)) * std::cos(2 * V(i, 1));
    V.row(i) = V.row(i).normalized() * r;
  }
}

// Central finite-difference check of the gradient at Y, on all coordinates.
// Vertices flagged in `skip` are not perturbed.
void check_gradient(const ShellEnergy& W, const Eigen::MatrixXd& Y, double rel_tol,
                    double h = 1e-6, const std::vector<char>& skip = {}) {
  Eigen::MatrixXd G;
  W.evaluate(Y, &G);
  double max_err = 0, max_g = 0;
  for (int i = 0; i < Y.rows(); ++i)
    for (int k = 0; k < 3; ++k) {
      if (!skip.empty() && skip[i]) continue;
      Eigen::MatrixXd Yp = Y, Ym = Y;
      Yp(i, k) += h;
      Ym(i, k) -= h;
      const double fd = (W.evaluate(Yp) - W.evaluate(Ym)) / (2 * h);
      max_err = std::max(max_err, std::abs(fd - G(i, k)));
      max_g = std::max(max_g, std::abs(G(i, k)));
    }
  EXPECT_LT(max_err, rel_tol * std::max(1.0, max_g)) << "max |g| = " << max_g;
}

}  // namespace

TEST(ShellEnergy, DensityZeroAndStationaryAtIdentity) {
  double Wt, Wd;
  const double W = membrane_density(2.0, 1.0, 1.0, 1.0, 1e-4, &Wt, &Wd);
  EXPECT_NEAR(W, 0.0, 1e-14);
  // dW/dA = Wt I + Wd det(A) A^{-T} = (Wt + Wd) I at A = I.
  EXPECT_NEAR(Wt + Wd, 0.0, 1e-14);
  // C^1 at eps: values and slopes agree from both sides.
  const double eps = 1e-3;
  double d1, d2;
  const double a = membrane_density(2.0, eps * (1 - 1e-12), 1, 1, eps, nullptr, &d1);
  const double b = membrane_density(2.0, eps * (1 + 1e-12), 1, 1, eps, nullptr, &d2);
  EXPECT_NEAR(a, b, 1e-9);
  EXPECT_NEAR(d1, d2, 1e-6 * std::abs(d1));
  // finite below eps and at d <= 0
  EXPECT_TRUE(std::isfinite(membrane_density(2.0, 0.0, 1, 1, eps)));
  EXPECT_TRUE(std::isfinite(membrane_density(0.0, -1.0, 1, 1, eps)));
}

TEST(ShellEnergy, ZeroAtIdentityAndRigidMotion) {
  Eigen::MatrixXd V;
  Eigen::MatrixXi F;
  test_sphere(V, F);
  ShellEnergy W(V, F);
  ShellEnergyTerms t;
  Eigen::MatrixXd G;
  EXPECT_NEAR(W.evaluate(V, &G, &t), 0.0, 1e-12);
  EXPECT_LT(G.cwiseAbs().maxCoeff(), 1e-10);
  EXPECT_EQ(t.admissible_edges, W.num_edges());
  EXPECT_EQ(W.num_edges(), 3 * F.rows() / 2);
  Eigen::Matrix3d R = Eigen::AngleAxisd(0.7, Eigen::Vector3d(1, 2, 3).normalized()).toRotationMatrix();
  Eigen::MatrixXd Y = (V * R.transpose()).rowwise() + Eigen::RowVector3d(0.3, -1, 2);
  EXPECT_NEAR(W.evaluate(Y), 0.0, 1e-10);
  // a mirror image has the same fundamental forms and the same cosines: zero too
  Eigen::MatrixXd Ym = V;
  Ym.col(0) *= -1;
  EXPECT_NEAR(W.evaluate(Ym), 0.0, 1e-10);
  // a scaled copy costs membrane energy but no bending energy
  W.evaluate(1.3 * V, nullptr, &t);
  EXPECT_GT(t.membrane, 1e-3);
  EXPECT_NEAR(t.bending, 0.0, 1e-10);
}

TEST(ShellEnergy, GradientGeneric) {
  Eigen::MatrixXd V;
  Eigen::MatrixXi F;
  test_sphere(V, F);
  std::mt19937 rng(3);
  std::normal_distribution<double> N(0, 0.05);
  Eigen::MatrixXd Y = V;
  for (int i = 0; i < Y.size(); ++i) Y(i) += N(rng);
  for (double eta : {0.0, 0.1, 10.0}) {
    ShellEnergyOptions o;
    o.eta = eta;
    ShellEnergy W(V, F, o);
    check_gradient(W, Y, 1e-5);
  }
  // membrane only / bending only
  ShellEnergyOptions o;
  o.alpha = 0;
  o.eta = 1;
  check_gradient(ShellEnergy(V, F, o), Y, 1e-5);
}

TEST(ShellEnergy, GradientLinearExtensionAndInvertedTriangles) {
  Eigen::MatrixXd V;
  Eigen::MatrixXi F;
  test_sphere(V, F);
  ShellEnergyOptions o;
  o.log_eps = 0.05;  // large eps: many triangles in the linear region
  ShellEnergy W(V, F, o);
  // strongly compressed configuration: most triangles have det G < eps
  Eigen::MatrixXd Y = 0.15 * V;
  std::mt19937 rng(5);
  std::normal_distribution<double> N(0, 0.01);
  for (int i = 0; i < Y.size(); ++i) Y(i) += N(rng);
  check_gradient(W, Y, 1e-5, 1e-7);
  // invert some triangles by flattening and folding: push a band of vertices through
  Eigen::MatrixXd Z = V;
  for (int i = 0; i < Z.rows(); ++i)
    if (Z(i, 2) > 0.2) Z(i, 2) = 0.2 - 1.5 * (Z(i, 2) - 0.2);
  for (int i = 0; i < Z.size(); ++i) Z(i) += 0.2 * N(rng);
  check_gradient(W, Z, 1e-5, 1e-7);
  ShellEnergy W2(V, F);  // default eps
  check_gradient(W2, Z, 1e-5, 1e-7);
}

TEST(ShellEnergy, CollapsedTrianglesAreFiniteAndMasked) {
  Eigen::MatrixXd V;
  Eigen::MatrixXi F;
  test_sphere(V, F);
  ShellEnergy W(V, F);
  // collapse face 0 to a point and face 5 to a segment
  Eigen::MatrixXd Y = V;
  const Eigen::RowVector3d c = Y.row(F(0, 0));
  for (int j = 0; j < 3; ++j) Y.row(F(0, j)) = c;
  Y.row(F(5, 2)) = 0.5 * (Y.row(F(5, 0)) + Y.row(F(5, 1)));
  ShellEnergyTerms t;
  Eigen::MatrixXd G;
  const double E = W.evaluate(Y, &G, &t);
  EXPECT_TRUE(std::isfinite(E));
  EXPECT_TRUE(G.allFinite());
  EXPECT_GE(t.degenerate_faces, 2);
  EXPECT_LT(t.admissible_edges, W.num_edges());
  // everything collapsed to one point
  Eigen::MatrixXd Z = Eigen::MatrixXd::Zero(V.rows(), 3);
  const double E0 = W.evaluate(Z, &G, &t);
  EXPECT_TRUE(std::isfinite(E0));
  EXPECT_TRUE(G.allFinite());
  EXPECT_EQ(t.admissible_edges, 0);
  // The mask is a discontinuity (Sec. 5.2); perturbing a vertex of a collapsed face can
  // unmask it. Away from it (other vertices) the gradient is exact.
  std::vector<char> skip(V.rows(), 0);
  for (int f : {0, 5})
    for (int j = 0; j < 3; ++j) skip[F(f, j)] = 1;
  check_gradient(W, Y, 1e-5, 1e-7, skip);
}

TEST(ShellEnergy, BendingPenalizesFolding) {
  // Two triangles sharing an edge: folding costs (cos th^ - cos th)^2 l^2/d^.
  Eigen::MatrixXd V(4, 3);
  V << 0, 0, 0, 1, 0, 0, 0, 1, 0, 1, 1, 0;
  Eigen::MatrixXi F(2, 3);
  F << 0, 1, 2, 2, 1, 3;
  ShellEnergyOptions o;
  o.alpha = 0;
  o.eta = 1;
  ShellEnergy W(V, F, o);
  ASSERT_EQ(W.num_edges(), 1);
  Eigen::MatrixXd Y = V;
  Y(3, 2) = 1.0;  // fold: right triangle now at some angle
  // reference cos = 1; deformed normals n0 = (0,0,1), n1 of (2,1,3)
  Eigen::Vector3d a = Y.row(2), b = Y.row(1), c = Y.row(3);
  Eigen::Vector3d n1 = (b - a).cross(c - a).normalized();
  const double cosd = n1.z();
  const double l2 = 2.0, d = (0.5 + 0.5) / 3.0;
  EXPECT_NEAR(W.evaluate(Y), (1 - cosd) * (1 - cosd) * l2 / d, 1e-12);
  check_gradient(W, Y, 1e-6);
}

// The serial path (default below ShellEnergyOptions::parallel_min_faces) and the parallel
// path (forced) give bitwise identical energies and gradients for 1 and 2 threads, with the
// mask recomputed and frozen; the gradient is checked by finite differences on a sample of
// coordinates of a 5120-face mesh with a collapsed (masked) triangle.
TEST(ShellEnergy, SerialAndParallelPathsIdenticalAndGradient) {
  Eigen::MatrixXd V;
  Eigen::MatrixXi F;
  test_sphere(V, F, 4);  // 5120 faces
  std::mt19937 rng(7);
  std::normal_distribution<double> N(0, 0.01);
  Eigen::MatrixXd Y = 1.1 * V;
  for (int i = 0; i < Y.size(); ++i) Y(i) += N(rng);
  // collapse face 17 onto a line (its third corner onto the midpoint of the other two)
  Y.row(F(17, 2)) = 0.5 * (Y.row(F(17, 0)) + Y.row(F(17, 1)));
  ShellEnergy W(V, F);
  ShellEnergyOptions po;
  po.parallel_min_faces = 0;
  ShellEnergy Wp(V, F, po);
  const int threads = omp_get_max_threads();
  for (int frozen = 0; frozen < 2; ++frozen) {
    if (frozen) {
      Eigen::Matrix<double, Eigen::Dynamic, 3, Eigen::RowMajor> Yr = Y;
      W.freeze_mask(Yr.data());
      Wp.freeze_mask(Yr.data());
    }
    Eigen::MatrixXd G1, G2, G3;
    ShellEnergyTerms t1, t2, t3;
    omp_set_num_threads(1);
    const double E1 = W.evaluate(Y, &G1, &t1);
    const double E2 = Wp.evaluate(Y, &G2, &t2);
    omp_set_num_threads(2);
    const double E3 = Wp.evaluate(Y, &G3, &t3);
    omp_set_num_threads(threads);
    EXPECT_EQ(E1, E2);
    EXPECT_EQ(E1, E3);
    EXPECT_EQ((G1 - G2).cwiseAbs().maxCoeff(), 0.0);
    EXPECT_EQ((G1 - G3).cwiseAbs().maxCoeff(), 0.0);
    EXPECT_EQ(t1.admissible_edges, t3.admissible_edges);
    EXPECT_EQ(t1.degenerate_faces, 1);
    EXPECT_EQ(t3.degenerate_faces, 1);
    EXPECT_EQ(t1.admissible_edges, W.num_edges() - 3);
    EXPECT_EQ(W.evaluate(Y), E1);   // value-only paths
    EXPECT_EQ(Wp.evaluate(Y), E1);
    // finite differences on 150 coordinates away from the collapsed face
    const double h = 1e-6;
    double max_err = 0;
    const double max_g = G1.cwiseAbs().maxCoeff();
    std::uniform_int_distribution<int> pick(0, int(Y.rows()) - 1);
    for (int s = 0; s < 150; ++s) {
      const int i = pick(rng), k = s % 3;
      if (i == F(17, 0) || i == F(17, 1) || i == F(17, 2)) continue;
      Eigen::MatrixXd Yp = Y, Ym = Y;
      Yp(i, k) += h;
      Ym(i, k) -= h;
      const double fd = (W.evaluate(Yp) - W.evaluate(Ym)) / (2 * h);
      max_err = std::max(max_err, std::abs(fd - G1(i, k)));
    }
    EXPECT_LT(max_err, 1e-5 * std::max(1.0, max_g)) << "frozen " << frozen;
  }
  W.unfreeze_mask();
}

// freeze_mask says whether the admissible set changed since the previous call, which the
// elastic Y steps rely on to keep the shell part of their last evaluation: the first call,
// and a call after a face collapsed or reopened, report a change; the same set does not.
TEST(ShellEnergy, FreezeMaskReportsWhetherTheSetChanged) {
  Eigen::MatrixXd V;
  Eigen::MatrixXi F;
  test_sphere(V, F);
  ShellEnergy W(V, F);
  using RowY = Eigen::Matrix<double, Eigen::Dynamic, 3, Eigen::RowMajor>;
  RowY Y = 1.2 * V;
  EXPECT_TRUE(W.freeze_mask(Y.data()));   // first call
  EXPECT_FALSE(W.freeze_mask(Y.data()));  // same configuration
  RowY Y2 = Y;
  Y2.row(0) *= 1.01;                      // moved, no face collapsed: same set
  EXPECT_FALSE(W.freeze_mask(Y2.data()));
  const Eigen::RowVector3d mid = 0.5 * (Y.row(F(0, 1)) + Y.row(F(0, 2)));
  Y2 = Y;
  Y2.row(F(0, 0)) = mid;                  // face 0 collapses: its edges leave the set
  EXPECT_TRUE(W.freeze_mask(Y2.data()));
  EXPECT_FALSE(W.freeze_mask(Y2.data()));
  EXPECT_TRUE(W.freeze_mask(Y.data()));   // reopened
  W.unfreeze_mask();
  EXPECT_FALSE(W.freeze_mask(Y.data()));  // unfreezing does not forget the set
}

// ShellEnergyOptions::mask_tol (issue 20): freeze_mask(y, true) leaves out the edges of a sliver
// (here face 0 flattened to 0.1% of its rest area, not degenerate) and says the set changed;
// freeze_mask(y) and mask_tol 0 keep them (the paper's set). With the sliver left out the
// frozen energy is smooth: exact gradient at the sliver's corners too.
TEST(ShellEnergy, FrozenMaskCanLeaveOutSlivers) {
  Eigen::MatrixXd V;
  Eigen::MatrixXi F;
  test_sphere(V, F);
  using RowY = Eigen::Matrix<double, Eigen::Dynamic, 3, Eigen::RowMajor>;
  RowY Y = V;
  const Eigen::RowVector3d mid = 0.5 * (Y.row(F(0, 1)) + Y.row(F(0, 2)));
  Y.row(F(0, 0)) = mid + 1e-3 * (Y.row(F(0, 0)) - mid);  // area ratio 1e-3
  ShellEnergyOptions paper;
  paper.mask_tol = 0;
  ShellEnergy Wp(V, F, paper), Ws(V, F);  // Ws: the default mask_tol 1e-2
  ShellEnergyTerms tp, tk, ts;
  Wp.freeze_mask(Y.data(), true);
  Wp.evaluate(Y.data(), nullptr, &tp);
  EXPECT_EQ(tp.admissible_edges, Wp.num_edges());
  EXPECT_TRUE(Ws.freeze_mask(Y.data()));
  Ws.evaluate(Y.data(), nullptr, &tk);
  EXPECT_EQ(tk.admissible_edges, Ws.num_edges());
  EXPECT_TRUE(Ws.freeze_mask(Y.data(), true));  // a different set
  Ws.evaluate(Y.data(), nullptr, &ts);
  EXPECT_EQ(ts.admissible_edges, Ws.num_edges() - 3);  // face 0's three edges
  EXPECT_EQ(ts.degenerate_faces, 0);
  EXPECT_LT(ts.bending, tk.bending);
  EXPECT_FALSE(Ws.freeze_mask(Y.data(), true));
  check_gradient(Ws, Eigen::MatrixXd(Y), 1e-6, 1e-7);
  Ws.unfreeze_mask();
}

// Issue 20: log_eps = 0 makes -log det G (Eq. 7) an unbounded barrier: exact gradient on a
// strongly compressed shell, and the energy grows without bound as one triangle collapses
// (the linear extension of Sec. 4.1 stays bounded).
TEST(ShellEnergy, UnboundedBarrierGradientAndGrowth) {
  Eigen::MatrixXd V;
  Eigen::MatrixXi F;
  test_sphere(V, F);
  ShellEnergyOptions o;
  o.log_eps = 0;
  ShellEnergy W(V, F, o);
  Eigen::MatrixXd Y = 0.1 * V;  // det G ~ 1e-4 on every triangle
  std::mt19937 rng(11);
  std::normal_distribution<double> N(0, 0.005);
  for (int i = 0; i < Y.size(); ++i) Y(i) += N(rng);
  check_gradient(W, Y, 1e-5, 1e-8);
  // move vertex 0 of face 0 onto the midpoint of its opposite edge: that face collapses
  ShellEnergy Wlin(V, F);  // default eps = 1e-4
  const int v = F(0, 0);
  const Eigen::RowVector3d mid = 0.5 * (V.row(F(0, 1)) + V.row(F(0, 2)));
  double prev = -1, prev_lin = -1, last = 0, last_lin = 0;
  for (double s : {0.9, 0.99, 0.999, 0.9999, 0.99999}) {
    Eigen::MatrixXd Z = V;
    Z.row(v) = (1 - s) * V.row(v) + s * mid;
    last = W.evaluate(Z);
    last_lin = Wlin.evaluate(Z);
    EXPECT_GT(last, prev);
    prev = last;
    prev_lin = std::max(prev_lin, last_lin);
  }
  EXPECT_GT(last - last_lin, 5.0);  // -log(1e-10) against the bounded extension
  Eigen::MatrixXd Z = V;
  Z.row(v) = mid;
  const double at = W.evaluate(Z);  // zero area up to rounding: +inf or larger still
  EXPECT_TRUE(!std::isfinite(at) || at > last) << at;
}
