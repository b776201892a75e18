// One end-to-end run per command with --threads 1 and --threads 2 on the same inputs and
// seed: every output file must be byte-identical (README: the same output whatever the
// thread count). report.json is compared without its timings and thread count, which are
// the only fields allowed to differ. Small generated shapes keep the set short.
#include "cli_run.h"
#include <gtest/gtest.h>
#include <nlohmann/json.hpp>
#include <algorithm>
#include <filesystem>
#include <fstream>
#include <iterator>
#include <set>
#include <string>
#include <vector>

namespace fs = std::filesystem;
using shapemap::testing::TempDir;
using shapemap::testing::slurp;

namespace {

int run_threads(int threads, const std::string& args) {
  const std::string cmd = std::string(SHAPEMAP_BINARY) + " --threads " + std::to_string(threads) +
                          " -q " + args + " > /dev/null 2>&1";
  const int rc = std::system(cmd.c_str());
  return WIFEXITED(rc) ? WEXITSTATUS(rc) : -1;
}

// Timings, CPU times and the thread count are measured, not computed: dropped.
bool is_measured(const std::string& key) {
  for (const char* k : {"second", "time", "timing", "threads", "cpu", "elapsed"})
    if (key.find(k) != std::string::npos) return true;
  return false;
}
// A table of per-stage seconds (BIM's "stages": {"A/features": 0.006, ...}).
bool is_stage_timings(const std::string& key, const nlohmann::json& v) {
  if (key != "stages" || !v.is_object()) return false;
  for (const auto& e : v)
    if (!e.is_number()) return false;
  return true;
}
nlohmann::json without_measured(const nlohmann::json& j) {
  if (j.is_object()) {
    nlohmann::json out = nlohmann::json::object();
    for (auto it = j.begin(); it != j.end(); ++it)
      if (!is_measured(it.key()) && !is_stage_timings(it.key(), it.value()))
        out[it.key()] = without_measured(it.value());
    return out;
  }
  if (j.is_array()) {
    nlohmann::json out = nlohmann::json::array();
    for (const auto& v : j) out.push_back(without_measured(v));
    return out;
  }
  return j;
}

std::set<std::string> files_below(const fs::path& dir) {
  std::set<std::string> out;
  if (fs::is_regular_file(dir)) return {""};
  for (const auto& e : fs::recursive_directory_iterator(dir))
    if (e.is_regular_file()) out.insert(fs::relative(e.path(), dir).string());
  return out;
}

// Compares two outputs (folders or single files) file by file.
void expect_identical(const fs::path& a, const fs::path& b) {
  const std::set<std::string> fa = files_below(a), fb = files_below(b);
  ASSERT_FALSE(fa.empty()) << a;
  EXPECT_EQ(fa, fb);
  for (const std::string& f : fa) {
    if (!fb.count(f)) continue;
    const fs::path pa = f.empty() ? a : a / f, pb = f.empty() ? b : b / f;
    const std::string name = pa.filename().string();
    if (name == "report.html" || name == "index.html") continue;  // embeds report.json's timings
    if (pa.extension() == ".json") {
      const auto ja = nlohmann::json::parse(slurp(pa)), jb = nlohmann::json::parse(slurp(pb));
      EXPECT_EQ(without_measured(ja), without_measured(jb)) << f;
    } else {
      EXPECT_TRUE(slurp(pa) == slurp(pb)) << f << " differs between --threads 1 and --threads 2";
    }
  }
}

// Runs `args` (with OUT replaced by the output path, ending in ext) at 1 and 2 threads and
// compares.
void expect_same_at_1_and_2_threads(const TempDir& t, const std::string& tag, const std::string& args,
                                    const std::string& ext = "") {
  std::string outs[2];
  for (int k = 0; k < 2; ++k) {
    outs[k] = t.p(tag + "_t" + std::to_string(k + 1) + ext);
    std::string a = args;
    a.replace(a.find("OUT"), 3, outs[k]);
    ASSERT_EQ(run_threads(k + 1, a), 0) << a;
  }
  expect_identical(outs[0], outs[1]);
}

// One small generated pair with tets, shared by the tests below (ctest runs this suite in one
// process: SHAPEMAP_SHARED_FIXTURE_SUITES_cli in CMakeLists.txt).
const TempDir& pair_dir() {
  static TempDir t("threads_pair");
  static const bool made = [] {
    return run_threads(2, "generate --shape pair --kind non-isometric --vertices 600 --tets --tet-count 2000 "
                          "--seed 4 -o " + t.p("pair")) == 0;
  }();
  EXPECT_TRUE(made);
  return t;
}

}  // namespace

