// shapemap volume-map / evaluate volume: outputs of a small run, and bad input -> exit 2.
#include "shapemap/io.h"
#include "shapemap/maps.h"
#include <nlohmann/json.hpp>
#include "volume/ball_test_mesh.h"
#include "volume/volume_test_util.h"
#include "cli/cli_run.h"
#include <gtest/gtest.h>
#include <cstdlib>
#include <filesystem>
#include <cstdio>
#include <fstream>
#include <string>
#include <unistd.h>

namespace fs = std::filesystem;
using namespace shapemap;

namespace {
int run(const std::string& args) { return shapemap::testing::run_quiet(args); }
struct Files {
  fs::path dir;
  Files() {
    dir = fs::temp_directory_path() / ("shapemap_volmap_cli_" + std::to_string(::getpid()));
    fs::create_directories(dir);
    TetMesh A = test_volume::grid_box(6, 4, 3, 1.0, 0.6, 0.45);
    TetMesh B = test_volume::grid_box(5, 4, 4, 1.0, 0.6, 0.45);
    for (int i = 0; i < B.V.rows(); ++i) B.V(i, 1) += 0.2 * B.V(i, 0) * B.V(i, 0);
    write_volume((dir / "A.mesh").string(), A);
    write_volume((dir / "B.vtk").string(), B);
    auto corners = [](int nx, int ny, int nz) {
      std::string s;
      for (int k : {0, nz})
        for (int j : {0, ny})
          for (int i : {0, nx}) s += std::to_string((k * (ny + 1) + j) * (nx + 1) + i) + "\n";
      return s;
    };
    std::ofstream(dir / "LA.txt") << corners(6, 4, 3);
    std::ofstream(dir / "LB.txt") << corners(5, 4, 4);
    std::ofstream(dir / "LB_short.txt") << "0\n1\n";
    std::string lb = corners(5, 4, 4);
    lb = lb.substr(0, lb.rfind('\n', lb.size() - 2) + 1) + "100000\n";  // 7 valid + 1 out of range
    std::ofstream(dir / "LB_bad.txt") << lb;
  }
  ~Files() { fs::remove_all(dir); }
  std::string p(const std::string& f) const { return (dir / f).string(); }
};
// Mean distance of A's images X to the truth of the bent box, (x, y + 0.2 x^2, z).
double bent_box_error(const TetMesh& A, const Eigen::MatrixXd& X) {
  double err = 0;
  for (int i = 0; i < A.num_vertices(); ++i) {
    const Eigen::RowVector3d t(A.V(i, 0), A.V(i, 1) + 0.2 * A.V(i, 0) * A.V(i, 0), A.V(i, 2));
    err += (X.row(i) - t).norm() / A.num_vertices();
  }
  return err;
}
}  // namespace

TEST(VolumeMapCli, LandmarkRunWritesAllOutputsAndEvaluates) {
  Files f;
  ASSERT_EQ(run("volume-map " + f.p("A.mesh") + " " + f.p("B.vtk") + " -o " + f.p("out") +
                " --init landmarks --landmarks " + f.p("LA.txt") + " " + f.p("LB.txt") + " --max-iterations 10"),
            0);
  for (const char* name : {"map_AB.txt", "map_BA.txt", "A_on_B.vtk", "B_on_A.vtk", "report.json"})
    EXPECT_TRUE(fs::exists(f.dir / "out" / name)) << name;
  // Tet meshes given: they are the user's own files, not copied.
  EXPECT_FALSE(fs::exists(f.dir / "out" / "A.vtk"));
  EXPECT_FALSE(fs::exists(f.dir / "out" / "B.vtk"));
  BarycentricMap m = read_map(f.p("out/map_AB.txt"));
  EXPECT_EQ(m.size(), 7 * 5 * 4);
  EXPECT_EQ(run("evaluate volume " + f.p("A.mesh") + " " + f.p("B.vtk") + " " + f.p("out/map_AB.txt") +
                " --map-ba " + f.p("out/map_BA.txt") + " -o " + f.p("eval.json")),
            0);
  EXPECT_TRUE(fs::exists(f.dir / "eval.json"));
}

