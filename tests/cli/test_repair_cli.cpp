// Messy input through the command line: surfaces with a pinched vertex, a floating piece,
// a hole and a duplicate vertex are repaired with one note per change, the outputs keep the
// user's vertex numbering, and --strict refuses with one line naming the file and defects.
// A tet mesh whose parts touch along an edge is split for the ball map.
#include "shapemap/io.h"
#include "shapemap/maps.h"
#include "cli/cli_run.h"
#include "polycube.h"
#include <gtest/gtest.h>
#include <nlohmann/json.hpp>
#include <Eigen/Geometry>
#include <algorithm>
#include <array>
#include <filesystem>
#include <fstream>
#include <string>

namespace fs = std::filesystem;
using namespace shapemap;
using shapemap::testing::TempDir;
using shapemap::testing::slurp;

namespace {

// Runs the binary with stderr (not quiet: the notes) to `err`; returns the exit code.
int run_with_notes(const std::string& args, const std::string& err) {
  const std::string cmd = std::string(SHAPEMAP_BINARY) + " --threads 1 " + args + " > /dev/null 2> " + err;
  const int rc = std::system(cmd.c_str());
  return WIFEXITED(rc) ? WEXITSTATUS(rc) : -1;
}

// The vertex farthest from all of `from` (largest smallest distance).
int farthest(const TriMesh& s, const std::vector<int>& from) {
  int best = 0;
  double best_d = -1;
  for (int i = 0; i < s.V.rows(); ++i) {
    double d = 1e300;
    for (int v : from) d = std::min(d, (s.V.row(i) - s.V.row(v)).squaredNorm());
    if (d > best_d) best_d = d, best = i;
  }
  return best;
}

// A sphere with every defect the repairs handle, each far from the others: vertex `far`
// glued onto vertex 0 (a pinched vertex; far stays in the file, unused), the faces around
// vertex h removed (a hole; h unused), vertex d duplicated (one face uses the copy, the last
// vertex but four), a small tetrahedron floating beside vertex 0 (the last four vertices).
int g_dup = -1;
TriMesh messy(const TriMesh& s) {
  TriMesh m = s;
  const int far = farthest(s, {0}), n = int(s.V.rows());
  const int h = farthest(s, {0, far}), d = farthest(s, {0, far, h});
  g_dup = d;
  std::vector<int> keep;
  for (int f = 0; f < m.F.rows(); ++f) {
    bool hole = false;
    for (int c = 0; c < 3; ++c) {
      if (m.F(f, c) == far) m.F(f, c) = 0;
      hole |= s.F(f, c) == h;
    }
    if (!hole) keep.push_back(f);
  }
  Eigen::MatrixXi F(Eigen::Index(keep.size()) + 4, 3);
  for (size_t k = 0; k < keep.size(); ++k) F.row(Eigen::Index(k)) = m.F.row(keep[k]);
  m.V.conservativeResize(n + 5, 3);
  m.V.row(n) = s.V.row(d);
  for (Eigen::Index f = 0; f < Eigen::Index(keep.size()); ++f)
    if (F(f, 0) == d) {
      F(f, 0) = n;
      break;
    }
  const Eigen::RowVector3d p = s.V.row(0) * 1.2;
  m.V.row(n + 1) = p;
  m.V.row(n + 2) = p + Eigen::RowVector3d(0.03, 0, 0);
  m.V.row(n + 3) = p + Eigen::RowVector3d(0, 0.03, 0);
  m.V.row(n + 4) = p + Eigen::RowVector3d(0, 0, 0.03);
  const int a = n + 1;
  F.bottomRows(4) << a, a + 2, a + 1, a, a + 1, a + 3, a, a + 3, a + 2, a + 1, a + 2, a + 3;
  m.F = F;
  return m;
}

// Seven cubes of side 1 (k^3 Kuhn-subdivided cells each, 6 tets per cell) in a C around an
// empty cube, whose ends touch along the vertical edge at x = 2, y = 1: the boundary has k
// non-manifold edges there.
TetMesh c_shape(int k) {
  const int N = 3 * k + 1, L = k + 1;  // N x N x L grid points
  auto id = [&](int x, int y, int z) { return x + N * (y + N * z); };
  TetMesh M;
  M.V.resize(N * N * L, 3);
  for (int z = 0; z < L; ++z)
    for (int y = 0; y < N; ++y)
      for (int x = 0; x < N; ++x) M.V.row(id(x, y, z)) << double(x) / k, double(y) / k, double(z) / k;
  const std::vector<std::array<int, 2>> cells = {{0, 0}, {1, 0}, {0, 1}, {0, 2}, {1, 2}, {2, 2}, {2, 1}};
  std::vector<std::array<int, 4>> tets;
  const int perms[6][3] = {{0, 1, 2}, {0, 2, 1}, {1, 0, 2}, {1, 2, 0}, {2, 0, 1}, {2, 1, 0}};
  for (int X = 0; X < 3 * k; ++X)
    for (int Y = 0; Y < 3 * k; ++Y) {
      if (std::find(cells.begin(), cells.end(), std::array<int, 2>{X / k, Y / k}) == cells.end()) continue;
      for (int Z = 0; Z < k; ++Z)
        for (const auto& p : perms) {  // Kuhn subdivision: paths from corner 000 to 111
          int xyz[3] = {X, Y, Z};
          std::array<int, 4> tet;
          tet[0] = id(xyz[0], xyz[1], xyz[2]);
          for (int step = 0; step < 3; ++step) {
            ++xyz[p[step]];
            tet[step + 1] = id(xyz[0], xyz[1], xyz[2]);
          }
          const Eigen::RowVector3d a = M.V.row(tet[0]), e1 = M.V.row(tet[1]) - a, e2 = M.V.row(tet[2]) - a,
                                   e3 = M.V.row(tet[3]) - a;
          if (e1.dot(e2.cross(e3)) < 0) std::swap(tet[2], tet[3]);
          tets.push_back(tet);
        }
    }
  // Grid points used by no cell (around the corner x = 3, y = 0) removed.
  std::vector<int> number(M.V.rows(), -1);
  for (const auto& tet : tets)
    for (int v : tet) number[size_t(v)] = 0;
  Eigen::MatrixXd V(M.V.rows(), 3);
  int used = 0;
  for (int v = 0; v < M.V.rows(); ++v)
    if (number[size_t(v)] == 0) V.row(used) = M.V.row(v), number[size_t(v)] = used++;
  M.V = V.topRows(used);
  M.T.resize(Eigen::Index(tets.size()), 4);
  for (size_t i = 0; i < tets.size(); ++i)
    for (int j = 0; j < 4; ++j) M.T(Eigen::Index(i), j) = number[size_t(tets[i][size_t(j)])];
  return M;
}

}  // namespace

