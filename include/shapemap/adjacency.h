// Adjacency helpers over F (m×3) and T (m×4).
#pragma once
#include <Eigen/Core>
#include <vector>

namespace shapemap {

// Unique undirected edges of a triangle mesh, E: k×2 with E(i,0) < E(i,1).
// If face_edges is given it receives m×3: edge index opposite to corner j of face f.
Eigen::MatrixXi unique_edges(const Eigen::MatrixXi& F, Eigen::MatrixXi* face_edges = nullptr);

// For each unique edge (as from unique_edges), the two incident faces (-1 if boundary)
// and the corner (0..2) of each face opposite to the edge. Returns k×4:
// [f0, corner0, f1, corner1].
Eigen::MatrixXi edge_faces(const Eigen::MatrixXi& F, const Eigen::MatrixXi& E,
                           const Eigen::MatrixXi& face_edges);

// Vertex-vertex adjacency lists (sorted, unique) of a triangle or tet mesh.
std::vector<std::vector<int>> vertex_neighbors(const Eigen::MatrixXi& elements, int num_vertices);

// Elements incident to each vertex.
std::vector<std::vector<int>> vertex_elements(const Eigen::MatrixXi& elements, int num_vertices);

// Elements incident to each vertex in compressed rows: elems[start[v] .. start[v + 1]) are the
// elements with corner v, ascending. Two flat arrays, for loops that run every iteration.
struct VertexElementsCsr {
  std::vector<int> start, elems;
};
VertexElementsCsr vertex_elements_csr(const Eigen::MatrixXi& elements, int num_vertices);

// Connected components of the vertex graph induced by the elements; returns the
// component id per vertex (vertices used by no element get their own components)
// and writes the count to num_components.
Eigen::VectorXi connected_components(const Eigen::MatrixXi& elements, int num_vertices,
                                     int* num_components);

}  // namespace shapemap
