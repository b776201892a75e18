// A prepared surface saved to bytes and loaded again (how shapemap batch shares BIM's
// per-surface stage between worker processes) gives the very same maps.
#include "shapemap/error.h"
#include "shapemap/generate.h"
#include "shapemap/surface/prepared_surface_io.h"
#include "shapemap/surface/surface_map_pipeline.h"
#include <gtest/gtest.h>

using namespace shapemap;

TEST(PreparedSurfaceIO, LoadedSurfacesGiveTheSameMap) {
  const TriMesh A = make_creature(3, 700), B = make_creature(4, 800);
  SurfaceMapRequest req;
  req.symmetric = true;
  req.bim.name_A = "A";
  req.bim.name_B = "B";
  // 128 samples and 1000 candidates (defaults 256, 10000): the maps are compared with each
  // other, and the defaults' consistency matrix would be most of the time.
  req.bim.num_even = 128;
  req.bim.max_candidates = 1000;
  const SurfaceMapRun direct = run_surface_map(A, B, req);

  const auto pA = prepare_surface(A, "A", req.bim, false), pB = prepare_surface(B, "B", req.bim, false);
  const std::string bytesA = save_prepared_surface(*pA);
  req.prepared_A = load_prepared_surface(bytesA);
  req.prepared_B = load_prepared_surface(save_prepared_surface(*pB));
  EXPECT_EQ(save_prepared_surface(*req.prepared_A), bytesA);  // a round trip keeps every byte
  const SurfaceMapRun shared = run_surface_map(A, B, req);
  EXPECT_EQ(shared.AB.elem, direct.AB.elem);
  EXPECT_EQ((shared.AB.bary - direct.AB.bary).cwiseAbs().maxCoeff(), 0.0);
  EXPECT_EQ(shared.BA.elem, direct.BA.elem);
  EXPECT_EQ((shared.BA.bary - direct.BA.bary).cwiseAbs().maxCoeff(), 0.0);
}

TEST(PreparedSurfaceIO, RefusesOtherBytes) {
  EXPECT_THROW(load_prepared_surface("not a prepared surface"), Error);
  const auto p = prepare_surface(make_sphere(300), "S", BIMOptions{}, false);
  const std::string b = save_prepared_surface(*p);
  EXPECT_THROW(load_prepared_surface(b.substr(0, b.size() / 2)), Error);
  EXPECT_THROW(load_prepared_surface(b + "x"), Error);
}
