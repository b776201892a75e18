// The fixed-pattern block Hessian (block_hessian.h) against dense assembly, and projected
// Newton (newton.h): one step on a quadratic, convergence on a non-quadratic convex energy
// of a mesh, fixed vertices held, an indefinite rounding shift.
#include "shapemap/error.h"
#include "shapemap/optim/block_hessian.h"
#include "shapemap/optim/coupled_newton.h"
#include "shapemap/optim/newton.h"
#include <Eigen/Dense>
#include <gtest/gtest.h>
#include <random>

using namespace shapemap;

namespace {
// Two tets sharing a face, and a triangle sharing nothing: 6 vertices (5 is isolated).
Eigen::MatrixXi two_tets() {
  Eigen::MatrixXi T(2, 4);
  T << 0, 1, 2, 3, 1, 2, 3, 4;
  return T;
}
Eigen::MatrixXd random_spd(int n, std::mt19937& rng) {
  std::normal_distribution<double> g(0, 1);
  Eigen::MatrixXd R(n, n);
  for (int i = 0; i < R.size(); ++i) R(i) = g(rng);
  return R * R.transpose() + Eigen::MatrixXd::Identity(n, n);
}
}  // namespace

TEST(BlockHessian, MatchesDenseAssemblyWithFixedVertices) {
  const Eigen::MatrixXi T = two_tets();
  std::mt19937 rng(2);
  const std::vector<int> free = {4, 0, 2, 5, 3};  // vertex 1 fixed, any order
  BlockHessian H(T, 6, free);
  EXPECT_EQ(H.num_free(), 5);
  EXPECT_EQ(H.free_index(1), -1);
  EXPECT_EQ(H.free_index(2), 2);
  Eigen::MatrixXd dense = Eigen::MatrixXd::Zero(18, 18);  // by vertex
  for (int e = 0; e < 2; ++e) {
    const Eigen::MatrixXd He = random_spd(12, rng);
    H.add_element(e, He);
    for (int a = 0; a < 4; ++a)
      for (int b = 0; b < 4; ++b) dense.block<3, 3>(3 * T(e, a), 3 * T(e, b)) += He.block<3, 3>(3 * a, 3 * b);
  }
  Eigen::Matrix3d B = random_spd(3, rng);
  B(0, 1) += 0.5;  // not symmetric: (a, b) gets B, (b, a) gets B^T
  H.add_block(0, 3, B);
  dense.block<3, 3>(0, 9) += B;
  dense.block<3, 3>(9, 0) += B.transpose();
  const Eigen::Matrix3d S = random_spd(3, rng);
  H.add_block(2, 2, S);
  dense.block<3, 3>(6, 6) += S;
  H.add_diagonal(5, 2.0);
  dense.block<3, 3>(15, 15) += 2.0 * Eigen::Matrix3d::Identity();
  H.add_block(1, 1, S);  // fixed: dropped
  EXPECT_THROW(H.add_block(0, 4, B), Error);  // share no element
  // The free-vertex submatrix in free order.
  Eigen::MatrixXd want(15, 15);
  for (int p = 0; p < 5; ++p)
    for (int q = 0; q < 5; ++q) want.block<3, 3>(3 * p, 3 * q) = dense.block<3, 3>(3 * free[p], 3 * free[q]);
  const Eigen::MatrixXd got = Eigen::MatrixXd(Eigen::SparseMatrix<double>(H.matrix().selfadjointView<Eigen::Lower>()));
  EXPECT_LT((got - want).cwiseAbs().maxCoeff(), 1e-12);
  // Only the lower triangle is stored.
  for (int j = 0; j < H.matrix().outerSize(); ++j)
    for (Eigen::SparseMatrix<double>::InnerIterator it(H.matrix(), j); it; ++it) EXPECT_GE(it.row(), it.col());
  Eigen::VectorXd x = Eigen::VectorXd::LinSpaced(15, -1, 2);
  EXPECT_LT((H.multiply(x) - want * x).cwiseAbs().maxCoeff(), 1e-11);
  H.set_zero();
  EXPECT_EQ(Eigen::MatrixXd(H.matrix()).cwiseAbs().maxCoeff(), 0.0);
}

