// `shapemap ball`, `shapemap register --via ball`, `shapemap evaluate ball`: outputs,
// report fields and exit codes.
#include "cli_run.h"
#include "shapemap/io.h"
#include "volume/ball_test_mesh.h"
#include <gtest/gtest.h>
#include <nlohmann/json.hpp>
#include <cstdlib>
#include <filesystem>
#include <fstream>
#include <string>
#include <unistd.h>

namespace fs = std::filesystem;
using namespace shapemap;
using namespace shapemap::testing;

TEST(CliBall, BallRegisterEvaluateAndBadInput) {
  TempDir tmp("cli_ball");
  const fs::path A = tmp.dir / "a.vtk", B = tmp.dir / "b.vtk", H = tmp.dir / "hollow.vtk";
  const fs::path err = tmp.dir / "err.txt";
  write_volume(A.string(), testing_ball::blob_tets(4, Eigen::Vector3d(1, 0.7, 0.5), 0.1));
  write_volume(B.string(), testing_ball::blob_tets(3, Eigen::Vector3d(1, 0.8, 0.5), 0.0));
  write_volume(H.string(), testing_ball::hollow_cube(4));

  // ball
  const fs::path out = tmp.dir / "ball";
  ASSERT_EQ(run_stderr("ball " + A.string() + " -o " + out.string() + " --max-iterations 50", err), 0) << slurp(err);
  ASSERT_TRUE(fs::exists(out / "ball.vtk"));
  const nlohmann::json j = nlohmann::json::parse(slurp(out / "report.json"));
  EXPECT_EQ(j["metrics"]["folded_tets"].get<int>(), 0);
  EXPECT_LE(j["metrics"]["boundary_sphere_error"].get<double>(), 1e-9);
  EXPECT_LE(j["optimization"]["E_I_final"].get<double>(), j["optimization"]["E_I_after_vsem"].get<double>());
  for (const char* k : {"mean", "sd", "p25", "p50", "p75", "p95"}) EXPECT_TRUE(j["metrics"]["D_V"].contains(k));
  // No inverted tets after the first run: the fold retry did not run.
  EXPECT_FALSE(j["optimization"]["fold_retry"]["ran"].get<bool>());
  const TetMesh ball = read_volume((out / "ball.vtk").string());
  EXPECT_LE(ball.V.rowwise().norm().maxCoeff(), 1.0 + 1e-6);

  // evaluate ball: same metrics from the files.
  const fs::path ev = tmp.dir / "eval.json";
  ASSERT_EQ(run_stderr("evaluate ball " + A.string() + " " + (out / "ball.vtk").string() + " -o " + ev.string(), err), 0)
      << slurp(err);
  const nlohmann::json e = nlohmann::json::parse(slurp(ev));
  EXPECT_NEAR(e["metrics"]["D_V"]["mean"].get<double>(), j["metrics"]["D_V"]["mean"].get<double>(), 1e-6);
  // D_V (Eq. 45) divides by |tau|: an inverted input tet is an input error, not NaN metrics.
  {
    TetMesh a2 = read_volume(A.string()), f2 = ball;
    std::swap(a2.T(0, 2), a2.T(0, 3));
    f2.T = a2.T;
    const fs::path A2 = tmp.dir / "a_inverted.vtk", F2 = tmp.dir / "ball_inverted.vtk";
    write_volume(A2.string(), a2);
    write_volume(F2.string(), f2);
    const fs::path ev2 = tmp.dir / "eval2.json";
    EXPECT_EQ(run_stderr("evaluate ball " + A2.string() + " " + F2.string() + " -o " + ev2.string(), err), 2);
    const std::string m2 = slurp(err);
    EXPECT_NE(m2.find(A2.string()), std::string::npos) << m2;
    EXPECT_EQ(std::count(m2.begin(), m2.end(), '\n'), 1) << m2;
    EXPECT_FALSE(fs::exists(ev2));
  }

  // register with frames
  const fs::path reg = tmp.dir / "reg";
  ASSERT_EQ(run_stderr("register " + A.string() + " " + B.string() + " -o " + reg.string() +
                    " --via ball --frames 3 --max-iterations 30",
                err),
            0)
      << slurp(err);
  for (const char* f : {"map_AB.txt", "A_on_B.vtk", "map_BA.txt", "B_on_A.vtk", "report.json",
                        "frames/frame_000.vtk", "frames/frame_002.vtk"})
    EXPECT_TRUE(fs::exists(reg / f)) << f;
  const nlohmann::json r = nlohmann::json::parse(slurp(reg / "report.json"));
  EXPECT_TRUE(r.contains("d_phi"));
  EXPECT_TRUE(r.contains("metrics_BA"));
  EXPECT_FALSE(fs::exists(reg / "frames/frame_003.vtk"));
  EXPECT_TRUE(r["parameters"]["center"].get<bool>());
  // The frames are H(v, t) = (1 - t) v + t phi(v) (Eq. 46): the middle one is the average of
  // A and A_on_B.
  {
    const TetMesh a = read_volume(A.string()), aob = read_volume((reg / "A_on_B.vtk").string());
    const TetMesh mid = read_volume((reg / "frames/frame_001.vtk").string());
    EXPECT_LT((mid.V - 0.5 * (a.V + aob.V)).cwiseAbs().maxCoeff(), 1e-9);
  }
  // Location report: every boundary vertex of A lies on the sphere, outside B's inscribed
  // polyhedral ball, so it is snapped; interior ones are counted apart.
  const nlohmann::json& loc = r["located_AB"];
  EXPECT_GE(loc["outside_ball_mesh"].get<int>(), r["ball_A"]["metrics"]["num_boundary_vertices"].get<int>() / 2);
  EXPECT_LE(loc["interior_outside_ball_mesh"].get<int>(), loc["outside_ball_mesh"].get<int>());
  EXPECT_GT(loc["max_snap_distance"].get<double>(), 0.0);
  EXPECT_LE(loc["max_snap_distance_interior"].get<double>(), loc["max_snap_distance"].get<double>());
  EXPECT_TRUE(r["located_BA"].contains("interior_outside_ball_mesh"));
  // --no-center: the paper's raw coordinates in the Procrustes step.
  const fs::path reg2 = tmp.dir / "reg_raw";
  ASSERT_EQ(run_stderr("register " + A.string() + " " + B.string() + " -o " + reg2.string() +
                    " --no-center --max-iterations 30",
                err),
            0)
      << slurp(err);
  EXPECT_FALSE(nlohmann::json::parse(slurp(reg2 / "report.json"))["parameters"]["center"].get<bool>());

  // not a ball -> exit 2, one line naming the file, no output folder
  const fs::path bad = tmp.dir / "bad";
  EXPECT_EQ(run_stderr("ball " + H.string() + " -o " + bad.string(), err), 2);
  const std::string msg = slurp(err);
  EXPECT_NE(msg.find(H.string()), std::string::npos) << msg;
  EXPECT_NE(msg.find("boundary"), std::string::npos) << msg;
  EXPECT_EQ(std::count(msg.begin(), msg.end(), '\n'), 1) << msg;
  EXPECT_FALSE(fs::exists(bad));
}

