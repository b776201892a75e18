// `shapemap ball`, `shapemap register --via ball`, `shapemap evaluate ball`: outputs,
// report fields and exit codes.
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

namespace {

struct TempDir {
  fs::path path;
  TempDir() {
    path = fs::temp_directory_path() / ("shapemap_cli_ball_" + std::to_string(getpid()));
    fs::remove_all(path);
    fs::create_directories(path);
  }
  ~TempDir() { fs::remove_all(path); }
};

int run(const std::string& args, const fs::path& err) {
  const std::string cmd = std::string(SHAPEMAP_BINARY) + " --quiet --threads 1 " + args + " 2> " + err.string();
  const int st = std::system(cmd.c_str());
  return WIFEXITED(st) ? WEXITSTATUS(st) : -1;
}

std::string slurp(const fs::path& p) {
  std::ifstream f(p);
  return std::string(std::istreambuf_iterator<char>(f), {});
}

}  // namespace

TEST(CliBall, BallRegisterEvaluateAndBadInput) {
  TempDir tmp;
  const fs::path A = tmp.path / "a.vtk", B = tmp.path / "b.vtk", H = tmp.path / "hollow.vtk";
  const fs::path err = tmp.path / "err.txt";
  write_volume(A.string(), testing_ball::blob_tets(4, Eigen::Vector3d(1, 0.7, 0.5), 0.1));
  write_volume(B.string(), testing_ball::blob_tets(3, Eigen::Vector3d(1, 0.8, 0.5), 0.0));
  write_volume(H.string(), testing_ball::hollow_cube(4));

  // ball
  const fs::path out = tmp.path / "ball";
  ASSERT_EQ(run("ball " + A.string() + " -o " + out.string() + " --max-iterations 50", err), 0) << slurp(err);
  ASSERT_TRUE(fs::exists(out / "ball.vtk"));
  const nlohmann::json j = nlohmann::json::parse(slurp(out / "report.json"));
  EXPECT_EQ(j["metrics"]["folded_tets"].get<int>(), 0);
  EXPECT_LE(j["metrics"]["boundary_sphere_error"].get<double>(), 1e-9);
  EXPECT_LE(j["optimization"]["E_I_final"].get<double>(), j["optimization"]["E_I_after_vsem"].get<double>());
  for (const char* k : {"mean", "sd", "p25", "p50", "p75", "p95"}) EXPECT_TRUE(j["metrics"]["D_V"].contains(k));
  const TetMesh ball = read_volume((out / "ball.vtk").string());
  EXPECT_LE(ball.V.rowwise().norm().maxCoeff(), 1.0 + 1e-6);

  // evaluate ball: same metrics from the files.
  const fs::path ev = tmp.path / "eval.json";
  ASSERT_EQ(run("evaluate ball " + A.string() + " " + (out / "ball.vtk").string() + " -o " + ev.string(), err), 0)
      << slurp(err);
  const nlohmann::json e = nlohmann::json::parse(slurp(ev));
  EXPECT_NEAR(e["metrics"]["D_V"]["mean"].get<double>(), j["metrics"]["D_V"]["mean"].get<double>(), 1e-6);

  // register with frames
  const fs::path reg = tmp.path / "reg";
  ASSERT_EQ(run("register " + A.string() + " " + B.string() + " -o " + reg.string() +
                    " --via ball --frames 3 --max-iterations 30",
                err),
            0)
      << slurp(err);
  for (const char* f : {"map_AB.txt", "A_on_B.vtk", "report.json", "frames/frame_000.vtk", "frames/frame_002.vtk"})
    EXPECT_TRUE(fs::exists(reg / f)) << f;
  const nlohmann::json r = nlohmann::json::parse(slurp(reg / "report.json"));
  EXPECT_TRUE(r.contains("d_phi"));

  // not a ball -> exit 2, one line naming the file, no output folder
  const fs::path bad = tmp.path / "bad";
  EXPECT_EQ(run("ball " + H.string() + " -o " + bad.string(), err), 2);
  const std::string msg = slurp(err);
  EXPECT_NE(msg.find(H.string()), std::string::npos) << msg;
  EXPECT_NE(msg.find("boundary"), std::string::npos) << msg;
  EXPECT_EQ(std::count(msg.begin(), msg.end(), '\n'), 1) << msg;
  EXPECT_FALSE(fs::exists(bad));
}
