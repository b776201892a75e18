// `shapemap check`: exit codes and the one-line error contract, run on the real binary.
#include "core/io_test_util.h"
#include "shapemap/io.h"
#include <gtest/gtest.h>
#include <nlohmann/json.hpp>
#include <sys/wait.h>
#include <cstdlib>

using namespace shapemap;
using namespace shapemap::testing;

namespace {

struct CheckRun {
  int code = -1;
  std::string out, err;
};

CheckRun run_check(const std::string& args) {
  std::string o = scratch("cli_out.txt"), e = scratch("cli_err.txt");
  std::string cmd = std::string(SHAPEMAP_BINARY) + " check " + args + " >" + o + " 2>" + e;
  int rc = std::system(cmd.c_str());
  CheckRun r;
  r.code = WIFEXITED(rc) ? WEXITSTATUS(rc) : -1;
  r.out = read_bytes(o);
  r.err = read_bytes(e);
  return r;
}

int lines(const std::string& s) { return int(std::count(s.begin(), s.end(), '\n')); }

}  // namespace

TEST(CliCheck, GarbledFileGivesExit2AndOneLineNamingTheFile) {
  std::string p = scratch("garbled.obj");
  write_file(p, "v 0 0 0\nv 1 0 0\nv 0 1 0\nv 0 0 1\nf 1 3 2\nf 1 2 4\nf 1 4 @#!\nf 2 3 4\n");
  CheckRun r = run_check(p);
  EXPECT_EQ(r.code, 2);
  EXPECT_EQ(lines(r.err), 1) << r.err;
  EXPECT_NE(r.err.find(p + ":7:"), std::string::npos) << r.err;
  // A binary STL cut short.
  std::string s = scratch("cut.stl");
  write_surface(s, octahedron(1.25));
  std::string bytes = read_bytes(s);
  write_file(s, bytes.substr(0, bytes.size() / 2));
  r = run_check(s);
  EXPECT_EQ(r.code, 2);
  EXPECT_EQ(lines(r.err), 1) << r.err;
  EXPECT_NE(r.err.find(s), std::string::npos) << r.err;
  // A missing file and an unknown extension.
  r = run_check(scratch("missing.off"));
  EXPECT_EQ(r.code, 2);
  EXPECT_EQ(lines(r.err), 1) << r.err;
  r = run_check(scratch("x.xyz"));
  EXPECT_EQ(r.code, 2);
  EXPECT_EQ(lines(r.err), 1) << r.err;
}

TEST(CliCheck, ValidMeshesExit0AndJson) {
  std::string p = scratch("octa.off");
  write_surface(p, octahedron());
  CheckRun r = run_check(p);
  EXPECT_EQ(r.code, 0) << r.err;
  EXPECT_NE(r.out.find("genus"), std::string::npos);
  EXPECT_TRUE(r.err.empty()) << r.err;
  r = run_check(p + " --json");
  EXPECT_EQ(r.code, 0);
  nlohmann::json j = nlohmann::json::parse(r.out);
  EXPECT_EQ(j["ok"], true);
  EXPECT_EQ(j["genus"], 0);
  EXPECT_EQ(j["kind"], "surface");
  EXPECT_EQ(j["num_faces"], 8);
  std::string v = scratch("grid.vtk");
  write_volume(v, grid_tets());
  r = run_check(v + " --json");
  EXPECT_EQ(r.code, 0) << r.err;
  j = nlohmann::json::parse(r.out);
  EXPECT_EQ(j["kind"], "volume");
  EXPECT_EQ(j["boundary_components"], 1);
  EXPECT_EQ(j["num_tets"], 162);
}

TEST(CliCheck, MeshWithProblemsExit2) {
  TriMesh m = octahedron();
  m.F.conservativeResize(7, 3);  // a hole
  std::string p = scratch("open.obj");
  write_surface(p, m);
  CheckRun r = run_check(p);
  EXPECT_EQ(r.code, 2);
  EXPECT_EQ(lines(r.err), 1) << r.err;
  EXPECT_NE(r.err.find(p + ": not closed"), std::string::npos) << r.err;
  EXPECT_NE(r.out.find("not closed"), std::string::npos);
}
