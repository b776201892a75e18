// The volume-map pipeline's pieces that moved out of the CLI: volume inputs from surfaces,
// landmarks carried from a surface to its tet mesh (against brute force), input errors.
#include "shapemap/error.h"
#include "shapemap/eval/surface_distortion.h"
#include "shapemap/generate.h"
#include "shapemap/surface/surface_map_pipeline.h"
#include "shapemap/volume/symmetric_map.h"
#include "shapemap/volume/volume_map_pipeline.h"
#include <gtest/gtest.h>

#include <cstdio>

using namespace shapemap;

TEST(VolumeMapPipeline, LandmarksGoToTheNearestBoundaryVertex) {
  const TriMesh s = make_ellipsoid(600, Eigen::Vector3d(1.0, 0.7, 0.5));
  const VolumeInput in = volume_input_from_surface(s, "ellipsoid", 1500, 1, false);
  ASSERT_TRUE(in.from_surface);
  const std::vector<int> marks = {0, 17, 123, 599};
  const std::vector<int> got = carry_landmarks_to_volume(in, marks);
  ASSERT_EQ(got.size(), marks.size());
  const TetBoundary bd = boundary_surface(in.mesh);
  for (size_t k = 0; k < marks.size(); ++k) {
    double best = 1e300;
    for (int i = 0; i < bd.to_volume.size(); ++i)
      best = std::min(best, (in.mesh.V.row(bd.to_volume(i)) - s.V.row(marks[k])).squaredNorm());
    EXPECT_GE(bd.to_surface(got[k]), 0) << "not a boundary vertex";
    EXPECT_DOUBLE_EQ((in.mesh.V.row(got[k]) - s.V.row(marks[k])).squaredNorm(), best);
  }
  EXPECT_THROW(carry_landmarks_to_volume(in, {int(s.V.rows())}), InputError);
  // A tet-mesh input keeps its indices.
  const VolumeInput tets = volume_input_from_tets(in.mesh, "tets");
  EXPECT_EQ(carry_landmarks_to_volume(tets, marks), marks);
}

TEST(VolumeMapPipeline, BadRequestsAreInputErrors) {
  const TriMesh s = make_sphere(500);
  VolumeInput a = volume_input_from_surface(s, "a", 800, 1, false), b = a;
  VolumeMapRequest req;
  req.init = "nope";
  EXPECT_THROW(run_volume_map(a, b, req), InputError);
  req.init = "landmarks";
  req.landmarks_A = {0, 1, 2};
  req.landmarks_B = {0, 1};
  EXPECT_THROW(run_volume_map(a, b, req), InputError);
  req.init = "surface-map";
  EXPECT_THROW(run_volume_map(a, b, req), InputError);
}

TEST(SurfaceMapPipeline, InvertingTheIdentityGivesTheIdentity) {
  const TriMesh s = make_sphere(500);
  BarycentricMap id;
  id.elem.resize(s.num_vertices());
  id.bary = Eigen::MatrixXd::Zero(s.num_vertices(), 3);
  for (int f = 0; f < s.num_faces(); ++f)
    for (int j = 0; j < 3; ++j) {
      id.elem(s.F(f, j)) = f;
      id.bary.row(s.F(f, j)).setZero();
      id.bary(s.F(f, j), j) = 1;
    }
  const BarycentricMap inv = invert_surface_map(id, s, s);
  const Eigen::MatrixXd X = map_positions(inv, s.V, s.F);
  EXPECT_LT((X - s.V).rowwise().norm().maxCoeff(), 1e-9);
}