TEST(RepairCli, SurfaceMapRepairsAndKeepsTheUsersNumbering) {
  TempDir t("repair_cli");
  ASSERT_EQ(shapemap::testing::run_quiet("generate --shape sphere --vertices 500 -o " + t.p("s.obj")), 0);
  ASSERT_EQ(shapemap::testing::run_quiet("generate --shape ellipsoid --vertices 500 -o " + t.p("B.obj")), 0);
  const TriMesh A = messy(read_surface(t.p("s.obj")));
  write_surface(t.p("A.off"), A);
  const TriMesh B = read_surface(t.p("B.obj"));
  const std::string err = t.p("err.txt");
  ASSERT_EQ(run_with_notes("surface-map " + t.p("A.off") + " " + t.p("B.obj") + " -o " + t.p("out") +
                               " --method bim --symmetric",
                           err),
            0)
      << slurp(err);
  // One note line per change, naming the file.
  const std::string notes = slurp(err);
  EXPECT_NE(notes.find(t.p("A.off") + ": note: "), std::string::npos) << notes;
  for (const char* what : {"1 duplicate vertex merged", "1 non-manifold vertex split", "1 smaller component set aside",
                           "1 small hole filled", "used by no face set aside"})
    EXPECT_NE(notes.find(what), std::string::npos) << what << "\n" << notes;
  // The map files have the users' rows and elements.
  const BarycentricMap ab = read_map(t.p("out/map_AB.txt")), ba = read_map(t.p("out/map_BA.txt"));
  EXPECT_EQ(ab.size(), A.num_vertices());
  EXPECT_NO_THROW(validate_map(ab, A.num_vertices(), B.num_faces(), 3, "map_AB"));
  EXPECT_EQ(ba.size(), B.num_vertices());
  EXPECT_NO_THROW(validate_map(ba, B.num_vertices(), A.num_faces(), 3, "map_BA"));
  const TriMesh AonB = read_surface(t.p("out/A_on_B.obj"));
  EXPECT_EQ(AonB.num_vertices(), A.num_vertices());
  EXPECT_EQ(AonB.F, A.F);
  // The duplicate shares its vertex's row; the floating piece maps near vertex 0's image.
  const int n = int(A.V.rows()) - 5;
  EXPECT_EQ(ab.elem(n), ab.elem(g_dup));
  EXPECT_EQ(ab.bary.row(n), ab.bary.row(g_dup));
  const Eigen::MatrixXd X = map_positions(ab, B.V, B.F);
  EXPECT_LT((X.row(n + 1) - X.row(0)).norm(), 0.3 * (B.V.colwise().maxCoeff() - B.V.colwise().minCoeff()).norm());
  // report.json lists the repairs.
  std::ifstream rj(t.p("out/report.json"));
  const nlohmann::json r = nlohmann::json::parse(rj);
  ASSERT_TRUE(r["inputs"]["repairs"].is_array());
  EXPECT_EQ(r["inputs"]["repairs"].size(), 5u) << r["inputs"]["repairs"].dump();
  EXPECT_EQ(r["inputs"]["A_vertices"], A.num_vertices());

  // --strict: exit 2, one line naming the file and its defects, no output.
  EXPECT_EQ(shapemap::testing::run_stderr("--strict surface-map " + t.p("A.off") + " " + t.p("B.obj") + " -o " +
                                              t.p("strict"),
                                          err),
            2);
  const std::string msg = slurp(err);
  EXPECT_EQ(std::count(msg.begin(), msg.end(), '\n'), 1) << msg;
  EXPECT_NE(msg.find(t.p("A.off") + ": "), std::string::npos) << msg;
  for (const char* what : {"1 duplicate vertex", "1 non-manifold vertex", "not closed", "2 connected components",
                           "(--strict: not repaired)"})
    EXPECT_NE(msg.find(what), std::string::npos) << what << "\n" << msg;
  EXPECT_FALSE(fs::exists(t.dir / "strict"));
}

