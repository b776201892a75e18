// Scenes that show maps the way the papers do: scalar fields with a colour bar,
// checkerboard texture transfer and normal transfer through a surface map
// (elastic correspondence Sec. 6.1), landmarks as spheres, checkerboards on slices of
// a volume pushed through a volume map with inverted tets in red (symmetric volume
// maps Sec. 6.1), and the ball of a ball parameterization cut open.
#pragma once
#include "shapemap/maps.h"
#include "shapemap/mesh.h"
#include "shapemap/render/rasterizer.h"
#include <string>
#include <vector>

namespace shapemap {

struct SceneOptions {
  RenderOptions render;
  Eigen::Vector3d view_dir{-0.5, -0.35, -1.0};
  bool wireframe = false;
  int checker_squares = 10;  // checkerboard squares across the target's extent
};

// A per-vertex (size n) or per-face (size m) scalar with a colour bar.
Image render_scalar(const TriMesh& mesh, const Eigen::VectorXd& values, const std::string& label,
                    const SceneOptions& opt = {}, double vmin = NAN, double vmax = NAN);

// Planar-projected checkerboard texture on the target B (projection onto B's two
// principal axes) and the same texture pulled back to A through mapped positions
// (n_A×3 points on B, e.g. map_positions). Returns panels: target | source.
Image render_texture_transfer(const TriMesh& A, const TriMesh& B, const Eigen::MatrixXd& A_on_B,
                              const SceneOptions& opt = {});

// Normal transfer: A coloured by the normals of B at the mapped points (RGB = n/2+1/2).
Image render_normal_transfer(const TriMesh& A, const TriMesh& B, const BarycentricMap& map_AB,
                             const SceneOptions& opt = {});

// The mesh in grey with landmarks as coloured spheres (colour by landmark index).
Image render_landmarks(const TriMesh& mesh, const std::vector<int>& landmarks,
                       const SceneOptions& opt = {});

// A volume map: the source cut by a plane through its centroid (normal `axis`),
// the remaining half's boundary and cut face coloured by a 3D checkerboard of the
// mapped positions X (n×3, in the target's frame); tets with det J <= 0 in red.
Image render_volume_slices(const TetMesh& source, const Eigen::MatrixXd& X, int axis = 2,
                           const SceneOptions& opt = {});

// A ball parameterization: the ball (positions `ball`, n×3) cut open, coloured by a
// 3D checkerboard of the original positions, folded tets in red.
Image render_ball(const TetMesh& mesh, const Eigen::MatrixXd& ball, const SceneOptions& opt = {});

// A plain shaded mesh (optionally wireframe) in a flat colour.
Image render_mesh(const TriMesh& mesh, const SceneOptions& opt = {},
                  const Eigen::Vector3f& color = Eigen::Vector3f(0.75f, 0.78f, 0.85f));

}  // namespace shapemap