// Issue 20: volume-map --init auto gets the same surface maps as `surface-map --method elastic`
// (refine_surface_maps.h: the collapse guard and the untangling stage), not the refinement
// alone. On a generated pair whose refinement leaves folds, the automatic initialization's
// maps are the surface-map command's (with the same BIM options), bit for bit, have no more
// flipped or collapsed triangles than the refinement alone, and its description names the stage.
// Since 6 Dec 2026 its default is surface-map's (reverse candidates): checked the same way.
// How short a refinement still leaves folds on the generated pair depends on the processor (BIM's
// choice among nearly tied candidates): 2 outer iterations did on the machines before 7 Dec 2026;
// on the 38th session's one even 1 removed them all, and 0 (BIM's maps through the refinement's
// own guard) left 2. So the longest of 2, 1, 0 that leaves folds is taken.
TEST(VolumeMapPipeline, AutoInitSurfaceMapsAreTheSurfaceMapCommands) {
  const GeneratedPair pair = make_creature_pair(2, PairKind::NonIsometric, 1200);
  const TriMesh &A = pair.A, &B = pair.B;
  auto bad = [](const TriMesh& S, const TriMesh& T, const BarycentricMap& P) {
    const SurfaceDistortion d = surface_distortion(S, T, P);
    return d.flipped + d.degenerate;
  };
  SurfaceMapRequest req;
  req.method = "elastic";
  req.bim.reverse_candidates = false;  // each direction's own blend leaves folds on this pair
  req.elastic.untangle = false;
  int bad_alone = 0;
  for (int iterations = 2; iterations >= 0 && bad_alone == 0; --iterations) {
    req.elastic.iterations = iterations;  // a short refinement leaves folds for the stage to work on
    const SurfaceMapRun alone = run_surface_map(A, B, req);
    bad_alone = bad(A, B, alone.AB) + bad(B, A, alone.BA);
  }
  ASSERT_GT(bad_alone, 0) << "the refinement alone must leave folds for this test to see the stage";
  std::printf("%d outer iterations leave %d folds\n", req.elastic.iterations, bad_alone);
  req.elastic.untangle = true;
  const SurfaceMapRun full = run_surface_map(A, B, req);
  std::string used;
  const auto [sAB, sBA] = surface_map_for_volumes(A, B, {}, &used, true, &req.elastic, {}, {}, false);
  EXPECT_NE(used.find("untangle"), std::string::npos) << used;
  EXPECT_EQ(used.find("reverse candidates"), std::string::npos) << used;
  EXPECT_EQ(sAB.elem, full.AB.elem);
  EXPECT_EQ(sAB.bary, full.AB.bary);
  EXPECT_EQ(sBA.elem, full.BA.elem);
  EXPECT_EQ(sBA.bary, full.BA.bary);
  EXPECT_LT(bad(A, B, sAB) + bad(B, A, sBA), bad_alone);
  // The default: surface-map's default BIM options.
  req.bim = BIMOptions{};
  ASSERT_TRUE(req.bim.reverse_candidates);
  const SurfaceMapRun dflt = run_surface_map(A, B, req);
  const auto [dAB, dBA] = surface_map_for_volumes(A, B, {}, &used, true, &req.elastic);
  EXPECT_NE(used.find("reverse candidates"), std::string::npos) << used;
  EXPECT_EQ(dAB.elem, dflt.AB.elem);
  EXPECT_EQ(dAB.bary, dflt.AB.bary);
  EXPECT_EQ(dBA.elem, dflt.BA.elem);
  EXPECT_EQ(dBA.bary, dflt.BA.bary);
}

namespace {
// Each vertex of s on itself (a face containing it, that corner's coordinate 1), or, with
// `antipodal`, on the vertex nearest to its mirror image -x.
BarycentricMap vertex_map(const TriMesh& s, bool antipodal) {
  BarycentricMap m;
  m.elem.resize(s.num_vertices());
  m.bary = Eigen::MatrixXd::Zero(s.num_vertices(), 3);
  std::vector<std::pair<int, int>> corner(s.num_vertices());
  for (int f = 0; f < s.num_faces(); ++f)
    for (int j = 0; j < 3; ++j) corner[s.F(f, j)] = {f, j};
  for (int v = 0; v < s.num_vertices(); ++v) {
    int u = v;
    if (antipodal) (s.V.rowwise() + s.V.row(v)).rowwise().squaredNorm().minCoeff(&u);
    m.elem(v) = corner[u].first;
    m.bary(v, corner[u].second) = 1;
  }
  return m;
}
}  // namespace

// The start's round trip (report.json init_round_trip, and a note above 1% of the diagonal):
// round_trip_bbox against brute force, and through the pipeline with agreeing and disagreeing
// surface maps on a sphere.
TEST(VolumeMapPipeline, DisagreeingSurfaceMapsGetANote) {
  const TriMesh s = make_sphere(400);
  const BarycentricMap id = vertex_map(s, false), anti = vertex_map(s, true);
  const double diag = (s.V.colwise().maxCoeff() - s.V.colwise().minCoeff()).norm();
  const Eigen::VectorXd zero = round_trip_bbox(s, s, id, id), far = round_trip_bbox(s, s, id, anti);
  EXPECT_LT(zero.maxCoeff(), 1e-12);
  for (int v = 0; v < s.num_vertices(); ++v) {
    int u;
    (s.V.rowwise() + s.V.row(v)).rowwise().squaredNorm().minCoeff(&u);
    EXPECT_NEAR(far(v), (s.V.row(u) - s.V.row(v)).norm() / diag, 1e-12);
  }
  VolumeInput a = volume_input_from_surface(s, "a", 800, 1, false), b = a;
  VolumeMapRequest req;
  req.init = "surface-map";
  req.surface_map_mesh_A = req.surface_map_mesh_B = s;
  req.opt.max_iterations = 1;
  req.opt.land_on_target = false;
  auto noted = [](const VolumeMapRun& r) {
    for (const std::string& n : r.notes)
      if (n.find("initial surface maps disagree") != std::string::npos) return true;
    return false;
  };
  req.surface_map_AB = req.surface_map_BA = id;
  const VolumeMapRun same = run_volume_map(a, b, req);
  EXPECT_LT(same.init_round_trip_AB, 1e-12);
  EXPECT_FALSE(noted(same));
  EXPECT_LT(same.report["init_round_trip"]["BA"].get<double>(), 1e-12);
  req.surface_map_BA = anti;
  const VolumeMapRun swapped = run_volume_map(a, b, req);
  EXPECT_NEAR(swapped.init_round_trip_AB, far.mean(), 1e-12);
  EXPECT_GT(swapped.init_round_trip_BA, 0.5);  // about 2 r / diag = 1 / sqrt(3)
  EXPECT_TRUE(noted(swapped));
}
