// Viewer data of report.html: binary buffers + settings as report_data.js (see the header).
#include "shapemap/render/report_viewer.h"
#include "shapemap/render/base64.h"
#include "report_viewer_js.h"  // generated: kReportViewerJs
#include <Eigen/Geometry>
#include <algorithm>
#include <cmath>
#include <cstdint>
#include <cstdlib>
#include <cstring>
#include <filesystem>

#ifndef SHAPEMAP_THREE_JS_PATH
#define SHAPEMAP_THREE_JS_PATH "/usr/share/javascript/three/three.min.js"
#endif

namespace shapemap {

namespace {

// Little-endian bytes of a value (the viewer reads them with typed arrays, which use the
// machine's order; every browser platform is little-endian).
template <typename T>
void put(std::string& out, T v) {
  unsigned char b[sizeof(T)];
  std::memcpy(b, &v, sizeof(T));
#if defined(__BYTE_ORDER__) && __BYTE_ORDER__ == __ORDER_BIG_ENDIAN__
  std::reverse(b, b + sizeof(T));
#endif
  out.append(reinterpret_cast<const char*>(b), sizeof(T));
}

// Bounding box of points: the viewer scales the checkerboard and frames the camera by it.
nlohmann::json bbox(const Eigen::MatrixXd& V) {
  if (V.rows() == 0) return {{"min", {0, 0, 0}}, {"max", {1, 1, 1}}};
  const Eigen::RowVector3d lo = V.colwise().minCoeff(), hi = V.colwise().maxCoeff();
  return {{"min", {lo(0), lo(1), lo(2)}}, {"max", {hi(0), hi(1), hi(2)}}};
}

// Signed volume of the image tet / volume of the tet (det J of the piecewise-linear map).
Eigen::VectorXd det_j(const Eigen::MatrixXd& V, const Eigen::MatrixXi& T, const Eigen::MatrixXd& X) {
  Eigen::VectorXd d(T.rows());
  for (int t = 0; t < T.rows(); ++t) {
    auto vol = [&](const Eigen::MatrixXd& P) {
      const Eigen::RowVector3d a = P.row(T(t, 1)) - P.row(T(t, 0)), b = P.row(T(t, 2)) - P.row(T(t, 0)),
                               c = P.row(T(t, 3)) - P.row(T(t, 0));
      return a.dot(b.cross(c));
    };
    const double v0 = vol(V);
    d(t) = v0 != 0 ? vol(X) / v0 : 0.0;
  }
  return d;
}

// Percentile of finite values (colour ranges that one outlier does not flatten).
double percentile(const Eigen::VectorXd& x, double p) {
  std::vector<double> v;
  for (int i = 0; i < x.size(); ++i)
    if (std::isfinite(x(i))) v.push_back(x(i));
  if (v.empty()) return 0;
  const size_t k = std::min(v.size() - 1, size_t(p * (v.size() - 1) + 0.5));
  std::nth_element(v.begin(), v.begin() + k, v.end());
  return v[k];
}

// One direction S -> X: images, inverted tets (det J <= 0) and the colour scalar per tet
// (det J unless `scalar` is given).
void add_tet_direction(ViewerData& d, const std::string& tag, const TetMesh& S, const Eigen::MatrixXd& X,
                       const Eigen::VectorXd* scalar = nullptr) {
  const Eigen::VectorXd dj = det_j(S.V, S.T, X);
  const Eigen::VectorXd& s = scalar ? *scalar : dj;
  std::vector<unsigned char> bad(dj.size());
  int n_bad = 0;
  for (int t = 0; t < dj.size(); ++t) n_bad += bad[t] = dj(t) <= 0;
  d.add("scalar_" + tag, Eigen::MatrixXd(s));
  d.add("bad_" + tag, bad);
  d.add("X_" + tag, X);
  d.meta()["directions"].push_back({{"tag", tag},
                                    {"bad", n_bad},
                                    {"image_bbox", bbox(X)},
                                    {"scalar_p05", percentile(s, 0.05)},
                                    {"scalar_p95", percentile(s, 0.95)}});
}

}  // namespace

ViewerData::ViewerData(const std::string& kind) { meta_ = {{"kind", kind}}; }

void ViewerData::add(const std::string& name, const Eigen::MatrixXd& M) {
  Buffer b{name, "f32", int(M.rows()), int(M.cols()), {}};
  b.bytes.reserve(size_t(M.size()) * 4);
  for (int i = 0; i < M.rows(); ++i)
    for (int j = 0; j < M.cols(); ++j) put<float>(b.bytes, float(M(i, j)));
  buffers_.push_back(std::move(b));
}

void ViewerData::add(const std::string& name, const Eigen::MatrixXi& M) {
  Buffer b{name, "u32", int(M.rows()), int(M.cols()), {}};
  b.bytes.reserve(size_t(M.size()) * 4);
  for (int i = 0; i < M.rows(); ++i)
    for (int j = 0; j < M.cols(); ++j) put<std::uint32_t>(b.bytes, std::uint32_t(std::max(0, M(i, j))));
  buffers_.push_back(std::move(b));
}

void ViewerData::add(const std::string& name, const std::vector<unsigned char>& v) {
  buffers_.push_back({name, "u8", int(v.size()), 1, std::string(v.begin(), v.end())});
}

size_t ViewerData::bytes() const {
  size_t n = 0;
  for (auto& b : buffers_) n += b.bytes.size();
  return n;
}

std::string ViewerData::script() const {
  nlohmann::json layout = nlohmann::json::object();
  for (auto& b : buffers_) layout[b.name] = {{"type", b.type}, {"rows", b.rows}, {"cols", b.cols}};
  // The object is plain JSON (tools and tests can parse it after the '='); the base64
  // strings are appended directly (no escaping needed) rather than through nlohmann.
  std::string s = "// shapemap report viewer data: geometry as base64 little-endian buffers.\n";
  s += "window.SHAPEMAP_VIEWER = {\"meta\": " + meta_.dump() + ",\n\"layout\": " + layout.dump() +
       ",\n\"buffers\": {";
  for (size_t i = 0; i < buffers_.size(); ++i) {
    const Buffer& b = buffers_[i];
    s += std::string(i ? ",\n" : "\n") + "\"" + b.name + "\": \"" +
         base64_encode(reinterpret_cast<const unsigned char*>(b.bytes.data()), b.bytes.size()) + "\"";
  }
  s += "}};\n";
  return s;
}

ViewerData surface_map_viewer(const TriMesh& A, const TriMesh& B, const SurfaceMapDirection& AB,
                              const SurfaceMapDirection* BA, const std::vector<int>& landmarks_A,
                              const std::vector<int>& landmarks_B) {
  ViewerData d("surface");
  d.add("V_A", A.V);
  d.add("F_A", A.F);
  d.add("V_B", B.V);
  d.add("F_B", B.F);
  auto direction = [&](const std::string& tag, const SurfaceMapDirection& m, int faces) {
    d.add("X_" + tag, m.images);
    int flipped = 0, collapsed = 0;
    if (int(m.face_flags.size()) == faces) {
      for (unsigned char f : m.face_flags) {
        flipped += f == 1;
        collapsed += f == 2;
      }
      if (flipped + collapsed > 0) d.add("flags_" + tag, m.face_flags);
    }
    nlohmann::json dir = {{"tag", tag}, {"flipped", flipped}, {"collapsed", collapsed}};
    if (m.vertex_error.size() == m.images.rows()) {
      d.add("err_" + tag, Eigen::MatrixXd(m.vertex_error));
      Eigen::VectorXd known = m.vertex_error;
      for (int i = 0; i < known.size(); ++i)
        if (known(i) < 0) known(i) = NAN;  // not evaluated: out of the colour range
      dir["error_p95"] = percentile(known, 0.95);
      dir["error_max"] = known.size() ? percentile(known, 1.0) : 0.0;
    }
    d.meta()["directions"].push_back(dir);
  };
  direction("AB", AB, A.num_faces());
  if (BA) direction("BA", *BA, B.num_faces());
  d.meta()["bbox_A"] = bbox(A.V);
  d.meta()["bbox_B"] = bbox(B.V);
  const size_t k = std::min(landmarks_A.size(), landmarks_B.size());
  nlohmann::json lm = nlohmann::json::array();
  for (size_t i = 0; i < k; ++i)
    if (landmarks_A[i] >= 0 && landmarks_A[i] < A.num_vertices() && landmarks_B[i] >= 0 &&
        landmarks_B[i] < B.num_vertices())
      lm.push_back({landmarks_A[i], landmarks_B[i]});
  d.meta()["landmarks"] = lm;
  return d;
}

ViewerData volume_map_viewer(const TetMesh& A, const Eigen::MatrixXd& X12, const TetMesh* B,
                             const Eigen::MatrixXd* X21) {
  ViewerData d("volume");
  d.meta()["scalar"] = "det J";
  d.add("V_A", A.V);
  d.add("T_A", A.T);
  d.meta()["bbox_A"] = bbox(A.V);
  add_tet_direction(d, "AB", A, X12);
  if (B && X21) {
    d.add("V_B", B->V);
    d.add("T_B", B->T);
    d.meta()["bbox_B"] = bbox(B->V);
    add_tet_direction(d, "BA", *B, *X21);
  }
  return d;
}

ViewerData ball_viewer(const TetMesh& mesh, const Eigen::MatrixXd& ball, const Eigen::VectorXd& D_V) {
  ViewerData d("ball");
  d.meta()["scalar"] = "D_V";
  d.add("V_A", mesh.V);
  d.add("T_A", mesh.T);
  d.meta()["bbox_A"] = bbox(mesh.V);
  // Folded tets from det J of the ball map; the colour is D_V.
  add_tet_direction(d, "AB", mesh, ball, &D_V);
  return d;
}

const std::string& report_viewer_js() {
  static const std::string js(kReportViewerJs);
  return js;
}

bool copy_three_js(const std::string& path) {
  namespace fs = std::filesystem;
  const char* env = std::getenv("SHAPEMAP_THREE_JS");
  const fs::path src = env && *env ? fs::path(env) : fs::path(SHAPEMAP_THREE_JS_PATH);
  std::error_code ec;
  if (!fs::is_regular_file(src, ec)) return false;
  fs::copy_file(src, path, fs::copy_options::overwrite_existing, ec);
  return !ec;
}

}  // namespace shapemap
