// Software rasterizer: edge functions over the screen-space bounding box of each
// triangle, perspective-correct attribute interpolation, z-buffer, supersampling.
#include "shapemap/render/rasterizer.h"
#include "shapemap/mesh.h"
#include <Eigen/Geometry>
#include <algorithm>
#include <cmath>
#include <limits>

namespace shapemap {

Camera fit_camera(const Eigen::MatrixXd& V, const Eigen::Vector3d& view_dir, double margin) {
  Camera cam;
  Eigen::Vector3d lo = V.colwise().minCoeff(), hi = V.colwise().maxCoeff();
  cam.center = 0.5 * (lo + hi);
  double r = 0;
  for (Eigen::Index i = 0; i < V.rows(); ++i) r = std::max(r, (V.row(i).transpose() - cam.center).norm());
  r = std::max(r, 1e-12) * margin;
  double dist = r / std::sin(0.5 * cam.fov_deg * M_PI / 180.0);
  cam.eye = cam.center - dist * view_dir.normalized();
  cam.up = Eigen::Vector3d(0, 1, 0);
  if (std::abs(view_dir.normalized().dot(cam.up)) > 0.95) cam.up = Eigen::Vector3d(0, 0, 1);
  return cam;
}

Rasterizer::Rasterizer(const RenderOptions& opt, const Camera& cam) : opt_(opt), cam_(cam) {
  W_ = opt.width * opt.supersample;
  H_ = opt.height * opt.supersample;
  Eigen::Vector3d f = (cam.center - cam.eye).normalized();
  Eigen::Vector3d r = f.cross(cam.up).normalized();
  Eigen::Vector3d u = r.cross(f);
  R_.row(0) = r.transpose();
  R_.row(1) = u.transpose();
  R_.row(2) = -f.transpose();
  focal_ = 0.5 * std::min(W_, H_) / std::tan(0.5 * cam.fov_deg * M_PI / 180.0);
  depth_.assign(size_t(W_) * H_, std::numeric_limits<float>::infinity());
  color_.assign(size_t(W_) * H_ * 3, 0.f);
  for (size_t i = 0; i < size_t(W_) * H_; ++i)
    for (int c = 0; c < 3; ++c) color_[3 * i + c] = opt.background[c];
}

void Rasterizer::draw(const Eigen::MatrixXd& V, const Eigen::MatrixXi& F, const Eigen::MatrixXd& A,
                      const Shader& shader, bool wireframe, bool lit) {
  const int n = int(V.rows()), k = int(A.cols());
  // Camera-space positions and normals; screen positions.
  Eigen::MatrixXd C(n, 3), S(n, 3);
  Eigen::MatrixXd N = vertex_normals(V, F);
  for (int i = 0; i < n; ++i) {
    Eigen::Vector3d c = R_ * (V.row(i).transpose() - cam_.eye);
    C.row(i) = c.transpose();
    double z = std::max(-c.z(), 1e-9);  // distance along the view direction
    S(i, 0) = 0.5 * W_ + focal_ * c.x() / z;
    S(i, 1) = 0.5 * H_ - focal_ * c.y() / z;
    S(i, 2) = z;
  }
  Eigen::Vector3d light = opt_.light_dir.normalized();
  const float wire_px = opt_.wire_width * opt_.supersample;
  std::vector<double> attr(std::max(k, 1));
  for (Eigen::Index f = 0; f < F.rows(); ++f) {
    int i0 = F(f, 0), i1 = F(f, 1), i2 = F(f, 2);
    if (C(i0, 2) > -1e-9 || C(i1, 2) > -1e-9 || C(i2, 2) > -1e-9) continue;  // behind the eye
    double x0 = S(i0, 0), y0 = S(i0, 1), x1 = S(i1, 0), y1 = S(i1, 1), x2 = S(i2, 0), y2 = S(i2, 1);
    double area = (x1 - x0) * (y2 - y0) - (x2 - x0) * (y1 - y0);
    if (std::abs(area) < 1e-12) continue;
    int bx0 = std::max(0, int(std::floor(std::min({x0, x1, x2}))));
    int bx1 = std::min(W_ - 1, int(std::ceil(std::max({x0, x1, x2}))));
    int by0 = std::max(0, int(std::floor(std::min({y0, y1, y2}))));
    int by1 = std::min(H_ - 1, int(std::ceil(std::max({y0, y1, y2}))));
    if (bx0 > bx1 || by0 > by1) continue;
    // Heights of the triangle over each edge, for the wireframe distance.
    double e0 = std::hypot(x2 - x1, y2 - y1), e1 = std::hypot(x0 - x2, y0 - y2), e2 = std::hypot(x1 - x0, y1 - y0);
    double h0 = std::abs(area) / std::max(e0, 1e-12), h1 = std::abs(area) / std::max(e1, 1e-12),
           h2 = std::abs(area) / std::max(e2, 1e-12);
    double iz0 = 1.0 / S(i0, 2), iz1 = 1.0 / S(i1, 2), iz2 = 1.0 / S(i2, 2);
    for (int y = by0; y <= by1; ++y) {
      double py = y + 0.5;
      for (int x = bx0; x <= bx1; ++x) {
        double px = x + 0.5;
        double w0 = ((x1 - px) * (y2 - py) - (x2 - px) * (y1 - py)) / area;
        double w1 = ((x2 - px) * (y0 - py) - (x0 - px) * (y2 - py)) / area;
        double w2 = 1.0 - w0 - w1;
        if (w0 < 0 || w1 < 0 || w2 < 0) continue;
        double iz = w0 * iz0 + w1 * iz1 + w2 * iz2;
        float z = float(1.0 / iz);
        size_t pix = size_t(y) * W_ + x;
        if (z >= depth_[pix]) continue;
        depth_[pix] = z;
        // Perspective-correct barycentric coordinates.
        double p0 = w0 * iz0 / iz, p1 = w1 * iz1 / iz, p2 = 1.0 - p0 - p1;
        for (int a = 0; a < k; ++a) attr[a] = p0 * A(i0, a) + p1 * A(i1, a) + p2 * A(i2, a);
        Eigen::Vector3f col = shader ? shader(attr.data(), int(f)) : Eigen::Vector3f(0.8f, 0.8f, 0.8f);
        if (lit) {
          Eigen::Vector3d nrm = p0 * N.row(i0) + p1 * N.row(i1) + p2 * N.row(i2);
          nrm = R_ * nrm;
          double len = nrm.norm();
          double lambert = len > 0 ? std::abs(nrm.dot(light)) / len : 1.0;
          col *= float(opt_.ambient + (1.0 - opt_.ambient) * lambert);
        }
        if (wireframe) {
          double d = std::min({w0 * h0, w1 * h1, w2 * h2});
          if (d < wire_px) col = opt_.wire_color;
        }
        for (int c = 0; c < 3; ++c) color_[3 * pix + c] = col[c];
      }
    }
  }
}

double Rasterizer::coverage() const {
  size_t covered = 0;
  for (float d : depth_) covered += std::isfinite(d);
  return double(covered) / double(depth_.size());
}

Image Rasterizer::resolve() const {
  const int s = opt_.supersample;
  Image img(opt_.width, opt_.height);
  const float inv = 1.0f / float(s * s);
  for (int y = 0; y < opt_.height; ++y)
    for (int x = 0; x < opt_.width; ++x) {
      Eigen::Vector3f acc = Eigen::Vector3f::Zero();
      for (int dy = 0; dy < s; ++dy)
        for (int dx = 0; dx < s; ++dx) {
          size_t pix = size_t(y * s + dy) * W_ + (x * s + dx);
          acc += Eigen::Vector3f(color_[3 * pix], color_[3 * pix + 1], color_[3 * pix + 2]);
        }
      img.at(x, y) = acc * inv;
    }
  return img;
}

}  // namespace shapemap
