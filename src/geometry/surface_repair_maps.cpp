// The correspondence side of the input repairs (shapemap/repair.h): which defects a surface
// has, the identity correspondence of a clean surface, and maps carried between the users'
// numbering and the repaired surfaces. The repairs themselves: src/cgal/repair_surface.cpp.
#include "shapemap/checks.h"
#include "shapemap/geometry/closest_point.h"
#include "shapemap/repair.h"

#include <algorithm>
#include <numeric>

namespace shapemap {

namespace {

// The barycentric row b of face f of mesh S expressed in face g of mesh T whose corners are
// at the same positions (in any order).
Eigen::RowVector3d permute_corners(const TriMesh& S, int f, const Eigen::RowVector3d& b, const TriMesh& T, int g) {
  Eigen::RowVector3d out = Eigen::RowVector3d::Zero();
  for (int c = 0; c < 3; ++c)
    for (int k = 0; k < 3; ++k)
      if (S.V.row(S.F(f, c)) == T.V.row(T.F(g, k))) {
        out(k) += b(c);
        break;
      }
  return out;
}

Eigen::RowVector3d clean_bary(const Eigen::Vector4d& b4) {
  Eigen::RowVector3d b = b4.head<3>().transpose().cwiseMax(0.0);
  return b.sum() > 0 ? Eigen::RowVector3d(b / b.sum()) : Eigen::RowVector3d(1, 0, 0);
}

// Moves the rows of `M` listed in `rows` (positions X, k×3 in the same order) to the closest
// point of the faces `faces` of T (face indices of T).
void project_rows(BarycentricMap& M, const std::vector<int>& rows, const Eigen::MatrixXd& X, const TriMesh& T,
                  const std::vector<int>& faces) {
  if (rows.empty()) return;
  Eigen::MatrixXi F(Eigen::Index(faces.size()), 3);
  for (size_t k = 0; k < faces.size(); ++k) F.row(Eigen::Index(k)) = T.F.row(faces[k]);
  ClosestPoint3 bvh(T.V, F);
  const std::vector<ClosestPointResult> r = bvh.query(X);
  for (size_t k = 0; k < rows.size(); ++k) {
    M.elem(rows[k]) = faces[size_t(r[k].elem)];
    M.bary.row(rows[k]) = clean_bary(r[k].bary);
  }
}

}  // namespace

std::vector<std::string> repairable_defects(const TriMesh& in) {
  const MeshReport r = check_surface(in);
  std::vector<std::string> d;
  if (!r.finite || !r.indices_in_range || r.num_elements == 0) return d;  // not repairable: the guards say why
  append_repairable_problems(r, d);
  if (r.unreferenced_vertices)
    d.push_back(plural(r.unreferenced_vertices, "unreferenced vertex", "unreferenced vertices"));
  if (!r.closed)
    d.push_back("not closed: " + plural(r.boundary_edges, "boundary edge", "boundary edges") + " in " +
                plural(r.boundary_components, "hole", "holes"));
  if (r.components > 1) d.push_back(std::to_string(r.components) + " connected components");
  return d;
}

SurfaceRepair identity_repair(const TriMesh& in) {
  SurfaceRepair R;
  R.mesh = in;
  const int n = int(in.V.rows()), m = int(in.F.rows());
  R.vertex_from.resize(n);
  std::iota(R.vertex_from.data(), R.vertex_from.data() + n, 0);
  R.face_from.resize(m);
  std::iota(R.face_from.data(), R.face_from.data() + m, 0);
  R.input_vertex = R.vertex_from;
  R.input_on_repaired.elem = Eigen::VectorXi::Zero(n);
  R.input_on_repaired.bary = Eigen::MatrixXd::Zero(n, 3);
  R.input_on_repaired.bary.col(0).setOnes();
  if (in.F.cols() != 3) return R;
  for (int f = m - 1; f >= 0; --f)
    for (int c = 0; c < 3; ++c) {
      const int v = in.F(f, c);
      if (v < 0 || v >= n) continue;
      R.input_on_repaired.elem(v) = f;
      R.input_on_repaired.bary.row(v).setZero();
      R.input_on_repaired.bary(v, c) = 1.0;
    }
  return R;
}

int repaired_vertex(const SurfaceRepair& r, int i) {
  if (r.input_vertex(i) >= 0) return r.input_vertex(i);
  Eigen::Index c = 0;
  r.input_on_repaired.bary.row(i).maxCoeff(&c);
  return r.mesh.F(r.input_on_repaired.elem(i), int(c));
}

BarycentricMap map_to_inputs(const BarycentricMap& M, const SurfaceRepair& rA, const SurfaceRepair& rB,
                             const TriMesh& inputB) {
  if (!rA.changed() && !rB.changed()) return M;
  const TriMesh& B = rB.mesh;
  const int n = int(rA.input_vertex.size());
  BarycentricMap R;
  R.elem.resize(n);
  R.bary.resize(n, 3);
  // Rows: a vertex's own row, or the image of its nearest point, back on B.
  std::vector<int> off;
  Eigen::MatrixXd X;
  const Eigen::MatrixXd img = map_positions(M, B.V, B.F);
  for (int i = 0; i < n; ++i) {
    const int v = rA.input_vertex(i);
    if (v >= 0) {
      R.elem(i) = M.elem(v);
      R.bary.row(i) = M.bary.row(v);
    } else {
      off.push_back(i);
    }
  }
  if (!off.empty()) {
    X.resize(Eigen::Index(off.size()), 3);
    for (size_t k = 0; k < off.size(); ++k) {
      const int f = rA.input_on_repaired.elem(off[k]);
      X.row(Eigen::Index(k)).setZero();
      for (int c = 0; c < 3; ++c) X.row(Eigen::Index(k)) += rA.input_on_repaired.bary(off[k], c) * img.row(rA.mesh.F(f, c));
    }
    std::vector<int> all(size_t(B.num_faces()));
    std::iota(all.begin(), all.end(), 0);
    project_rows(R, off, X, B, all);
  }
  // Elements: B's faces -> the input faces they come from; images on added faces move to
  // the nearest kept input face.
  std::vector<int> moved, kept_faces;
  for (int f = 0; f < B.num_faces(); ++f)
    if (rB.face_from(f) >= 0) kept_faces.push_back(rB.face_from(f));
  std::sort(kept_faces.begin(), kept_faces.end());
  Eigen::MatrixXd Y;
  for (int i = 0; i < n; ++i) {
    const int f = R.elem(i), g = rB.face_from(f);
    if (g >= 0) {
      R.bary.row(i) = permute_corners(B, f, R.bary.row(i), inputB, g);
      R.elem(i) = g;
    } else {
      moved.push_back(i);
    }
  }
  if (!moved.empty()) {
    Y.resize(Eigen::Index(moved.size()), 3);
    for (size_t k = 0; k < moved.size(); ++k) {
      const int i = moved[k], f = R.elem(i);
      Y.row(Eigen::Index(k)).setZero();
      for (int c = 0; c < 3; ++c) Y.row(Eigen::Index(k)) += R.bary(i, c) * B.V.row(B.F(f, c));
    }
    project_rows(R, moved, Y, inputB, kept_faces);
  }
  return R;
}

BarycentricMap map_to_repaired(const BarycentricMap& M, const SurfaceRepair& rA, const SurfaceRepair& rB,
                               const TriMesh& inputB) {
  if (!rA.changed() && !rB.changed()) return M;
  const TriMesh& A = rA.mesh;
  const TriMesh& B = rB.mesh;
  const int n = A.num_vertices();
  // Added vertices take the row of the nearest original vertex in mesh hops (breadth-first
  // from the original vertices, in index order: deterministic).
  std::vector<int> source(size_t(n), -1), queue;
  for (int v = 0; v < n; ++v)
    if (rA.vertex_from(v) >= 0) {
      source[size_t(v)] = rA.vertex_from(v);
      queue.push_back(v);
    }
  std::vector<std::vector<int>> nb(static_cast<size_t>(n));
  for (int f = 0; f < A.num_faces(); ++f)
    for (int c = 0; c < 3; ++c) nb[size_t(A.F(f, c))].push_back(A.F(f, (c + 1) % 3));
  for (size_t q = 0; q < queue.size(); ++q)
    for (int w : nb[size_t(queue[q])])
      if (source[size_t(w)] < 0) {
        source[size_t(w)] = source[size_t(queue[q])];
        queue.push_back(w);
      }
  std::vector<int> inverse(size_t(inputB.num_faces()), -1);
  for (int f = B.num_faces() - 1; f >= 0; --f)
    if (rB.face_from(f) >= 0) inverse[size_t(rB.face_from(f))] = f;
  BarycentricMap R;
  R.elem.resize(n);
  R.bary.resize(n, 3);
  std::vector<int> moved;
  for (int v = 0; v < n; ++v) {
    const int i = std::max(source[size_t(v)], 0);
    const int g = M.elem(i), f = inverse[size_t(g)];
    R.elem(v) = g;
    R.bary.row(v) = M.bary.row(i);
    if (f >= 0) {
      R.bary.row(v) = permute_corners(inputB, g, M.bary.row(i), B, f);
      R.elem(v) = f;
    } else {
      moved.push_back(v);
    }
  }
  if (!moved.empty()) {
    Eigen::MatrixXd Y(Eigen::Index(moved.size()), 3);
    for (size_t k = 0; k < moved.size(); ++k) {
      const int v = moved[k], g = R.elem(v);
      Y.row(Eigen::Index(k)).setZero();
      for (int c = 0; c < 3; ++c) Y.row(Eigen::Index(k)) += R.bary(v, c) * inputB.V.row(inputB.F(g, c));
    }
    std::vector<int> all(size_t(B.num_faces()));
    std::iota(all.begin(), all.end(), 0);
    project_rows(R, moved, Y, B, all);
  }
  return R;
}

}  // namespace shapemap
