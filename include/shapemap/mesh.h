// The data model: triangle surfaces and tetrahedral volumes as plain Eigen matrices
// (libigl style), and the boundary surface of a tetrahedral mesh.
#pragma once
#include <Eigen/Core>
#include <string>
#include <vector>

namespace shapemap {

using RowMatrixX3d = Eigen::Matrix<double, Eigen::Dynamic, 3, Eigen::RowMajor>;

// A triangle mesh. V: n×3 vertex positions, F: m×3 vertex indices (counter-clockwise
// seen from outside for closed, outward-oriented surfaces).
struct TriMesh {
  Eigen::MatrixXd V;
  Eigen::MatrixXi F;
  int num_vertices() const { return int(V.rows()); }
  int num_faces() const { return int(F.rows()); }
};

// A tetrahedral mesh. V: n×3, T: m×4 with positive orientation
// det[v1-v0, v2-v0, v3-v0] > 0.
struct TetMesh {
  Eigen::MatrixXd V;
  Eigen::MatrixXi T;
  int num_vertices() const { return int(V.rows()); }
  int num_tets() const { return int(T.rows()); }
};

// The boundary surface of a tet mesh.
struct TetBoundary {
  TriMesh surface;            // boundary faces, outward oriented, on compacted vertices
  Eigen::VectorXi to_volume;  // surface vertex i -> tet-mesh vertex to_volume[i]
  Eigen::VectorXi to_surface; // tet-mesh vertex -> surface vertex, or -1 if interior
  Eigen::VectorXi face_tet;   // boundary face -> the tet it belongs to
};

// Boundary faces of T (faces used by exactly one tet), oriented outward, with the
// vertex maps between volume and surface numbering.
TetBoundary boundary_surface(const TetMesh& mesh);

// Throws InputError("<what>: ...") unless the element list E has `cols` columns and
// every index lies in [0, n): the guard of operators that index vertices by elements.
void require_element_indices(const Eigen::MatrixXi& E, Eigen::Index n, int cols, const char* what);

// Area-weighted and volume-weighted helpers used for normalization.
double surface_area(const Eigen::MatrixXd& V, const Eigen::MatrixXi& F);
double bbox_diagonal(const Eigen::MatrixXd& V);                               // 0 for no rows
double signed_volume(const Eigen::MatrixXd& V, const Eigen::MatrixXi& T);     // sum of tet volumes
double enclosed_volume(const Eigen::MatrixXd& V, const Eigen::MatrixXi& F);   // of a closed surface
Eigen::VectorXd triangle_areas(const Eigen::MatrixXd& V, const Eigen::MatrixXi& F);
Eigen::VectorXd tet_volumes(const Eigen::MatrixXd& V, const Eigen::MatrixXi& T); // signed
// Faces of F whose cone from the origin is positive, V_i . (V_j x V_k) > 0 (the others are
// flat, inverted or NaN): the orientation of a triangle mesh mapped onto a sphere.
int positive_origin_cones(const Eigen::MatrixXd& V, const Eigen::MatrixXi& F);
Eigen::MatrixXd face_normals(const Eigen::MatrixXd& V, const Eigen::MatrixXi& F);   // unit
Eigen::MatrixXd vertex_normals(const Eigen::MatrixXd& V, const Eigen::MatrixXi& F); // area weighted, unit

// A similarity that maps a mesh to a normalized frame: x -> (x - center) * scale.
struct Normalization {
  Eigen::RowVector3d center = Eigen::RowVector3d::Zero();
  double scale = 1.0;
  Eigen::MatrixXd apply(const Eigen::MatrixXd& V) const;
  Eigen::MatrixXd undo(const Eigen::MatrixXd& V) const;
};
// Centered at the area centroid, scaled to unit area (BIM, elastic correspondence).
Normalization unit_area_normalization(const TriMesh& mesh);
// Centered at the volume centroid, scaled to unit volume (symmetric volume maps).
Normalization unit_volume_normalization(const TetMesh& mesh);

}  // namespace shapemap