TEST(RepairCli, BallSplitsTetsTouchingAlongAnEdge) {
  TempDir t("repair_ball_cli");
  const TetMesh M = c_shape(1);
  write_volume(t.p("c.vtk"), M);
  const std::string err = t.p("err.txt");
  // --strict: the defect named.
  EXPECT_EQ(shapemap::testing::run_stderr("--strict ball " + t.p("c.vtk") + " -o " + t.p("strict"), err), 2);
  EXPECT_NE(slurp(err).find(t.p("c.vtk") + ": boundary surface has 1 non-manifold edge and 2 non-manifold vertices"), std::string::npos)
      << slurp(err);
  EXPECT_FALSE(fs::exists(t.dir / "strict"));
  // Repaired: the edge's two vertices split (copies appended), the user's rows first.
  ASSERT_EQ(run_with_notes("ball " + t.p("c.vtk") + " -o " + t.p("b"), err), 0) << slurp(err);
  EXPECT_NE(slurp(err).find("2 vertices split"), std::string::npos) << slurp(err);
  const TetMesh in = read_volume(t.p("b/input.vtk"));
  ASSERT_EQ(in.num_vertices(), M.num_vertices() + 2);
  EXPECT_EQ(in.V.topRows(M.num_vertices()), M.V);
  EXPECT_EQ(read_volume(t.p("b/ball.vtk")).num_vertices(), in.num_vertices());
  std::ifstream rj(t.p("b/report.json"));
  const nlohmann::json r = nlohmann::json::parse(rj);
  EXPECT_EQ(r["inputs"]["repairs"].size(), 1u);
}

TEST(RepairCli, VolumeMapAutoRepairsTheBoundary) {
  // The C's boundary (non-manifold along the touching edge) is repaired for the automatic
  // surface map; the volume map keeps the tet mesh as given. A self-map comes out the identity.
  TempDir t("repair_vm_cli");
  const TetMesh M = c_shape(4);
  write_volume(t.p("c.vtk"), M);
  const std::string err = t.p("err.txt");
  EXPECT_EQ(shapemap::testing::run_stderr("--strict volume-map " + t.p("c.vtk") + " " + t.p("c.vtk") + " -o " +
                                              t.p("strict"),
                                          err),
            2);
  EXPECT_NE(slurp(err).find(t.p("c.vtk") + " (boundary): 4 non-manifold edges"), std::string::npos) << slurp(err);
  ASSERT_EQ(run_with_notes("volume-map " + t.p("c.vtk") + " " + t.p("c.vtk") + " -o " + t.p("v"), err), 0) << slurp(err);
  EXPECT_NE(slurp(err).find(t.p("c.vtk") + " (boundary): note: 4 non-manifold edges"), std::string::npos) << slurp(err);
  const BarycentricMap ab = read_map(t.p("v/map_AB.txt"));
  ASSERT_EQ(ab.size(), M.num_vertices());
  const Eigen::MatrixXd X = map_positions(ab, M.V, M.T);
  EXPECT_LT((X - M.V).rowwise().norm().maxCoeff(), 1e-3);
  std::ifstream rj(t.p("v/report.json"));
  const nlohmann::json r = nlohmann::json::parse(rj);
  EXPECT_EQ(r["inputs"]["repairs"].size(), 2u);  // A's boundary and B's
}