TEST(VolumeMapCli, BadInputExitsWithTwo) {
  Files f;
  const std::string AB = "volume-map " + f.p("A.mesh") + " " + f.p("B.vtk") + " -o " + f.p("bad");
  EXPECT_EQ(run(AB + " --landmarks " + f.p("LA.txt") + " " + f.p("LB_short.txt")), 2);
  EXPECT_EQ(run(AB + " --landmarks " + f.p("LA.txt") + " " + f.p("LB_bad.txt")), 2);
  EXPECT_EQ(run(AB + " --init landmarks"), 2);
  // Inputs of another initialization: an error, not silently ignored.
  EXPECT_EQ(run(AB + " --init ball --landmarks " + f.p("LA.txt") + " " + f.p("LB.txt")), 2);
  EXPECT_EQ(run(AB + " --init auto --surface-map " + f.p("LA.txt") + " " + f.p("LB.txt")), 2);
  EXPECT_EQ(run(AB + " --landmarks " + f.p("LA.txt") + " " + f.p("LB.txt") + " --surface-map " + f.p("LA.txt") +
                " " + f.p("LB.txt")),
            2);
  EXPECT_EQ(run("volume-map " + f.p("missing.mesh") + " " + f.p("B.vtk") + " -o " + f.p("bad") +
                " --landmarks " + f.p("LA.txt") + " " + f.p("LB.txt")),
            2);
  EXPECT_FALSE(fs::exists(f.dir / "bad"));
  // --init ball needs topological balls: a cube with a cavity -> exit 2, nothing written.
  write_volume(f.p("hollow.vtk"), testing_ball::hollow_cube(4));
  EXPECT_EQ(run("volume-map " + f.p("A.mesh") + " " + f.p("hollow.vtk") + " -o " + f.p("bad") + " --init ball"), 2);
  EXPECT_FALSE(fs::exists(f.dir / "bad"));
}

// --init ball: both directions from one pair of ball maps (register.h), then Algorithm 1.
// B is A's box remeshed and bent (y += 0.2 x^2), so the truth is known: phi(x, y, z) =
// (x, y + 0.2 x^2, z). Measured mean error 0.0176 (the 8-corner landmark init: 0.0175;
// ball init stopped after 10 outer iterations: 0.084).
TEST(VolumeMapCli, BallInitRecoversTheBend) {
  Files f;
  ASSERT_EQ(run("volume-map " + f.p("A.mesh") + " " + f.p("B.vtk") + " -o " + f.p("ball") + " --init ball"), 0);
  const TetMesh A = read_volume(f.p("A.mesh")), B = read_volume(f.p("B.vtk"));
  const BarycentricMap m = read_map(f.p("ball/map_AB.txt"));
  validate_map(m, A.num_vertices(), B.num_tets(), 4, "map_AB");
  validate_map(read_map(f.p("ball/map_BA.txt")), B.num_vertices(), A.num_tets(), 4, "map_BA");
  const Eigen::MatrixXd X = map_positions(m, B.V, B.T);
  const double err = bent_box_error(A, X);
  std::printf("--init ball on the bent box: mean error %.4f\n", err);
  EXPECT_LT(err, 0.03);
  std::ifstream rep(f.p("ball/report.json"));
  const std::string text((std::istreambuf_iterator<char>(rep)), std::istreambuf_iterator<char>());
  EXPECT_NE(text.find("\"init\": \"ball"), std::string::npos);
}

