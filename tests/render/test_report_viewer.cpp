// report_data.js of the interactive report: base64, buffer layout, det J / inverted flags,
// and the table's JSON pointers. (The page itself is tested in a browser: tests/browser.)
#include "shapemap/render/base64.h"
#include "shapemap/render/report_html.h"
#include "shapemap/render/report_viewer.h"
#include <gtest/gtest.h>
#include <cstring>

using namespace shapemap;

namespace {
// The JSON object after "window.SHAPEMAP_VIEWER = ".
nlohmann::json parse_script(const std::string& s) {
  const std::string key = "window.SHAPEMAP_VIEWER = ";
  const size_t a = s.find(key);
  EXPECT_NE(a, std::string::npos);
  const size_t b = s.rfind("};");
  return nlohmann::json::parse(s.substr(a + key.size(), b + 1 - a - key.size()));
}
std::vector<unsigned char> decode(const std::string& b64) {
  auto val = [](char c) -> int {
    if (c >= 'A' && c <= 'Z') return c - 'A';
    if (c >= 'a' && c <= 'z') return c - 'a' + 26;
    if (c >= '0' && c <= '9') return c - '0' + 52;
    return c == '+' ? 62 : 63;
  };
  std::vector<unsigned char> out;
  for (size_t i = 0; i + 3 < b64.size(); i += 4) {
    const unsigned v = val(b64[i]) << 18 | val(b64[i + 1]) << 12 | (b64[i + 2] == '=' ? 0 : val(b64[i + 2]) << 6) |
                       (b64[i + 3] == '=' ? 0 : val(b64[i + 3]));
    out.push_back(v >> 16 & 255);
    if (b64[i + 2] != '=') out.push_back(v >> 8 & 255);
    if (b64[i + 3] != '=') out.push_back(v & 255);
  }
  return out;
}
template <typename T>
std::vector<T> values(const nlohmann::json& j, const std::string& name) {
  const std::vector<unsigned char> b = decode(j["buffers"][name].get<std::string>());
  std::vector<T> v(b.size() / sizeof(T));
  std::memcpy(v.data(), b.data(), v.size() * sizeof(T));
  return v;
}
TetMesh two_tets() {
  TetMesh m;
  m.V.resize(5, 3);
  m.V << 0, 0, 0, 1, 0, 0, 0, 1, 0, 0, 0, 1, 1, 1, 1;
  m.T.resize(2, 4);
  m.T << 0, 1, 2, 3, 1, 2, 3, 4;  // both positively oriented
  return m;
}
}  // namespace

TEST(ReportViewer, Base64MatchesRfc4648Vectors) {
  auto enc = [](const std::string& s) { return base64_encode(reinterpret_cast<const unsigned char*>(s.data()), s.size()); };
  EXPECT_EQ(enc(""), "");
  EXPECT_EQ(enc("f"), "Zg==");
  EXPECT_EQ(enc("fo"), "Zm8=");
  EXPECT_EQ(enc("foo"), "Zm9v");
  EXPECT_EQ(enc("foobar"), "Zm9vYmFy");
}

TEST(ReportViewer, VolumeDataHasDetJAndInvertedTets) {
  const TetMesh A = two_tets();
  Eigen::MatrixXd X = 2.0 * A.V;  // det J = 8 everywhere
  X(4, 0) = X(4, 1) = X(4, 2) = -1;  // ... except the second tet, turned inside out
  const ViewerData d = volume_map_viewer(A, X, nullptr, nullptr);
  const nlohmann::json j = parse_script(d.script());
  EXPECT_EQ(j["meta"]["kind"], "volume");
  EXPECT_EQ(j["layout"]["T_A"]["type"], "u32");
  EXPECT_EQ(j["layout"]["T_A"]["rows"], 2);
  EXPECT_EQ(j["layout"]["T_A"]["cols"], 4);
  const auto det = values<float>(j, "scalar_AB");
  const auto bad = values<unsigned char>(j, "bad_AB");
  ASSERT_EQ(det.size(), 2u);
  EXPECT_FLOAT_EQ(det[0], 8.0f);
  EXPECT_LT(det[1], 0.0f);
  EXPECT_EQ(bad, (std::vector<unsigned char>{0, 1}));
  EXPECT_EQ(j["meta"]["directions"][0]["bad"], 1);
  EXPECT_EQ(values<std::uint32_t>(j, "T_A")[5], std::uint32_t(A.T(1, 1)));
  EXPECT_EQ(values<float>(j, "X_AB")[12], -1.0f);
  EXPECT_EQ(d.bytes(), size_t(5 * 3 * 4 + 2 * 4 * 4 + 5 * 3 * 4 + 2 * 4 + 2));
}

TEST(ReportViewer, BallColoursByTheGivenScalar) {
  const TetMesh A = two_tets();
  const ViewerData d = ball_viewer(A, A.V, Eigen::Vector2d(0.25, 3.0));
  const nlohmann::json j = parse_script(d.script());
  EXPECT_EQ(j["meta"]["kind"], "ball");
  EXPECT_EQ(values<float>(j, "scalar_AB"), (std::vector<float>{0.25f, 3.0f}));
  EXPECT_EQ(j["meta"]["directions"][0]["bad"], 0);
}

TEST(ReportViewer, SurfaceDataKeepsOnlyFlagsThatAreSet) {
  TriMesh A;
  A.V = Eigen::MatrixXd::Identity(3, 3);
  A.F.resize(1, 3);
  A.F << 0, 1, 2;
  SurfaceMapDirection ab{A.V, {0}, Eigen::Vector3d(0.1, -1, 0.3)};
  SurfaceMapDirection ba{A.V, {1}};
  const nlohmann::json j = parse_script(surface_map_viewer(A, A, ab, &ba, {0, 2}, {1, 7}).script());
  EXPECT_FALSE(j["buffers"].contains("flags_AB"));  // nothing to highlight
  EXPECT_TRUE(j["buffers"].contains("flags_BA"));
  EXPECT_EQ(j["meta"]["directions"][1]["flipped"], 1);
  EXPECT_EQ(j["meta"]["landmarks"].size(), 1u);  // vertex 7 does not exist: the pair is dropped
  // Errors against the truth: -1 (not evaluated) stays out of the colour range.
  EXPECT_EQ(values<float>(j, "err_AB"), (std::vector<float>{0.1f, -1.0f, 0.3f}));
  EXPECT_DOUBLE_EQ(j["meta"]["directions"][0]["error_max"].get<double>(), 0.3);
  EXPECT_FALSE(j["buffers"].contains("err_BA"));
}

TEST(ReportViewer, TableCellsCarryTheJsonPointerOfTheirValue) {
  nlohmann::json j;
  j["metrics"]["a/b"] = 1.5;
  j["list"] = {1, 2};
  const std::string html = report_html("t", j, {}, true);
  EXPECT_NE(html.find("data-ptr=\"/metrics/a~1b\">1.5<"), std::string::npos);
  EXPECT_NE(html.find("<script src=\"three.min.js\"></script>"), std::string::npos);
  EXPECT_NE(html.find("id=\"views\""), std::string::npos);
  EXPECT_EQ(report_html("t", j, {}).find("three.min.js"), std::string::npos);
}