TEST(CliBall, SplitChordsRefinesTheInputAndSaysSo) {
  TempDir tmp("cli_ball");
  const fs::path A = tmp.dir / "a.vtk", err = tmp.dir / "err.txt";
  const TetMesh a = testing_ball::blob_tets(4, Eigen::Vector3d(1, 0.7, 0.5), 0.1);
  write_volume(A.string(), a);
  const fs::path plain = tmp.dir / "plain", split = tmp.dir / "split";
  ASSERT_EQ(run_stderr("ball " + A.string() + " -o " + plain.string() + " --max-iterations 20", err), 0) << slurp(err);
  const nlohmann::json jp = nlohmann::json::parse(slurp(plain / "report.json"));
  const int left = jp["boundary_chords"]["left"].get<int>();
  EXPECT_GT(left, 0);  // Kuhn corner cubes: diagonals between two boundary vertices
  EXPECT_EQ(jp["boundary_chords"]["split"].get<int>(), 0);
  EXPECT_FALSE(fs::exists(plain / "input.vtk"));  // given mesh, unchanged: not copied

  ASSERT_EQ(run_stderr("ball " + A.string() + " -o " + split.string() + " --max-iterations 20 --split-chords", err), 0)
      << slurp(err);
  const nlohmann::json js = nlohmann::json::parse(slurp(split / "report.json"));
  EXPECT_EQ(js["boundary_chords"]["split"].get<int>(), left);
  EXPECT_EQ(js["boundary_chords"]["left"].get<int>(), 0);
  const TetMesh in = read_volume((split / "input.vtk").string());
  const TetMesh ball = read_volume((split / "ball.vtk").string());
  EXPECT_EQ(in.num_vertices(), a.num_vertices() + left);
  EXPECT_EQ(ball.num_vertices(), in.num_vertices());
  EXPECT_EQ(ball.T, in.T);
  EXPECT_TRUE(in.V.topRows(a.num_vertices()).isApprox(a.V));  // old vertices first, unmoved

  // Without --quiet the plain run names the file and the fix on stderr.
  const std::string cmd = std::string(SHAPEMAP_BINARY) + " --threads 1 ball " + A.string() + " -o " +
                          (tmp.dir / "noisy").string() + " --max-iterations 5 2> " + err.string() + " > /dev/null";
  ASSERT_EQ(std::system(cmd.c_str()), 0);
  const std::string msg = slurp(err);
  EXPECT_NE(msg.find(A.string() + ": note: " + std::to_string(left) + " interior edges"), std::string::npos) << msg;
  EXPECT_NE(msg.find("--split-chords"), std::string::npos) << msg;
}
