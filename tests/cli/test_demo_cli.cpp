// `shapemap demo` end to end on a small generated pair: the whole chain (generate ->
// BIM -> elastic -> volume map from the elastic maps -> ball -> registration -> volume
// map from the registration) must succeed, write every report with its pictures, and
// reach quality that would catch a regression in any stage it chains.
#include <gtest/gtest.h>
#include <nlohmann/json.hpp>
#include <cstdlib>
#include <filesystem>
#include <fstream>
#include <string>
#include <sys/wait.h>
#include <unistd.h>

namespace fs = std::filesystem;

namespace {
nlohmann::json load(const fs::path& p) {
  std::ifstream f(p);
  EXPECT_TRUE(f.good()) << p;
  nlohmann::json j;
  if (f) f >> j;
  return j;
}
}  // namespace

TEST(DemoCli, WholeChainOnASmallPair) {
  const fs::path dir = fs::temp_directory_path() / ("shapemap_demo_" + std::to_string(::getpid()));
  fs::remove_all(dir);
  // 600 vertices and 3000 tets per shape (was 1200 / 8000: 41 s of CPU, now 32 s). The
  // thresholds below hold at both sizes with the same margins; measured here (Dec 2026):
  // BIM within 0.1: 0.970, elastic 1.0 (mean 0.0119, BIM 0.0395); volume map n_inv 0,
  // det 0.990, truth 0.0089; registration n_inv 441, truth 0.068; ball + volume map n_inv 0,
  // truth 0.0108 (at 1200 / 8000: 0.988, 1.0, 0 / 0.988 / 0.0092, 748 / 0.067, 0 / 0.0097).
  const std::string cmd = std::string(SHAPEMAP_BINARY) + " -q demo -o " + dir.string() +
                          " --vertices 600 --tets 3000 > " + (dir.string() + ".log") + " 2>&1";
  int rc = std::system(cmd.c_str());
  ASSERT_TRUE(WIFEXITED(rc));
  ASSERT_EQ(WEXITSTATUS(rc), 0) << "see " << dir.string() << ".log";

  for (const char* f : {"index.html", "summary.txt", "bim/report.html", "bim/texture_AB.png", "elastic/report.html",
                        "elastic/map_BA.txt", "volume/report.html", "volume/slices_AB.png", "volume/B_on_A.vtk",
                        "ball/ball.vtk", "ball/ball.png", "register/map_AB.txt", "register/report.html",
                        "volume_ball/map_AB.txt"})
    EXPECT_TRUE(fs::exists(dir / f)) << f;

  // Surface maps against the generated ground truth (BIM target: >= 0.75 within 0.1 on
  // non-isometric pairs; elastic must not make the geodesic error worse).
  const auto bim = load(dir / "bim/evaluation.json"), el = load(dir / "elastic/evaluation.json");
  const double bim_within = bim["geodesic_error"]["fraction_within_0.1"];
  const double el_within = el["geodesic_error"]["fraction_within_0.1"];
  EXPECT_GE(bim_within, 0.75);
  EXPECT_GE(el_within, 0.75);
  EXPECT_LE(double(el["geodesic_error"]["mean"]), 1.1 * double(bim["geodesic_error"]["mean"]) + 0.005);

  // The volume map from the elastic maps: no inverted tets, volume kept, close to the truth.
  const auto vol = load(dir / "volume/evaluation.json")["metrics"];
  EXPECT_LE(int(vol["n_inv"]), 2);
  EXPECT_GE(double(vol["det_J_mean"]), 0.95);
  EXPECT_LE(double(vol["truth_error_mean"]), 0.03);

  // The ball: on the unit sphere, E_I decreased by the optimization.
  const auto ball = load(dir / "ball/report.json");
  EXPECT_LE(double(ball["metrics"]["boundary_sphere_error"]), 1e-9);
  EXPECT_LT(double(ball["optimization"]["E_I_final"]), double(ball["optimization"]["E_I_after_vsem"]));

  // The registration through the ball, refined by the symmetric volume map (--init ball):
  // fewer inverted tets and closer to the truth than the composed ball maps alone.
  const auto reg = load(dir / "register/evaluation.json")["metrics"];
  const auto vb = load(dir / "volume_ball/evaluation.json")["metrics"];
  EXPECT_LT(int(vb["n_inv"]), int(reg["n_inv"]));
  EXPECT_LT(double(vb["truth_error_mean"]), double(reg["truth_error_mean"]));
  EXPECT_LE(double(vb["truth_error_mean"]), 0.04);
  fs::remove_all(dir);
  fs::remove(dir.string() + ".log");
}
