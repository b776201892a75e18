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
// Throws InputError if the file has none. A vertex may appear more than once (real files
// repeat points): tidy_landmark_pairs says what becomes of repeats.
// Landmark pairs LA[k] <-> LB[k] as users' files have them: a pair given more than once is
// kept once; a vertex given two different partners keeps both pairs (they act as two soft
// constraints: BIM's Mobius triplets skip a repeated point, the volume map's landmark
// initialization copies the nearest landmark's first partner). Returns one note per
// merged or kept repeat (empty if none). Throws InputError naming fileB when the counts
// differ.
std::vector<std::string> tidy_landmark_pairs(std::vector<int>& LA, std::vector<int>& LB,
                                            const std::string& fileA, const std::string& fileB);

std::vector<int> read_landmarks(const std::string& path, const Eigen::MatrixXd& V,
                                const std::vector<int>& candidates = {});

// Writes `text` to path atomically (temporary name in the same folder, then rename).
void write_text_atomic(const std::string& path, const std::string& text);
// The same for binary content (bytes written verbatim).
void write_binary_atomic(const std::string& path, const std::string& bytes);

}  // namespace shapemap