TEST(ThreadsIdentical, Generate) {
  TempDir t("threads_generate");
  expect_same_at_1_and_2_threads(t, "gen", "generate --shape pair --vertices 600 --tets --tet-count 2000 --seed 5 -o OUT");
}

TEST(ThreadsIdentical, Tetrahedralize) {
  const TempDir& p = pair_dir();
  TempDir t("threads_tet");
  expect_same_at_1_and_2_threads(t, "tet", "tetrahedralize " + p.p("pair/A.obj") + " -o OUT --tets 2000", ".vtk");
}

// BIM with 128 samples and 1000 candidates (defaults 256, 10000): every stage runs, with
// enough samples and candidates per thread, and the defaults' consistency matrix (10000^2
// products) would be most of the time.
const std::string kFastBim = " --samples 128 --candidates 1000";

TEST(ThreadsIdentical, SurfaceMapBim) {
  const TempDir& p = pair_dir();
  TempDir t("threads_bim");
  expect_same_at_1_and_2_threads(t, "bim", "surface-map " + p.p("pair/A.obj") + " " + p.p("pair/B.obj") +
                                               " -o OUT --method bim --symmetric" + kFastBim);
}

TEST(ThreadsIdentical, SurfaceMapElastic) {
  const TempDir& p = pair_dir();
  TempDir t("threads_elastic");
  expect_same_at_1_and_2_threads(t, "el", "surface-map " + p.p("pair/A.obj") + " " + p.p("pair/B.obj") +
                                              " -o OUT --method elastic --symmetric --elastic-iterations 20" +
                                              kFastBim);
}

TEST(ThreadsIdentical, VolumeMap) {
  const TempDir& p = pair_dir();
  TempDir t("threads_volmap");
  expect_same_at_1_and_2_threads(t, "vm", "volume-map " + p.p("pair/A.vtk") + " " + p.p("pair/B.vtk") +
                                              " -o OUT --init ball --max-iterations 5");
}

TEST(ThreadsIdentical, BallRegisterEvaluateRender) {
  const TempDir& p = pair_dir();
  TempDir t("threads_ball");
  expect_same_at_1_and_2_threads(t, "ball", "ball " + p.p("pair/A.vtk") + " -o OUT --max-iterations 40");
  expect_same_at_1_and_2_threads(t, "reg", "register " + p.p("pair/A.vtk") + " " + p.p("pair/B.vtk") +
                                               " -o OUT --via ball --max-iterations 40");
  expect_same_at_1_and_2_threads(t, "eval", "evaluate ball " + p.p("pair/A.vtk") + " " + t.p("ball_t1/ball.vtk") +
                                                " -o OUT", ".json");
  expect_same_at_1_and_2_threads(t, "eval_s", "evaluate surface " + p.p("pair/A.obj") + " " + p.p("pair/B.obj") +
                                                  " " + p.p("pair/truth_AB.txt") + " --truth " +
                                                  p.p("pair/truth_AB.txt") + " -o OUT", ".json");
  expect_same_at_1_and_2_threads(t, "render", "render " + p.p("pair/A.obj") + " -o OUT --width 64", ".png");
}