namespace {
// A mass-spring-like convex energy on a tet mesh's edges plus a quartic pull: E(x) =
// sum_edges |x_a - x_b - r_ab|^2 + sum_v |x_v - p_v|^4, with its exact Hessian (convex);
// quartic = false: the pull |x_v - p_v|^2 (a quadratic).
struct Springs {
  Eigen::MatrixXi T;
  std::vector<std::pair<int, int>> edges;
  Eigen::MatrixXd R, P;  // per edge rest vector; per vertex pull target
  int n;
  bool quartic = true;
  double value(const Eigen::MatrixXd& X, Eigen::MatrixXd* G) const {
    double E = 0;
    if (G) G->setZero(n, 3);
    for (size_t k = 0; k < edges.size(); ++k) {
      const auto [a, b] = edges[k];
      const Eigen::RowVector3d d = X.row(a) - X.row(b) - R.row(k);
      E += d.squaredNorm();
      if (G) {
        G->row(a) += 2 * d;
        G->row(b) -= 2 * d;
      }
    }
    for (int v = 0; v < n; ++v) {
      const Eigen::RowVector3d d = X.row(v) - P.row(v);
      E += quartic ? d.squaredNorm() * d.squaredNorm() : d.squaredNorm();
      if (G) G->row(v) += quartic ? Eigen::RowVector3d(4 * d.squaredNorm() * d) : Eigen::RowVector3d(2 * d);
    }
    return E;
  }
  void hessian(const Eigen::MatrixXd& X, BlockHessian& H) const {
    for (const auto& [a, b] : edges) {
      H.add_block(a, a, 2 * Eigen::Matrix3d::Identity());
      H.add_block(b, b, 2 * Eigen::Matrix3d::Identity());
      H.add_block(a, b, -2 * Eigen::Matrix3d::Identity());
    }
    for (int v = 0; v < n; ++v) {
      const Eigen::Vector3d d = (X.row(v) - P.row(v)).transpose();
      H.add_block(v, v, quartic ? Eigen::Matrix3d(4 * d.squaredNorm() * Eigen::Matrix3d::Identity() + 8 * d * d.transpose())
                                : Eigen::Matrix3d(2 * Eigen::Matrix3d::Identity()));
    }
  }
};
Springs make_springs(unsigned seed) {
  Springs s;
  s.T = two_tets();
  s.n = 5;
  for (int e = 0; e < 2; ++e)
    for (int a = 0; a < 4; ++a)
      for (int b = a + 1; b < 4; ++b) s.edges.emplace_back(s.T(e, a), s.T(e, b));
  std::mt19937 rng(seed);
  std::normal_distribution<double> g(0, 1);
  s.R.resize(s.edges.size(), 3);
  s.P.resize(5, 3);
  for (int i = 0; i < s.R.size(); ++i) s.R(i) = g(rng);
  for (int i = 0; i < s.P.size(); ++i) s.P(i) = g(rng);
  return s;
}
// Springs' value and Hessian over the free rows of X (the others held at X's values).
struct FreeRows {
  const Springs& s;
  std::vector<int> free;
  Eigen::MatrixXd X, G;
  void scatter(const Eigen::VectorXd& z) {
    for (size_t q = 0; q < free.size(); ++q) X.row(free[q]) = z.segment<3>(3 * q).transpose();
  }
  NewtonValue value() {
    return [this](const Eigen::VectorXd& z, Eigen::VectorXd* g) {
      scatter(z);
      const double v = s.value(X, g ? &G : nullptr);
      if (g)
        for (size_t q = 0; q < free.size(); ++q) g->segment<3>(3 * q) = G.row(free[q]).transpose();
      return v;
    };
  }
  NewtonHessian hessian() {
    return [this](const Eigen::VectorXd& z, BlockHessian& H) {
      scatter(z);
      s.hessian(X, H);
    };
  }
};
}  // namespace

