// The rasterizer and scenes, checked by pixel statistics on scenes whose answer is
// known in closed form.
#include "shapemap/generate.h"
#include "shapemap/render/rasterizer.h"
#include "shapemap/render/report_html.h"
#include "shapemap/render/scenes.h"
#include <gtest/gtest.h>
#include <cmath>

using namespace shapemap;

namespace {
int count_pixels(const Image& img, const std::function<bool(const Eigen::Vector3f&)>& pred) {
  int n = 0;
  for (int y = 0; y < img.height; ++y)
    for (int x = 0; x < img.width; ++x) n += pred(img.at(x, y));
  return n;
}
bool is_red(const Eigen::Vector3f& c) { return c[0] > 0.3f && c[1] < 0.15f * c[0] + 0.05f && c[2] < 0.15f * c[0] + 0.05f; }
}  // namespace

TEST(Rasterizer, SphereCoversItsProjectedDisk) {
  TriMesh s = make_sphere(5000, 1.0);
  RenderOptions ro;
  ro.width = ro.height = 200;
  ro.supersample = 2;
  Camera cam = fit_camera(s.V, Eigen::Vector3d(0, 0, -1));
  Rasterizer r(ro, cam);
  Eigen::Vector3f red(0.9f, 0.0f, 0.0f);
  r.draw(s.V, s.F, Eigen::MatrixXd(s.V.rows(), 0), [&](const double*, int) { return red; }, false, false);
  Image img = r.resolve();
  // Exact silhouette of a unit sphere seen from distance d: angular radius asin(1/d).
  double d = (cam.eye - cam.center).norm();
  double focal = 0.5 * ro.width / std::tan(0.5 * cam.fov_deg * M_PI / 180.0);
  double R = focal * std::tan(std::asin(1.0 / d));
  double expected = M_PI * R * R / (ro.width * ro.height);
  double got = double(count_pixels(img, is_red)) / (ro.width * ro.height);
  EXPECT_NEAR(got, expected, 0.02 * expected);
  EXPECT_NEAR(r.coverage(), expected, 0.02 * expected);
}

TEST(Rasterizer, NearerTriangleWins) {
  // Two parallel squares, the red one nearer to the camera, both covering the centre.
  Eigen::MatrixXd V(8, 3);
  V << -1, -1, 0, 1, -1, 0, 1, 1, 0, -1, 1, 0, -0.5, -0.5, 1, 0.5, -0.5, 1, 0.5, 0.5, 1, -0.5, 0.5, 1;
  Eigen::MatrixXi F(4, 3);
  F << 0, 1, 2, 0, 2, 3, 4, 5, 6, 4, 6, 7;
  Camera cam;
  cam.eye = Eigen::Vector3d(0, 0, 6);
  RenderOptions ro;
  ro.width = ro.height = 64;
  Rasterizer r(ro, cam);
  // Draw the near one first so the z-test, not the order, decides.
  r.draw(V, F.bottomRows(2), Eigen::MatrixXd(8, 0), [](const double*, int) { return Eigen::Vector3f(1, 0, 0); },
         false, false);
  r.draw(V, F.topRows(2), Eigen::MatrixXd(8, 0), [](const double*, int) { return Eigen::Vector3f(0, 0, 1); },
         false, false);
  Image img = r.resolve();
  EXPECT_TRUE(is_red(img.at(32, 32)));
  Eigen::Vector3f corner = img.at(12, 12);  // only the far square there
  EXPECT_GT(corner[2], 0.9f);
}

TEST(Scenes, TextureTransferIdentityMatchesTarget) {
  TriMesh s = make_sphere(2000, 1.0);
  SceneOptions so;
  so.render.width = so.render.height = 120;
  Image img = render_texture_transfer(s, s, s.V, so);
  // Identity map: the two panels are the same picture.
  int w = (img.width - 6) / 2;
  double diff = 0;
  for (int y = 26; y < img.height; ++y)
    for (int x = 0; x < w; ++x) diff += (img.at(x, y) - img.at(x + w + 6, y)).norm();
  EXPECT_LT(diff / (w * (img.height - 26)), 1e-6);
  // Both checker colours appear.
  int orange = count_pixels(img, [](const Eigen::Vector3f& c) { return c[0] > c[2] + 0.2f; });
  int blue = count_pixels(img, [](const Eigen::Vector3f& c) { return c[2] > c[0] + 0.2f; });
  EXPECT_GT(orange, 500);
  EXPECT_GT(blue, 500);
}

TEST(Scenes, InvertedTetsAreRed) {
  // A cube of 6 tets; mapping it by a reflection inverts every tet.
  TetMesh cube;
  cube.V.resize(8, 3);
  cube.V << 0, 0, 0, 1, 0, 0, 1, 1, 0, 0, 1, 0, 0, 0, 1, 1, 0, 1, 1, 1, 1, 0, 1, 1;
  cube.T.resize(6, 4);
  cube.T << 0, 1, 2, 6, 0, 2, 3, 6, 0, 3, 7, 6, 0, 7, 4, 6, 0, 4, 5, 6, 0, 5, 1, 6;
  Eigen::VectorXd vol = tet_volumes(cube.V, cube.T);
  for (int t = 0; t < 6; ++t)
    if (vol(t) < 0) std::swap(cube.T(t, 2), cube.T(t, 3));
  SceneOptions so;
  so.render.width = so.render.height = 100;
  Image good = render_volume_slices(cube, cube.V, 2, so);
  Eigen::MatrixXd X = cube.V;
  X.col(0) *= -1;
  Image bad = render_volume_slices(cube, X, 2, so);
  EXPECT_EQ(count_pixels(good, is_red), 0);
  EXPECT_GT(count_pixels(bad, is_red), 1000);
}

TEST(Scenes, ScalarBarAndHtml) {
  TriMesh s = make_sphere(1000, 1.0);
  SceneOptions so;
  so.render.width = so.render.height = 100;
  Image img = render_scalar(s, s.V.col(2), "z", so);
  EXPECT_EQ(img.width, 210);
  std::vector<unsigned char> png = encode_png(img);
  ASSERT_GT(png.size(), 8u);
  EXPECT_EQ(png[1], 'P');
  nlohmann::json j;
  j["metric"] = 1.5;
  std::string html = report_html("t", j, {{"sphere", img}});
  EXPECT_NE(html.find("data:image/png;base64,iVBORw0KGgo"), std::string::npos);
  EXPECT_NE(html.find("metric"), std::string::npos);
}
