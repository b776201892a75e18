// The pictures each map command puts beside its report.json (in report.html and as
// PNG files): the views the papers judge maps by. One function per kind of result; the
// interactive views of a surface map too (volume and ball: render/report_viewer.h directly).
#pragma once
#include "common.h"
#include "shapemap/maps.h"
#include "shapemap/mesh.h"
#include <vector>

namespace shapemap::cli {

// Surface maps: checkerboard texture transfer B -> A (and A -> B when map_BA is given)
// and normal transfer (elastic-correspondence Sec. 6.1).
std::vector<ReportFigure> surface_map_figures(const TriMesh& A, const TriMesh& B, const BarycentricMap& map_AB,
                                              const BarycentricMap* map_BA);

// Volume maps: checkerboard on a mid slice of each source pushed through the map,
// inverted tets in red (symmetric-volume-maps Sec. 6.1). X21/B may be null (one direction).
std::vector<ReportFigure> volume_map_figures(const TetMesh& A, const Eigen::MatrixXd& X12, const TetMesh* B,
                                             const Eigen::MatrixXd* X21);

// Ball parameterization: the ball cut open, coloured by the original positions.
std::vector<ReportFigure> ball_figures(const TetMesh& mesh, const Eigen::MatrixXd& ball);

// The interactive views of report.html (render/report_viewer.h) of a surface map: images of
// the vertices and the flipped / collapsed faces as surface_distortion counts them; error_AB
// (optional, empty = none): per vertex of A its error against the ground truth, -1 = unknown.
ViewerData surface_map_viewer_data(const TriMesh& A, const TriMesh& B, const BarycentricMap& map_AB,
                                   const BarycentricMap* map_BA, const std::vector<int>& landmarks_A = {},
                                   const std::vector<int>& landmarks_B = {},
                                   const Eigen::VectorXd* error_AB = nullptr);

}  // namespace shapemap::cli