TEST(ProjectedNewton, ConvergesQuadraticallyAndHoldsFixedVertices) {
  const Springs s = make_springs(3);
  Eigen::MatrixXd X = Eigen::MatrixXd::Zero(5, 3);
  X.row(2) << 5, 5, 5;  // fixed
  const std::vector<int> free = {0, 1, 3, 4};
  ProjectedNewton pn(BlockHessian(s.T, 5, free));
  FreeRows fr{s, free, X, {}};
  Eigen::MatrixXd& Xf = fr.X;
  Eigen::MatrixXd G;
  auto scatter = [&](const Eigen::VectorXd& z) { fr.scatter(z); };
  const NewtonValue f = fr.value();
  const NewtonHessian h = fr.hessian();
  Eigen::VectorXd x = Eigen::VectorXd::Zero(12);
  NewtonOptions o;
  o.max_iterations = 50;
  o.grad_tol = 1e-10;
  o.f_rel_tol = 0;
  NewtonResult r = pn.minimize(f, h, x, o);
  EXPECT_EQ(r.stop, "gradient");
  EXPECT_LT(r.iterations, 25);
  EXPECT_LT(r.grad_norm, 1e-10);
  scatter(x);
  EXPECT_EQ(Xf.row(2), Eigen::RowVector3d(5, 5, 5));
  // The gradient of the free rows vanishes; the fixed row's does not.
  s.value(Xf, &G);
  EXPECT_GT(G.row(2).norm(), 1e-3);
  // A quadratic (no quartic pull) is solved in one Newton step.
  Springs q = s;
  q.P.setZero();
  auto fq = [&](const Eigen::VectorXd& z, Eigen::VectorXd* g) {
    scatter(z);
    double v = 0;
    Eigen::MatrixXd Gq = Eigen::MatrixXd::Zero(5, 3);
    for (size_t k = 0; k < q.edges.size(); ++k) {
      const auto [a, b] = q.edges[k];
      const Eigen::RowVector3d d = Xf.row(a) - Xf.row(b) - q.R.row(k);
      v += d.squaredNorm();
      Gq.row(a) += 2 * d;
      Gq.row(b) -= 2 * d;
    }
    if (g)
      for (int p = 0; p < 4; ++p) g->segment<3>(3 * p) = Gq.row(free[p]).transpose();
    return v;
  };
  NewtonHessian hq = [&](const Eigen::VectorXd& z, BlockHessian& H) {
    scatter(z);
    for (const auto& [a, b] : q.edges) {
      H.add_block(a, a, 2 * Eigen::Matrix3d::Identity());
      H.add_block(b, b, 2 * Eigen::Matrix3d::Identity());
      H.add_block(a, b, -2 * Eigen::Matrix3d::Identity());
    }
  };
  ProjectedNewton pq(BlockHessian(s.T, 5, free));
  x.setZero();
  o.max_iterations = 1;
  NewtonResult rq = pq.minimize(fq, hq, x, o);
  Eigen::VectorXd gq(12);
  fq(x, &gq);
  EXPECT_EQ(rq.iterations, 1);
  EXPECT_LT(gq.norm(), 1e-9);
}

