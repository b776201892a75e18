// Dense maps between meshes: every source vertex goes to a point on the target given
// as an element index and barycentric coordinates (docs/formats.md).
#pragma once
#include "shapemap/mesh.h"
#include <string>

namespace shapemap {

// A vertex-to-point map. elem(i) indexes F (surfaces, 3 barycentric coordinates) or
// T (volumes, 4 coordinates) of the target; bary is n×3 or n×4, rows sum to 1.
struct BarycentricMap {
  Eigen::VectorXi elem;
  Eigen::MatrixXd bary;
  int size() const { return int(elem.size()); }
  int arity() const { return int(bary.cols()); }  // 3 = triangles, 4 = tets
};

// Positions of the mapped points: row i = sum_j bary(i,j) * V(elements(elem(i), j)).
Eigen::MatrixXd map_positions(const BarycentricMap& map, const Eigen::MatrixXd& V,
                              const Eigen::MatrixXi& elements);

// Throws InputError("<name>: ...") unless the map fits: size == num_source_vertices,
// element indices in [0, num_target_elements), arity matches, coordinates
// non-negative (tolerance 1e-6) and summing to 1 (tolerance 1e-6).
void validate_map(const BarycentricMap& map, int num_source_vertices, int num_target_elements,
                  int arity, const std::string& name);

// The map file format (docs/formats.md): optional '#' comment lines, then a header
// line "shapemap-map 1 <n> <arity>", then n lines "elem b0 b1 b2 [b3]".
BarycentricMap read_map(const std::string& path);
void write_map(const std::string& path, const BarycentricMap& map);

}  // namespace shapemap