// --init auto with --landmarks: the landmarks guide the surface map between the boundaries
// (BIM guided by them, anchors of the elastic refinement); the bent box's truth as
// above. Measured mean error 0.0178 (the landmark init 0.0175, the ball 0.0176). Before,
// --init auto refused --landmarks (exit 2).
TEST(VolumeMapCli, AutoInitUsesTheLandmarks) {
  Files f;
  ASSERT_EQ(run("volume-map " + f.p("A.mesh") + " " + f.p("B.vtk") + " -o " + f.p("auto") + " --init auto --landmarks " +
                f.p("LA.txt") + " " + f.p("LB.txt") + " --max-iterations 10"),
            0);
  const TetMesh A = read_volume(f.p("A.mesh")), B = read_volume(f.p("B.vtk"));
  const Eigen::MatrixXd X = map_positions(read_map(f.p("auto/map_AB.txt")), B.V, B.T);
  const double err = bent_box_error(A, X);
  std::printf("--init auto with the 8 corner landmarks on the bent box: mean error %.4f\n", err);
  EXPECT_LT(err, 0.025);
  std::ifstream rep(f.p("auto/report.json"));
  const nlohmann::json r = nlohmann::json::parse(rep);
  const std::string init = r["parameters"]["init"];
  EXPECT_NE(init.find("BIM guided by landmarks"), std::string::npos) << init;
  EXPECT_NE(init.find("8 landmarks as anchors"), std::string::npos) << init;
  EXPECT_EQ(init.find("reverse candidates"), std::string::npos) << init;  // each direction's own blend
  // Too few landmarks for BIM's triplets: exit 2.
  std::ofstream(f.p("L2a.txt")) << "0\n6\n";
  std::ofstream(f.p("L2b.txt")) << "0\n5\n";
  EXPECT_EQ(run("volume-map " + f.p("A.mesh") + " " + f.p("B.vtk") + " -o " + f.p("auto2") + " --init auto --landmarks " +
                f.p("L2a.txt") + " " + f.p("L2b.txt")),
            2);
  EXPECT_FALSE(fs::exists(f.dir / "auto2"));
  // Three landmarks and no --init: the landmark initialization would start every vertex on one of 3
  // points, so they guide --init auto instead (as with any count below 20), with a note; --init
  // landmarks still forces it.
  {
    std::ifstream la(f.p("LA.txt")), lb(f.p("LB.txt"));
    std::ofstream a3(f.p("L3a.txt")), b3(f.p("L3b.txt"));
    std::string line;
    for (int k = 0; k < 3 && std::getline(la, line); ++k) a3 << line << "\n";
    for (int k = 0; k < 3 && std::getline(lb, line); ++k) b3 << line << "\n";
  }
  const std::string three = " --landmarks " + f.p("L3a.txt") + " " + f.p("L3b.txt") + " --max-iterations 3";
  const std::string cmd = std::string(SHAPEMAP_BINARY) + " --threads 1 volume-map " + f.p("A.mesh") + " " +
                          f.p("B.vtk") + " -o " + f.p("auto3") + three + " > /dev/null 2> " + f.p("auto3.err");
  ASSERT_EQ(std::system(cmd.c_str()), 0);
  const std::string note = shapemap::testing::slurp(f.p("auto3.err"));
  EXPECT_NE(note.find("fewer than 20 distinct landmark pairs"), std::string::npos) << note;
  const nlohmann::json r3 = nlohmann::json::parse(shapemap::testing::slurp(f.p("auto3/report.json")));
  const std::string init3 = r3["parameters"]["init"];
  EXPECT_EQ(init3.rfind("auto (BIM guided by landmarks", 0), 0u) << init3;
  ASSERT_EQ(run("volume-map " + f.p("A.mesh") + " " + f.p("B.vtk") + " -o " + f.p("lm3") + " --init landmarks" + three), 0);
  const nlohmann::json l3 = nlohmann::json::parse(shapemap::testing::slurp(f.p("lm3/report.json")));
  EXPECT_EQ(l3["parameters"]["init"], "landmarks");
  // The 8 corners without --init: fewer than 20 pairs on genus-0 boundaries, so the guided
  // automatic start too.
  ASSERT_EQ(run("volume-map " + f.p("A.mesh") + " " + f.p("B.vtk") + " -o " + f.p("auto8") + " --landmarks " +
                f.p("LA.txt") + " " + f.p("LB.txt") + " --max-iterations 3"),
            0);
  const nlohmann::json r8 = nlohmann::json::parse(shapemap::testing::slurp(f.p("auto8/report.json")));
  const std::string init8 = r8["parameters"]["init"];
  EXPECT_EQ(init8.rfind("auto (BIM guided by landmarks", 0), 0u) << init8;
}

// From 4 landmark pairs the default start is the automatic one only where BIM can map the
// boundaries: on a square ring of tets (its boundary a torus) 8 landmarks keep the landmark
// start, without the note.
TEST(VolumeMapCli, FewLandmarksOnARingKeepTheLandmarkStart) {
  shapemap::testing::TempDir t("volmap_cli_ring");
  // The box without its 2 x 2 middle columns of cells.
  const TetMesh box = test_volume::grid_box(6, 6, 1, 1.0, 1.0, 0.2);
  const TetMesh ring = testing_ball::keep_tets(box, [](const Eigen::Vector3d& c) {
    return std::abs(c(0) - 0.5) >= 1.0 / 6 || std::abs(c(1) - 0.5) >= 1.0 / 6;
  });
  const int n = int(ring.V.rows());
  write_volume(t.p("ring.vtk"), ring);
  {
    std::ofstream l(t.p("L.txt"));
    for (int k = 0; k < 8; ++k) l << k * (n / 8) << "\n";
  }
  const std::string cmd = std::string(SHAPEMAP_BINARY) + " --threads 1 volume-map " + t.p("ring.vtk") + " " +
                          t.p("ring.vtk") + " -o " + t.p("out") + " --landmarks " + t.p("L.txt") + " " + t.p("L.txt") +
                          " --max-iterations 1 > /dev/null 2> " + t.p("err.txt");
  ASSERT_EQ(std::system(cmd.c_str()), 0) << shapemap::testing::slurp(t.p("err.txt"));
  EXPECT_EQ(shapemap::testing::slurp(t.p("err.txt")).find("fewer than 20"), std::string::npos);
  const nlohmann::json r = nlohmann::json::parse(shapemap::testing::slurp(t.p("out/report.json")));
  EXPECT_EQ(r["parameters"]["init"], "landmarks");
}