// NewtonOptions::refactor_cg: a kept factor preconditions CG on the current Hessian. The
// descent reaches the exact-solve run's minimizer with fewer factorizations than steps.
TEST(ProjectedNewton, KeptFactorPreconditionsCGToTheSameMinimizer) {
  const Springs s = make_springs(5);
  const std::vector<int> free = {0, 1, 3, 4};
  FreeRows fr{s, free, Eigen::MatrixXd::Zero(5, 3), {}};
  fr.X.row(2) << 2, -1, 3;  // fixed
  const NewtonValue f = fr.value();
  const NewtonHessian h = fr.hessian();
  NewtonOptions o;
  o.max_iterations = 60;
  o.grad_tol = 1e-9;
  o.f_rel_tol = 0;
  Eigen::VectorXd exact = Eigen::VectorXd::Zero(12), kept = exact;
  ProjectedNewton p0(BlockHessian(s.T, 5, free)), p1(BlockHessian(s.T, 5, free));
  const NewtonResult r0 = p0.minimize(f, h, exact, o);
  o.refactor_cg = 4;
  o.cg_iterations = 50;
  o.cg_rel_tol = 1e-8;
  const NewtonResult r1 = p1.minimize(f, h, kept, o);
  EXPECT_EQ(r0.stop, "gradient");
  EXPECT_EQ(r1.stop, "gradient");
  EXPECT_EQ(r0.factorizations, r0.iterations);
  EXPECT_LT(r1.factorizations, r1.iterations);
  EXPECT_LT((kept - exact).norm(), 1e-6);
}

// preconditioned_cg against a dense solve; an exact preconditioner needs one iteration.
TEST(PreconditionedCG, SolvesASymmetricPositiveDefiniteSystem) {
  std::mt19937 rng(7);
  std::normal_distribution<double> n01(0, 1);
  Eigen::MatrixXd B(12, 12);
  for (int i = 0; i < B.size(); ++i) B(i) = n01(rng);
  const Eigen::MatrixXd A = B * B.transpose() + Eigen::MatrixXd::Identity(12, 12);
  Eigen::VectorXd g(12), d;
  for (int i = 0; i < 12; ++i) g(i) = n01(rng);
  const Eigen::VectorXd truth = A.ldlt().solve(-g);
  auto apply = [&](const Eigen::VectorXd& p, Eigen::VectorXd& q) { q = A * p; };
  auto identity = [](const Eigen::VectorXd& r, Eigen::VectorXd& s) { s = r; };
  const int k = preconditioned_cg(apply, identity, g, d, 100, 1e-12);
  EXPECT_LE(k, 20);  // 12 in exact arithmetic
  EXPECT_LT((d - truth).norm(), 1e-8 * truth.norm());
  const Eigen::LDLT<Eigen::MatrixXd> exact(A);
  auto inverse = [&](const Eigen::VectorXd& r, Eigen::VectorXd& s) { s = exact.solve(r); };
  EXPECT_EQ(preconditioned_cg(apply, inverse, g, d, 100, 1e-10), 1);
  EXPECT_LT((d - truth).norm(), 1e-10 * truth.norm());
}

// A Hessian that is singular (a free vertex nobody constrains) gets a diagonal shift and
// still gives a descent step.
TEST(ProjectedNewton, ShiftsASingularHessian) {
  const Eigen::MatrixXi T = two_tets();
  ProjectedNewton pn(BlockHessian(T, 5, {0, 1, 2, 3, 4}));
  // f = |x_0 - 1|^2 only: vertices 1..4 have zero Hessian rows.
  NewtonValue f = [](const Eigen::VectorXd& z, Eigen::VectorXd* g) {
    if (g) {
      g->setZero();
      g->head<3>() = 2 * (z.head<3>().array() - 1).matrix();
    }
    return (z.head<3>().array() - 1).matrix().squaredNorm();
  };
  NewtonHessian h = [](const Eigen::VectorXd&, BlockHessian& H) { H.add_block(0, 0, 2 * Eigen::Matrix3d::Identity()); };
  Eigen::VectorXd x = Eigen::VectorXd::Zero(15);
  NewtonResult r = pn.minimize(f, h, x, {});
  EXPECT_LT(r.f, 1e-12);
  EXPECT_GE(r.factorizations, 1);
  EXPECT_EQ(x.tail<12>().cwiseAbs().maxCoeff(), 0.0);
}

