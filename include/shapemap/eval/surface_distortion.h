// Distortion metrics of surface maps, elastic-correspondence.txt Sec. 6.1:
// conformal distortion per triangle (Hormann-Greiner MIPS minus 2), area distortion
// log(a_t / a^_t), mean curvature error |P H~ - H|_X (lumped L2), flipped triangles,
// and reversibility |P Q X - X|_X. (Geodesic errors: eval/surface_metrics.h.)
//
// A map P sends the vertices of the source S (X, F) to points on the target S~
// (X~, F~); a source triangle t is "mapped" to the straight triangle spanned by the
// images of its corners (positions P X~), and compared with t itself.
#pragma once
#include "shapemap/adjacency.h"
#include "shapemap/maps.h"
#include "shapemap/mesh.h"
#include <Eigen/Core>
#include <vector>

namespace shapemap {

struct SurfaceDistortionOptions {
  bool normalize_area = true;    // Sec. 5.2 / 6.1: both meshes scaled to unit area first
  double conformal_cap = 1e4;    // per-triangle MIPS-2 is clamped here (collapsed triangles: inf)
  double min_area_ratio = 1e-8;  // a/a^ clamped to [min, 1/min] before the log
  double degenerate_tol = 1e-12; // mapped triangle collapsed if a_t <= tol * a^_t
};

struct SurfaceDistortion {
  Eigen::VectorXd conformal;     // per source face: sigma1/sigma2 + sigma2/sigma1 - 2 >= 0 (clamped)
  Eigen::VectorXd area;          // per source face: log(a_t / a^_t) (clamped)
  double conformal_mean = 0;     // mean over faces of conformal
  double conformal_median = 0;
  double area_mean_abs = 0;      // mean over faces of |log(a_t / a^_t)|
  double area_median_abs = 0;
  int flipped = 0;               // mapped triangles whose normal opposes the target's surface normal
  int degenerate = 0;            // mapped triangles with (numerically) zero area
  double mean_curvature_error = 0;  // |P H~ - H|_X, Sec. 6.1 (cotangent mean curvature)
};

// Per-face conformal distortion MIPS - 2 = tr(G)/sqrt(det G) - 2 with G = g^{-1} g the
// distortion tensor of rest X (n×3) -> deformed Y (n×3) on faces F (m×3). Collapsed
// triangles get +inf. m×1.
// The same for one face: e1, e2 its rest edge vectors x1 - x0, x2 - x0, d1, d2 their images
// (NaN for a degenerate rest face).
double face_conformal_distortion(const Eigen::Vector3d& e1, const Eigen::Vector3d& e2, const Eigen::Vector3d& d1,
                                 const Eigen::Vector3d& d2);
Eigen::VectorXd conformal_distortion(const Eigen::MatrixXd& X, const Eigen::MatrixXd& Y,
                                     const Eigen::MatrixXi& F);
// Per-face log(area_Y / area_X) (unclamped; -inf for collapsed). m×1.
Eigen::VectorXd area_distortion(const Eigen::MatrixXd& X, const Eigen::MatrixXd& Y,
                                const Eigen::MatrixXi& F);

// Flipped and collapsed triangles only, as surface_distortion counts them, in the frame given
// (no normalization; cheap enough to run every outer iteration of the elastic refinement).
// X n×3, F m×3: the source; Y n×3: positions of its vertices on or near the target (P X~, or
// a deformation); Nt m~×3: unit face normals of the target, Ft m~×3 its faces; P (n): the
// point of the target at (or nearest to) each vertex. Collapsed: a_t <= tol a^_t. Flipped:
// not collapsed and the mapped normal opposes the sum of the target normals at the corners'
// images. The target normal at a point is that of the face P gives for an interior point; for
// a point on an edge or at a vertex (barycentric tolerance 1e-6) it is the normal, among the
// two faces of the edge or all faces around the vertex, that is the most aligned with the
// mapped normal. (Issue 20: the one face P happens to give flagged triangles of the identity
// map at creases and on thin parts, where it can face away from the triangle's own.)
// faces (optional, m): 0 fine, 1 flipped, 2 collapsed.
struct FoldCounts {
  int flipped = 0;
  int degenerate = 0;
  int bad() const { return flipped + degenerate; }
};
// target_vertex_faces (optional): vertex_elements_csr(Ft, number of target vertices), for
// callers that count every iteration (built here when absent).
FoldCounts fold_counts(const Eigen::MatrixXd& X, const Eigen::MatrixXi& F, const Eigen::MatrixXd& Y,
                       const Eigen::MatrixXd& Nt, const Eigen::MatrixXi& Ft, const BarycentricMap& P,
                       double degenerate_tol = 1e-12, std::vector<unsigned char>* faces = nullptr,
                       const VertexElementsCsr* target_vertex_faces = nullptr);

// The class of one source face f as fold_counts gives it: 0 fine, 1 flipped, 2 collapsed (for
// callers that change a few images and recount only the faces around them).
int fold_class(int f, const Eigen::MatrixXd& X, const Eigen::MatrixXi& F, const Eigen::MatrixXd& Y,
               const Eigen::MatrixXd& Nt, const Eigen::MatrixXi& Ft, const BarycentricMap& P, double degenerate_tol,
               const VertexElementsCsr& target_vertex_faces);

// All of the above for the map P: S -> T (P: S.num_vertices() rows onto T's faces).
SurfaceDistortion surface_distortion(const TriMesh& S, const TriMesh& T, const BarycentricMap& P,
                                     const SurfaceDistortionOptions& opt = {});

// |P H~ - H|_X with H, H~ the mean curvatures (geometry/curvature.h) and the lumped mass
// of S, on unit-area copies if normalize_area.
double mean_curvature_error(const TriMesh& S, const TriMesh& T, const BarycentricMap& P,
                            bool normalize_area = true);

// Reversibility |P Q X - X|_X (Sec. 3.2): P: S -> T, Q: T -> S; lumped L2 norm on S,
// on unit-area copies if normalize_area.
double reversibility_error(const TriMesh& S, const TriMesh& T, const BarycentricMap& P,
                           const BarycentricMap& Q, bool normalize_area = true);

// The same round trip per vertex of S, |P Q x - x| over S's bounding-box diagonal: a
// scale-free figure for maps without ground truth (issue 20's camel target).
Eigen::VectorXd round_trip_bbox(const TriMesh& S, const TriMesh& T, const BarycentricMap& P,
                                const BarycentricMap& Q);

}  // namespace shapemap