TEST(RepairCli, VolumeMapFromTheSurfaceMapOfAMessySurface) {
  // surface-map writes its maps in the user's numbering of a messy surface; volume-map
  // --init surface-map takes that surface as given (--surface-map-meshes), once its repaired
  // copy is a closed genus-0 surface. It refused it before (its non-manifold vertex).
  TempDir t("repair_vm_smap_cli");
  ASSERT_EQ(shapemap::testing::run_quiet("generate --shape sphere --vertices 500 -o " + t.p("s.obj")), 0);
  ASSERT_EQ(shapemap::testing::run_quiet("generate --shape ellipsoid --vertices 500 -o " + t.p("B.obj")), 0);
  write_surface(t.p("A.off"), messy(read_surface(t.p("s.obj"))));
  const std::string err = t.p("err.txt");
  ASSERT_EQ(run_with_notes("surface-map " + t.p("A.off") + " " + t.p("B.obj") + " -o " + t.p("sm") +
                               " --method bim --symmetric",
                           err),
            0)
      << slurp(err);
  for (const char* s : {"A.off", "B.obj"}) {
    const std::string vtk = t.p(std::string(s) + ".vtk");
    ASSERT_EQ(shapemap::testing::run_quiet("tetrahedralize " + t.p(s) + " --tets 1500 -o " + vtk), 0);
  }
  const std::string args = "volume-map " + t.p("A.off.vtk") + " " + t.p("B.obj.vtk") + " --init surface-map " +
                           "--surface-map " + t.p("sm/map_AB.txt") + " " + t.p("sm/map_BA.txt") +
                           " --surface-map-meshes " + t.p("A.off") + " " + t.p("B.obj") + " -o ";
  ASSERT_EQ(run_with_notes(args + t.p("v"), err), 0) << slurp(err);
  const TetMesh A = read_volume(t.p("A.off.vtk"));
  EXPECT_EQ(read_map(t.p("v/map_AB.txt")).size(), A.num_vertices());
  std::ifstream rj(t.p("v/report.json"));
  const nlohmann::json r = nlohmann::json::parse(rj);
  EXPECT_LE(r["metrics"]["AB"]["n_inv"].get<int>(), 5) << r["metrics"].dump();
  // --strict: the defects of the surface named, exit 2, no output.
  EXPECT_EQ(shapemap::testing::run_stderr("--strict " + args + t.p("strict"), err), 2);
  EXPECT_NE(slurp(err).find(t.p("A.off") + ": "), std::string::npos) << slurp(err);
  EXPECT_FALSE(fs::exists(t.dir / "strict"));
}

TEST(RepairCli, BallOfASurfaceTouchingItself) {
  // A surface that touches itself along an edge: its repair splits the non-manifold edge, the
  // tetrahedralizer meshes it without the manifold criterion, and the tets touching along
  // that edge are split for the ball map as in a given tet mesh (before: "not a ball").
  TempDir t("repair_ball_touching_cli");
  write_surface(t.p("poly.obj"), shapemap::testing::touching_polycube());
  const std::string err = t.p("err.txt");
  ASSERT_EQ(run_with_notes("ball " + t.p("poly.obj") + " --tets 3000 -o " + t.p("b"), err), 0) << slurp(err);
  const std::string notes = slurp(err);
  EXPECT_NE(notes.find(t.p("poly.obj") + ": note: the surface touches itself"), std::string::npos) << notes;
  EXPECT_NE(notes.find("vertices split (copies appended"), std::string::npos) << notes;
  std::ifstream rj(t.p("b/report.json"));
  const nlohmann::json r = nlohmann::json::parse(rj);
  EXPECT_EQ(r["metrics"]["folded_tets"].get<int>(), 0) << r["metrics"].dump();
}