// A model Hessian 16x stiffer than the true one (as the clamped Hessian is where f is
// concave): each full step goes 1/16 of the way. Expansion doubles an accepted full step
// while f falls, so 4 doublings reach the minimum in one iteration; without them the
// iterations crawl (the decrease of each is 1 - (15/16)^2 of what is left).
TEST(ProjectedNewton, ExpansionLengthensAcceptedStepsOfAStiffModel) {
  const Eigen::MatrixXi T = two_tets();
  NewtonValue f = [](const Eigen::VectorXd& z, Eigen::VectorXd* g) {
    if (g) *g = 2 * (z.array() - 1).matrix();
    return (z.array() - 1).matrix().squaredNorm();
  };
  NewtonHessian h = [](const Eigen::VectorXd&, BlockHessian& H) {
    for (int v = 0; v < 5; ++v) H.add_diagonal(v, 32.0);
  };
  NewtonOptions o;
  o.max_iterations = 3;
  auto run = [&](int expansions, Eigen::VectorXd& x) {
    ProjectedNewton pn(BlockHessian(T, 5, {0, 1, 2, 3, 4}));
    o.max_expansions = expansions;
    x = Eigen::VectorXd::Zero(15);
    return pn.minimize(f, h, x, o);
  };
  Eigen::VectorXd x0, x4;
  const NewtonResult plain = run(0, x0), expanded = run(4, x4);
  EXPECT_NEAR(plain.f, 15 * std::pow(15.0 / 16.0, 6), 1e-9);  // three steps of 1/16
  EXPECT_LT(expanded.f, 1e-20);                               // 1/16 * 2^4 = the whole way
  EXPECT_EQ(plain.evaluations, 1 + 3);
  EXPECT_LE(x4.maxCoeff(), 1.0 + 1e-12);
  // One iteration: 3 doublings reach 1/2 of the way; with 6 allowed, the 5th (twice the
  // way: f as high as at the start) is refused and the search stops there.
  o.max_iterations = 1;
  Eigen::VectorXd x3, x6;
  EXPECT_NEAR(run(3, x3).f, 15 * 0.25, 1e-12);
  const NewtonResult six = run(6, x6);
  EXPECT_LT(six.f, 1e-20);
  EXPECT_EQ(six.evaluations, 1 + 1 + 5);
}

// Two spring meshes tied vertex to vertex by stiff springs k|x1_v - x2_v - s_v|^2: the
// coupled solver takes the blocks' Newton steps together (coupled_newton.h).
namespace {
struct TiedSprings {
  Springs a = make_springs(4), b = make_springs(5);
  Eigen::MatrixXd S = Eigen::MatrixXd::Constant(5, 3, 0.3);
  double k = 50;
  void set_quartic(bool q) { a.quartic = b.quartic = q; }
  static Eigen::MatrixXd rows(const Eigen::VectorXd& z, int block) {
    return Eigen::Map<const Eigen::MatrixXd>(z.data() + 15 * block, 3, 5).transpose();
  }
  double value(const Eigen::VectorXd& z, Eigen::VectorXd* g) const {
    const Eigen::MatrixXd X1 = rows(z, 0), X2 = rows(z, 1);
    Eigen::MatrixXd G1, G2;
    double E = a.value(X1, &G1) + b.value(X2, &G2);
    for (int v = 0; v < 5; ++v) {
      const Eigen::RowVector3d d = X1.row(v) - X2.row(v) - S.row(v);
      E += k * d.squaredNorm();
      G1.row(v) += 2 * k * d;
      G2.row(v) -= 2 * k * d;
    }
    if (g) {
      g->resize(30);
      for (int v = 0; v < 5; ++v) {
        g->segment<3>(3 * v) = G1.row(v).transpose();
        g->segment<3>(15 + 3 * v) = G2.row(v).transpose();
      }
    }
    return E;
  }
  // The tie's coupling block C is left empty when !couple (the blocks' separate steps).
  void hessian(const Eigen::VectorXd& z, BlockHessian& H1, BlockHessian& H2, Eigen::SparseMatrix<double>& C,
               bool couple) const {
    a.hessian(rows(z, 0), H1);
    b.hessian(rows(z, 1), H2);
    for (int v = 0; v < 5; ++v) {
      H1.add_diagonal(v, 2 * k);
      H2.add_diagonal(v, 2 * k);
    }
    std::vector<Eigen::Triplet<double>> t;
    if (couple)
      for (int i = 0; i < 15; ++i) t.emplace_back(i, i, -2 * k);
    C.resize(15, 15);
    C.setFromTriplets(t.begin(), t.end());
  }
};
}  // namespace

