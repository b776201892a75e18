// The `generate` and `tetrahedralize` subcommands end to end (files, exit codes).
#include "cli_run.h"
#include "shapemap/io.h"
#include "shapemap/maps.h"
#include "shapemap/mesh.h"
#include <gtest/gtest.h>
#include <cstdlib>
#include <filesystem>
#include <fstream>
#include <sstream>
#include <string>
#include <sys/wait.h>
#include <unistd.h>

namespace fs = std::filesystem;
using namespace shapemap;
using namespace shapemap::testing;

TEST(CliGenerate, PairWithVolumes) {
  TempDir d("cgal_cli");
  const std::string out = d.p("pair");
  ASSERT_EQ(run_quiet("generate -o " + out + " --seed 3 --shape pair --kind non-isometric --vertices 1500 --tets "
                "--tet-count 3000"),
            0);
  for (const char* f : {"A.obj", "B.obj", "truth_AB.txt", "truth_BA.txt", "pair.json", "A.vtk", "B.vtk",
                        "truth_vol_AB.txt"})
    EXPECT_TRUE(fs::exists(out + "/" + f)) << f;
  TriMesh A = read_surface(out + "/A.obj"), B = read_surface(out + "/B.obj");
  BarycentricMap ab = read_map(out + "/truth_AB.txt"), ba = read_map(out + "/truth_BA.txt");
  validate_map(ab, A.num_vertices(), B.num_faces(), 3, "truth_AB");
  validate_map(ba, B.num_vertices(), A.num_faces(), 3, "truth_BA");
  TetMesh TA = read_volume(out + "/A.vtk"), TB = read_volume(out + "/B.vtk");
  BarycentricMap vol = read_map(out + "/truth_vol_AB.txt");
  EXPECT_EQ(vol.size(), TA.num_vertices());
  EXPECT_EQ(vol.arity(), 4);
  EXPECT_LT(vol.elem.maxCoeff(), TB.num_tets());
  // Same seed, same files.
  const std::string out2 = d.p("pair2");
  ASSERT_EQ(run_quiet("--seed 3 generate -o " + out2 + " --shape pair --kind non-isometric --vertices 1500"), 0);
  EXPECT_EQ(slurp(out + "/B.obj"), slurp(out2 + "/B.obj"));
  EXPECT_EQ(slurp(out + "/truth_AB.txt"), slurp(out2 + "/truth_AB.txt"));
}

TEST(CliTetrahedralize, WritesVolumeAndRejectsBadInput) {
  TempDir d("cgal_cli");
  ASSERT_EQ(run_quiet("generate --shape sphere --vertices 800 -o " + d.p("s.obj")), 0);
  ASSERT_EQ(run_quiet("tetrahedralize " + d.p("s.obj") + " -o " + d.p("s.mesh") + " --tets 2000"), 0);
  TetMesh t = read_volume(d.p("s.mesh"));
  EXPECT_GT(t.num_tets(), 2000 / 1.5);
  EXPECT_LT(t.num_tets(), 2000 * 1.5);
  // An open surface: exit 2 and no output.
  {
    std::ofstream o(d.p("open.obj"));
    o << "v 0 0 0\nv 1 0 0\nv 0 1 0\nv 0 0 1\nf 1 3 2\nf 1 2 4\nf 1 4 3\n";
  }
  EXPECT_EQ(run_quiet("tetrahedralize " + d.p("open.obj") + " -o " + d.p("open.vtk")), 2);
  EXPECT_FALSE(fs::exists(d.p("open.vtk")));
  EXPECT_EQ(run_quiet("tetrahedralize " + d.p("missing.obj") + " -o " + d.p("m.vtk")), 2);
  EXPECT_EQ(run_quiet("tetrahedralize " + d.p("s.obj") + " -o " + d.p("s.txt")), 2);
  EXPECT_EQ(run_quiet("tetrahedralize " + d.p("s.obj") + " -o " + d.p("s.vtk") + " --tets 100 --edge-length 0.1"), 2);
}
