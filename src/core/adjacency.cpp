// Adjacency helpers.
#include "shapemap/adjacency.h"
#include <algorithm>
#include <array>
#include <numeric>

namespace shapemap {

Eigen::MatrixXi unique_edges(const Eigen::MatrixXi& F, Eigen::MatrixXi* face_edges) {
  struct HalfEdge {
    int a, b, face, corner;
  };
  std::vector<HalfEdge> he;
  he.reserve(size_t(F.rows()) * 3);
  for (Eigen::Index f = 0; f < F.rows(); ++f)
    for (int c = 0; c < 3; ++c) {
      int a = F(f, (c + 1) % 3), b = F(f, (c + 2) % 3);
      he.push_back({std::min(a, b), std::max(a, b), int(f), c});
    }
  std::sort(he.begin(), he.end(), [](const HalfEdge& x, const HalfEdge& y) {
    return x.a != y.a ? x.a < y.a : (x.b != y.b ? x.b < y.b : x.face < y.face);
  });
  std::vector<std::array<int, 2>> edges;
  if (face_edges) face_edges->resize(F.rows(), 3);
  for (size_t i = 0; i < he.size();) {
    size_t j = i;
    while (j < he.size() && he[j].a == he[i].a && he[j].b == he[i].b) {
      if (face_edges) (*face_edges)(he[j].face, he[j].corner) = int(edges.size());
      ++j;
    }
    edges.push_back({he[i].a, he[i].b});
    i = j;
  }
  Eigen::MatrixXi E(Eigen::Index(edges.size()), 2);
  for (size_t i = 0; i < edges.size(); ++i) {
    E(Eigen::Index(i), 0) = edges[i][0];
    E(Eigen::Index(i), 1) = edges[i][1];
  }
  return E;
}

Eigen::MatrixXi edge_faces(const Eigen::MatrixXi& F, const Eigen::MatrixXi& E,
                           const Eigen::MatrixXi& face_edges) {
  Eigen::MatrixXi EF = Eigen::MatrixXi::Constant(E.rows(), 4, -1);
  for (Eigen::Index f = 0; f < F.rows(); ++f)
    for (int c = 0; c < 3; ++c) {
      int e = face_edges(f, c);
      if (EF(e, 0) < 0) {
        EF(e, 0) = int(f);
        EF(e, 1) = c;
      } else if (EF(e, 2) < 0) {
        EF(e, 2) = int(f);
        EF(e, 3) = c;
      }
    }
  return EF;
}

std::vector<std::vector<int>> vertex_neighbors(const Eigen::MatrixXi& elements, int num_vertices) {
  std::vector<std::vector<int>> adj(num_vertices);
  const int k = int(elements.cols());
  for (Eigen::Index e = 0; e < elements.rows(); ++e)
    for (int i = 0; i < k; ++i)
      for (int j = 0; j < k; ++j)
        if (i != j) adj[elements(e, i)].push_back(elements(e, j));
  for (auto& a : adj) {
    std::sort(a.begin(), a.end());
    a.erase(std::unique(a.begin(), a.end()), a.end());
  }
  return adj;
}

VertexElementsCsr vertex_elements_csr(const Eigen::MatrixXi& elements, int num_vertices) {
  VertexElementsCsr c;
  c.start.assign(num_vertices + 1, 0);
  for (int t = 0; t < elements.rows(); ++t)
    for (int j = 0; j < elements.cols(); ++j) ++c.start[elements(t, j) + 1];
  for (int v = 0; v < num_vertices; ++v) c.start[v + 1] += c.start[v];
  c.elems.resize(c.start[num_vertices]);
  std::vector<int> fill(c.start.begin(), c.start.end() - 1);
  for (int t = 0; t < elements.rows(); ++t)
    for (int j = 0; j < elements.cols(); ++j) c.elems[fill[elements(t, j)]++] = t;
  return c;
}

std::vector<std::vector<int>> vertex_elements(const Eigen::MatrixXi& elements, int num_vertices) {
  std::vector<std::vector<int>> inc(num_vertices);
  for (Eigen::Index e = 0; e < elements.rows(); ++e)
    for (int i = 0; i < elements.cols(); ++i) inc[elements(e, i)].push_back(int(e));
  for (auto& a : inc) a.erase(std::unique(a.begin(), a.end()), a.end());
  return inc;
}

Eigen::VectorXi connected_components(const Eigen::MatrixXi& elements, int num_vertices,
                                     int* num_components) {
  // Union-find with path halving.
  std::vector<int> parent(num_vertices);
  std::iota(parent.begin(), parent.end(), 0);
  auto find = [&](int x) {
    while (parent[x] != x) x = parent[x] = parent[parent[x]];
    return x;
  };
  for (Eigen::Index e = 0; e < elements.rows(); ++e)
    for (int i = 1; i < elements.cols(); ++i) {
      int a = find(elements(e, 0)), b = find(elements(e, i));
      if (a != b) parent[std::max(a, b)] = std::min(a, b);
    }
  Eigen::VectorXi comp(num_vertices);
  std::vector<int> label(num_vertices, -1);
  int count = 0;
  for (int v = 0; v < num_vertices; ++v) {
    int r = find(v);
    if (label[r] < 0) label[r] = count++;
    comp(v) = label[r];
  }
  if (num_components) *num_components = count;
  return comp;
}

}  // namespace shapemap
