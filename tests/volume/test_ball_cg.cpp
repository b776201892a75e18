// The preconditioned nonlinear CG of the ball parameterization (BallConjugateGradient,
// Algorithm 1 steps 13-38) run alone, outside ball_parameterization.
#include "ball_test_mesh.h"
#include "shapemap/volume/ball_cg.h"
#include "shapemap/volume/ball_param.h"
#include "shapemap/volume/vsem.h"
#include <gtest/gtest.h>
#include <numeric>

using namespace shapemap;
using namespace shapemap::testing_ball;

namespace {

// The driver's numbering: interior vertices first (x = [f_I; theta; phi], Eq. 14).
struct Permuted {
  Eigen::VectorXi perm;
  int nI = 0, nB = 0;
  Eigen::MatrixXi T;
  Eigen::MatrixXd V, f;
};
Permuted interior_first(const TetMesh& m, const Eigen::VectorXi& boundary, const Eigen::MatrixXd& f) {
  Permuted p;
  std::vector<char> isb(m.num_vertices(), 0);
  for (Eigen::Index b = 0; b < boundary.size(); ++b) isb[boundary(b)] = 1;
  Eigen::VectorXi iperm;
  p.nI = interior_first_order(isb, p.perm, iperm, &m.V);
  p.nB = int(boundary.size());
  p.T = renumber_tets(m.T, p.perm);
  p.V.resize(m.num_vertices(), 3);
  p.f.resize(m.num_vertices(), 3);
  for (int i = 0; i < m.num_vertices(); ++i) {
    p.V.row(p.perm(i)) = m.V.row(i);
    p.f.row(p.perm(i)) = f.row(i);
  }
  return p;
}

}  // namespace

TEST(BallConjugateGradient, AloneFromTheVsemStartMatchesTheDriversCgStage) {
  const TetMesh m = blob_tets(6, Eigen::Vector3d(1.0, 0.8, 0.6), 0.1);
  BallParamOptions o;
  o.anisotropic_scaling = false;  // the CG sees the input coordinates
  o.max_iterations = 40;
  o.untangle_rounds = 0;
  o.penalty_rounds = 0;
  o.fold_retry_barrier = 0;
  o.stall_preconditioner_fallback = false;
  const BallParamResult full = ball_parameterization(m, o);

  const Permuted p = interior_first(m, full.boundary, full.f_vsem);
  const IsovolumetricEnergy energy(p.V, p.T);
  Eigen::VectorXi interior(p.nI), boundary(p.nB);
  std::iota(interior.data(), interior.data() + p.nI, 0);
  std::iota(boundary.data(), boundary.data() + p.nB, p.nI);
  SphericalBallEnergy sbe(energy, interior, boundary);
  BallParamResult stats;
  BallConjugateGradient cg(energy, sbe, p.V, o, stats);
  cg.factor_preconditioner(p.f);
  cg.start_from(p.f);
  cg.evaluate_at_iterate();
  const double e0 = cg.energy();
  EXPECT_NEAR(e0, full.energy_vsem, 1e-12 * std::max(1.0, e0));
  cg.run(o.max_iterations, false);

  // The same iterations and energies as the driver's CG stage.
  EXPECT_EQ(stats.iterations, full.iterations);
  EXPECT_EQ(stats.energies, full.energies);
  EXPECT_EQ(cg.energy(), full.energy_cg);
  // Each accepted step lowers E (steps 33-37), and CG lowered it well below the start.
  for (size_t k = 1; k < stats.energies.size(); ++k) EXPECT_LT(stats.energies[k], stats.energies[k - 1]) << k;
  EXPECT_LT(cg.energy(), 0.5 * e0);
  EXPECT_EQ(stats.evaluations, full.evaluations);
}
