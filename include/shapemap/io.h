// Readers and writers. Readers throw InputError("<path>:<line>: <problem>") on bad
// input and never crash. Writers write to a temporary name and rename (atomic).
#pragma once
#include "shapemap/mesh.h"
#include <string>
#include <vector>

namespace shapemap {

// Surfaces by extension: .obj .off .ply (ASCII, binary little/big endian) .stl (ASCII, binary).
// Polygons with more than 3 vertices are fan-triangulated.
TriMesh read_surface(const std::string& path);
// .obj .off .ply (binary little endian, double) .stl (binary, float). See docs/formats.md.
void write_surface(const std::string& path, const TriMesh& mesh);

// Volumes by extension: .mesh (Medit), .vtk (legacy unstructured grid, ASCII or binary),
// .msh (gmsh v2 and v4 ASCII), .node/.ele (TetGen; either name given).
// Tets are reoriented (all of them) to positive volume if most are negative.
// Vertices keep the file's numbering (vertices used by no tet are kept).
TetMesh read_volume(const std::string& path);
// .vtk (ASCII) .mesh .msh (v2.2 ASCII) .node/.ele (TetGen: both files are written).
void write_volume(const std::string& path, const TetMesh& mesh);
// A VTK file with per-point or per-cell scalar fields attached (for viewers).
void write_vtk(const std::string& path, const TetMesh& mesh,
               const std::vector<std::pair<std::string, Eigen::VectorXd>>& point_data = {},
               const std::vector<std::pair<std::string, Eigen::VectorXd>>& cell_data = {});

// True if the extension names a volume format (.mesh .vtk .msh .node .ele).
bool is_volume_path(const std::string& path);
// True if the extension names a surface format (.obj .off .ply .stl).
bool is_surface_path(const std::string& path);

// Points: "x y z" per line ('#' comments and blank lines allowed, exactly three finite
// numbers per line). Throws InputError("<path>:<line>: ...") otherwise, or if there are none.
Eigen::MatrixXd read_points(const std::string& path);

// Landmarks: one 0-based vertex index per line, or "x y z" per line (snapped to the
// nearest vertex among `candidates`, all vertices if empty). '#' comments allowed.
// Throws InputError if the file has none, or names the same vertex twice.
std::vector<int> read_landmarks(const std::string& path, const Eigen::MatrixXd& V,
                                const std::vector<int>& candidates = {});

// Writes `text` to path atomically (temporary name in the same folder, then rename).
void write_text_atomic(const std::string& path, const std::string& text);
// The same for binary content (bytes written verbatim).
void write_binary_atomic(const std::string& path, const std::string& bytes);

}  // namespace shapemap