// Stage 5 on a generated pair whose vertex-only post-repair rounds leave inverted tets
// (1,352 / 2,052 surface vertices, 4,523 / 4,585 tets, 8 farthest-point landmarks with
// their true images, as bench/run does): measured 4 inverted tets A->B without the 1-ring
// fallback rounds (d_avg^ 0.001608), 0 with them (0.001651).
TEST(VolumeMapCli, PostRepairFallbackRemovesTheLastInvertedTets) {
  shapemap::testing::TempDir t("volmap_cli_post_repair");
  ASSERT_EQ(run("generate --shape pair --kind non-isometric --vertices 1000 --tets --tet-count 5000 --seed 1 -o " +
                t.p("pair")),
            0);
  const TriMesh A = read_surface(t.p("pair/A.obj")), B = read_surface(t.p("pair/B.obj"));
  const BarycentricMap truth = read_map(t.p("pair/truth_AB.txt"));
  const Eigen::MatrixXd TB = map_positions(truth, B.V, B.F);
  // 8 farthest-point landmarks on A (from the vertex farthest from the centroid).
  int next = 0;
  (A.V.rowwise() - A.V.colwise().mean()).rowwise().squaredNorm().maxCoeff(&next);
  Eigen::VectorXd d = Eigen::VectorXd::Constant(A.num_vertices(), 1e300);
  std::ofstream la(t.p("LA.txt")), lb(t.p("LB.txt"));
  la.precision(17);
  lb.precision(17);
  for (int k = 0; k < 8; ++k) {
    la << A.V(next, 0) << " " << A.V(next, 1) << " " << A.V(next, 2) << "\n";
    lb << TB(next, 0) << " " << TB(next, 1) << " " << TB(next, 2) << "\n";
    d = d.cwiseMin((A.V.rowwise() - A.V.row(next)).rowwise().squaredNorm());
    d.maxCoeff(&next);
  }
  la.close();
  lb.close();
  ASSERT_EQ(run("volume-map " + t.p("pair/A.vtk") + " " + t.p("pair/B.vtk") + " -o " + t.p("out") +
                " --init landmarks --landmarks " + t.p("LA.txt") + " " + t.p("LB.txt")),
            0);
  std::ifstream in(t.p("out/report.json"));
  const nlohmann::json r = nlohmann::json::parse(in);
  // Stage 5 (with its fallback) leaves no inverted tet in X ...
  bool seen = false;
  for (const auto& s : r["algorithm_stages"])
    if (s["name"] == "post-repair") {
      seen = true;
      EXPECT_EQ(s["n_inv_AB"].get<int>(), 0);
      EXPECT_EQ(s["n_inv_BA"].get<int>(), 0);
    }
  EXPECT_TRUE(seen);
  // ... and the landing on the target (issue 19) makes X what the map files hold: one map,
  // one count. The few left are where the mapped boundary folds on the target (measured 7 /
  // 2, tets with 2-3 boundary vertices; stage 5's X located in B had 7 / 2 too).
  for (const char* d : {"AB", "BA"}) {
    EXPECT_EQ(r["metrics"][d]["n_inv"].get<int>(), r["metrics_map_files"][d]["n_inv"].get<int>()) << d;
    EXPECT_LE(r["metrics"][d]["n_inv"].get<int>(), 10) << d;
  }
}

// The scalar field `name` of a VTK file's POINT_DATA (written by write_vtk), n values.
static Eigen::VectorXd point_field(const std::string& path, const std::string& name, int n) {
  std::ifstream in(path);
  std::string word;
  while (in >> word)
    if (word == "POINT_DATA") break;
  while (in >> word)
    if (word == "SCALARS" && (in >> word) && word == name) break;
  std::getline(in, word);  // "double 1"
  std::getline(in, word);  // LOOKUP_TABLE default
  Eigen::VectorXd f(n);
  for (int i = 0; i < n; ++i)
    if (!(in >> f(i))) ADD_FAILURE() << path << ": no " << name << " value " << i;
  return f;
}

