#include "figures.h"

#include "shapemap/eval/surface_distortion.h"
#include "shapemap/render/scenes.h"

namespace shapemap::cli {

std::vector<ReportFigure> surface_map_figures(const TriMesh& A, const TriMesh& B, const BarycentricMap& map_AB,
                                              const BarycentricMap* map_BA) {
  std::vector<ReportFigure> figs;
  figs.push_back({"texture_AB.png", "Checkerboard on B (left) pulled back to A through map_AB (right)",
                  render_texture_transfer(A, B, map_positions(map_AB, B.V, B.F))});
  figs.push_back({"normals_AB.png", "Normal transfer: A coloured by the normals of B at the mapped points",
                  render_normal_transfer(A, B, map_AB)});
  if (map_BA) {
    figs.push_back({"texture_BA.png", "Checkerboard on A (left) pulled back to B through map_BA (right)",
                    render_texture_transfer(B, A, map_positions(*map_BA, A.V, A.F))});
  }
  return figs;
}

std::vector<ReportFigure> volume_map_figures(const TetMesh& A, const Eigen::MatrixXd& X12, const TetMesh* B,
                                             const Eigen::MatrixXd* X21) {
  std::vector<ReportFigure> figs;
  figs.push_back({"slices_AB.png",
                  "A cut at its centroid, coloured by a 3D checkerboard of its image in B (inverted tets red)",
                  hconcat({render_volume_slices(A, X12, 2), render_volume_slices(A, X12, 0)},
                          {"A -> B, cut normal z", "A -> B, cut normal x"})});
  if (B && X21) {
    figs.push_back({"slices_BA.png",
                    "B cut at its centroid, coloured by a 3D checkerboard of its image in A (inverted tets red)",
                    hconcat({render_volume_slices(*B, *X21, 2), render_volume_slices(*B, *X21, 0)},
                            {"B -> A, cut normal z", "B -> A, cut normal x"})});
  }
  return figs;
}

std::vector<ReportFigure> ball_figures(const TetMesh& mesh, const Eigen::MatrixXd& ball) {
  return {{"ball.png", "The ball cut open, coloured by a 3D checkerboard of the input positions (folded tets red)",
           render_ball(mesh, ball)}};
}

namespace {
SurfaceMapDirection viewer_direction(const TriMesh& S, const TriMesh& T, const BarycentricMap& P) {
  SurfaceMapDirection d;
  d.images = map_positions(P, T.V, T.F);
  // Flags exactly as surface_distortion counts them (report.json): on unit-area copies.
  const Eigen::MatrixXd X = unit_area_normalization(S).apply(S.V), Xt = unit_area_normalization(T).apply(T.V);
  fold_counts(X, S.F, map_positions(P, Xt, T.F), face_normals(Xt, T.F), T.F, P,
              SurfaceDistortionOptions().degenerate_tol, &d.face_flags);
  return d;
}
}  // namespace

ViewerData surface_map_viewer_data(const TriMesh& A, const TriMesh& B, const BarycentricMap& map_AB,
                                   const BarycentricMap* map_BA, const std::vector<int>& landmarks_A,
                                   const std::vector<int>& landmarks_B, const Eigen::VectorXd* error_AB) {
  SurfaceMapDirection ab = viewer_direction(A, B, map_AB);
  if (error_AB) ab.vertex_error = *error_AB;
  if (!map_BA) return surface_map_viewer(A, B, ab, nullptr, landmarks_A, landmarks_B);
  const SurfaceMapDirection ba = viewer_direction(B, A, *map_BA);
  return surface_map_viewer(A, B, ab, &ba, landmarks_A, landmarks_B);
}

}  // namespace shapemap::cli