TEST(CoupledNewton, SolvesTheJointSystemWhereSeparateStepsCrawl) {
  TiedSprings ts;
  const std::vector<int> all = {0, 1, 2, 3, 4};
  NewtonValue f = [&](const Eigen::VectorXd& z, Eigen::VectorXd* g) { return ts.value(z, g); };
  CoupledNewtonOptions o;
  o.newton.max_iterations = 1;
  o.newton.f_rel_tol = 0;
  o.newton.grad_tol = 0;
  o.newton.cg_iterations = 200;
  o.newton.cg_rel_tol = 1e-13;
  // A quadratic: one step with an exact inner solve lands on the minimizer.
  ts.set_quartic(false);
  for (bool couple : {true, false}) {
    CoupledNewton cn(BlockHessian(ts.a.T, 5, all), BlockHessian(ts.b.T, 5, all));
    Eigen::VectorXd z = Eigen::VectorXd::Zero(30), g;
    cn.minimize(f, [&](const Eigen::VectorXd& x, BlockHessian& H1, BlockHessian& H2,
                       Eigen::SparseMatrix<double>& C) { ts.hessian(x, H1, H2, C, couple); },
                z, o);
    f(z, &g);
    if (couple) {
      EXPECT_LT(g.norm(), 1e-8);
      EXPECT_GT(cn.cg_iterations(), 1);
    } else {
      EXPECT_GT(g.norm(), 1e-2);  // the blocks' separate Newton steps miss the tie
      EXPECT_LE(cn.cg_iterations(), 1);
    }
  }
  // The quartic pull: converges to the gradient tolerance in few steps.
  ts.set_quartic(true);
  const CoupledHessian tied = [&](const Eigen::VectorXd& x, BlockHessian& H1, BlockHessian& H2,
                                  Eigen::SparseMatrix<double>& C) { ts.hessian(x, H1, H2, C, true); };
  auto run = [&](Eigen::VectorXd& z) {
    CoupledNewton cn(BlockHessian(ts.a.T, 5, all), BlockHessian(ts.b.T, 5, all));
    z = Eigen::VectorXd::Zero(30);
    return cn.minimize(f, tied, z, o);
  };
  o.newton.max_iterations = 40;
  o.newton.grad_tol = 1e-9;
  o.newton.cg_rel_tol = 1e-6;
  Eigen::VectorXd z, zk;
  const NewtonResult r = run(z);
  EXPECT_EQ(r.stop, "gradient");
  EXPECT_LT(r.iterations, 30);
  // Kept factors (NewtonOptions::refactor_cg): the same minimizer, fewer factorizations.
  o.newton.refactor_cg = 40;
  o.newton.cg_iterations = 100;
  o.newton.cg_rel_tol = 1e-8;
  const NewtonResult rk = run(zk);
  EXPECT_EQ(rk.stop, "gradient");
  EXPECT_LT(rk.factorizations, 2 * rk.iterations);  // two blocks per refactorization
  EXPECT_LT((zk - z).norm(), 1e-6);
}