// Surface inputs are tetrahedralized inside the command: the tet meshes the maps index are
// written beside them (A.vtk, B.vtk), consistent with map_AB.txt, map_BA.txt and A_on_B.vtk.
TEST(VolumeMapCli, SurfaceInputsWriteTheTetMeshesTheMapsIndex) {
  shapemap::testing::TempDir t("volmap_cli_surface_inputs");
  ASSERT_EQ(run("generate --shape pair --vertices 600 --seed 2 -o " + t.p("pair")), 0);
  const TriMesh A = read_surface(t.p("pair/A.obj")), B = read_surface(t.p("pair/B.obj"));
  const Eigen::MatrixXd TB = map_positions(read_map(t.p("pair/truth_AB.txt")), B.V, B.F);
  {
    std::ofstream la(t.p("LA.txt")), lb(t.p("LB.txt"));
    la.precision(17);
    lb.precision(17);
    // A's landmarks as vertex indices of the surface file (the tet mesh made from it has
    // its own, fewer vertices), B's as positions.
    for (int v : {0, A.num_vertices() / 3, 2 * A.num_vertices() / 3, A.num_vertices() - 1}) {
      la << v << "\n";
      lb << TB(v, 0) << " " << TB(v, 1) << " " << TB(v, 2) << "\n";
    }
  }
  ASSERT_EQ(run("volume-map " + t.p("pair/A.obj") + " " + t.p("pair/B.obj") + " -o " + t.p("out") +
                " --tets 1500 --init landmarks --landmarks " + t.p("LA.txt") + " " + t.p("LB.txt") +
                " --max-iterations 3"),
            0);
  const TetMesh TA = read_volume(t.p("out/A.vtk")), TBm = read_volume(t.p("out/B.vtk"));
  EXPECT_GT(TA.num_tets(), 500);
  EXPECT_GT(TBm.num_tets(), 500);
  validate_map(read_map(t.p("out/map_AB.txt")), TA.num_vertices(), TBm.num_tets(), 4, "map_AB");
  validate_map(read_map(t.p("out/map_BA.txt")), TBm.num_vertices(), TA.num_tets(), 4, "map_BA");
  const TetMesh AonB = read_volume(t.p("out/A_on_B.vtk"));
  EXPECT_EQ(AonB.T, TA.T);
  EXPECT_LT(TA.num_vertices(), A.num_vertices());  // so index 599 is the surface's, not the tets'
  const nlohmann::json r = nlohmann::json::parse(std::ifstream(t.p("out/report.json")));
  EXPECT_EQ(r["inputs"]["landmarks"].size(), 2u);
  // The metrics of the map files as written (images snapped into the target's tets).
  EXPECT_TRUE(r["metrics_map_files"]["AB"].contains("n_inv"));
  // The landing stage (land_on_target, on by default) puts every image inside the target's
  // tets, so writing the map files snaps nothing (measured: 0 both ways).
  EXPECT_LT(r["metrics_map_files"]["max_snap_AB"].get<double>(), 1e-9);
  EXPECT_LT(r["metrics_map_files"]["max_snap_BA"].get<double>(), 1e-9);
  EXPECT_EQ(run("evaluate volume " + t.p("out/A.vtk") + " " + t.p("out/B.vtk") + " " + t.p("out/map_AB.txt") +
                " -o " + t.p("eval.json")),
            0);
  // A_on_B.vtk's per-vertex round trip: A's vertex through map_AB, then map_BA's images of
  // B's vertices, back in A, against where it started.
  const Eigen::MatrixXd XBA = map_positions(read_map(t.p("out/map_BA.txt")), TA.V, TA.T);
  const Eigen::MatrixXd back = map_positions(read_map(t.p("out/map_AB.txt")), XBA, TBm.T);
  const Eigen::VectorXd rt = point_field(t.p("out/A_on_B.vtk"), "round_trip", TA.num_vertices());
  double mx = 0;
  for (int v = 0; v < TA.num_vertices(); ++v) {
    EXPECT_NEAR(rt(v), (back.row(v) - TA.V.row(v)).norm(), 1e-9);
    mx = std::max(mx, rt(v));
  }
  EXPECT_GT(mx, 0);
  const nlohmann::json& m = r["metrics"]["AB"];
  EXPECT_NEAR(m["round_trip_max_hat"].get<double>(), mx / bbox_diagonal(TA.V), 1e-9);
  EXPECT_GE(m["E_R_boundary_share"].get<double>(), 0);
  EXPECT_LE(m["E_R_boundary_share"].get<double>(), 1);
}
