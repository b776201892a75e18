// The interactive 3D part of report.html: the geometry a map is judged by, written once as
// binary buffers (little-endian float32 / uint32 / uint8, base64 in OUT/report_data.js, which
// the page loads with a plain <script>, so it opens from file:// with no server), drawn by
// report_viewer.js (src/render/report_viewer.js, embedded at build time) with three.js
// (Debian's libjs-three, copied beside the report).
//
// Three kinds, one builder each:
//   surface: A and B; a checkerboard/colour field of B's positions pulled back to A through
//            the map (and back if B -> A is given); flipped/collapsed faces; landmarks.
//   volume:  tet mesh A and the images X12 of its vertices (and B, X21): a cut through A and
//            the same tets at their images, coloured by det J, inverted tets red.
//   ball:    the input tet mesh and its ball; coloured by the volume distortion D_V.
#pragma once
#include "shapemap/mesh.h"
#include <Eigen/Core>
#include <nlohmann/json.hpp>
#include <string>
#include <vector>

namespace shapemap {

class ViewerData {
 public:
  explicit ViewerData(const std::string& kind);
  // Named buffers; `cols` values per row (the viewer reshapes nothing, it only needs counts).
  void add(const std::string& name, const Eigen::MatrixXd& M);  // float32, row-major
  void add(const std::string& name, const Eigen::MatrixXi& M);  // uint32, row-major (entries >= 0)
  void add(const std::string& name, const std::vector<unsigned char>& v);  // uint8
  nlohmann::json& meta() { return meta_; }  // kind-specific settings (names, ranges, counts)
  // The text of report_data.js: one comment line, then "window.SHAPEMAP_VIEWER = " + a JSON
  // object {meta, layout: {name: {type, rows, cols}}, buffers: {name: base64}} + ";".
  std::string script() const;
  size_t bytes() const;  // raw bytes of all buffers (before base64)

 private:
  struct Buffer {
    std::string name, type;
    int rows, cols;
    std::string bytes;
  };
  nlohmann::json meta_;
  std::vector<Buffer> buffers_;
};

// One direction of a surface map S -> T for the viewer: the images of S's vertices on T
// (n_S×3) and, optionally, per S face 0 fine / 1 flipped / 2 collapsed (fold_counts in
// eval/surface_distortion.h) and per S vertex the error against a ground truth (-1: not
// evaluated).
struct SurfaceMapDirection {
  Eigen::MatrixXd images;
  std::vector<unsigned char> face_flags;
  Eigen::VectorXd vertex_error;
};

// A -> B (and B -> A if BA is given). Landmarks: vertex indices of A and B, paired by
// position in the lists (may be empty).
ViewerData surface_map_viewer(const TriMesh& A, const TriMesh& B, const SurfaceMapDirection& AB,
                              const SurfaceMapDirection* BA, const std::vector<int>& landmarks_A = {},
                              const std::vector<int>& landmarks_B = {});

// A -> B by the images X12 (n_A×3) of A's vertices; B and X21 may be null (one direction).
// det J per tet = signed volume of the image tet / volume of the tet.
ViewerData volume_map_viewer(const TetMesh& A, const Eigen::MatrixXd& X12, const TetMesh* B,
                             const Eigen::MatrixXd* X21);

// The tet mesh and its ball (n×3); D_V per tet (m, Eq. 45 of the ball paper); folded tets
// (non-positive image volume) red.
ViewerData ball_viewer(const TetMesh& mesh, const Eigen::MatrixXd& ball, const Eigen::VectorXd& D_V);

// The viewer's JavaScript (report_viewer.js).
const std::string& report_viewer_js();

// Copies three.js (the non-module build three.min.js) to `path`: from $SHAPEMAP_THREE_JS if
// set, else from where libjs-three installs it. Returns false when it is not found (the
// report then shows its PNGs and says why the 3D views are missing).
bool copy_three_js(const std::string& path);

}  // namespace shapemap
