// A headless software rasterizer: perspective camera, z-buffer, Lambert shading with
// interpolated normals, optional wireframe, supersampling anti-aliasing. No GPU, no
// display. Each triangle carries per-vertex attributes that are interpolated
// perspective-correctly per pixel and turned into a colour by a shader, so textures
// (checkerboards of mapped coordinates) stay sharp.
#pragma once
#include "shapemap/render/image.h"
#include <Eigen/Core>
#include <functional>

namespace shapemap {

struct Camera {
  Eigen::Vector3d eye{0, 0, 5}, center{0, 0, 0}, up{0, 1, 0};
  double fov_deg = 30;
};

// A camera that frames the bounding sphere of V, looking along `view_dir` (from the
// eye towards the centre).
Camera fit_camera(const Eigen::MatrixXd& V, const Eigen::Vector3d& view_dir = Eigen::Vector3d(-0.5, -0.35, -1.0),
                  double margin = 1.1);

struct RenderOptions {
  int width = 480, height = 480;
  int supersample = 3;           // anti-aliasing: render at k× and box-filter down
  Eigen::Vector3f background{1, 1, 1};
  Eigen::Vector3d light_dir{0.4, 0.6, 1.0};  // towards the light, in camera space
  float ambient = 0.35f;         // Lambert: ambient + (1 - ambient) * |n·l|
  float wire_width = 0.8f;       // wireframe line width in output pixels
  Eigen::Vector3f wire_color{0.1f, 0.1f, 0.1f};
};

// Interpolated attributes (attr_dim values) and the face index -> unlit colour.
using Shader = std::function<Eigen::Vector3f(const double* attr, int face)>;

class Rasterizer {
 public:
  Rasterizer(const RenderOptions& opt, const Camera& cam);
  // V n×3, F m×3, A n×k per-vertex attributes (k may be 0). Lit with interpolated
  // vertex normals (two-sided). With wireframe, triangle edges are drawn on top.
  void draw(const Eigen::MatrixXd& V, const Eigen::MatrixXi& F, const Eigen::MatrixXd& A,
            const Shader& shader, bool wireframe = false, bool lit = true);
  // Fraction of (supersampled) pixels covered by any triangle so far.
  double coverage() const;
  Image resolve() const;

 private:
  RenderOptions opt_;
  Camera cam_;
  int W_, H_;
  Eigen::Matrix3d R_;  // world -> camera rotation (rows: right, up, -forward)
  double focal_;
  std::vector<float> depth_;
  std::vector<float> color_;
};

}  // namespace shapemap
