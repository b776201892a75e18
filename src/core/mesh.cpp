// Mesh measures, normalizations and the boundary surface of a tet mesh.
#include "shapemap/mesh.h"
#include "shapemap/geometry/tet_volume.h"
#include "shapemap/error.h"
#include <Eigen/Geometry>
#include <algorithm>
#include <array>
#include <cmath>
#include <map>

namespace shapemap {

Eigen::VectorXd triangle_areas(const Eigen::MatrixXd& V, const Eigen::MatrixXi& F) {
  Eigen::VectorXd A(F.rows());
#pragma omp parallel for schedule(static)
  for (Eigen::Index f = 0; f < F.rows(); ++f) {
    Eigen::Vector3d a = V.row(F(f, 0)), b = V.row(F(f, 1)), c = V.row(F(f, 2));
    A(f) = 0.5 * (b - a).cross(c - a).norm();
  }
  return A;
}

double bbox_diagonal(const Eigen::MatrixXd& V) {
  if (V.rows() == 0) return 0;
  return (V.colwise().maxCoeff() - V.colwise().minCoeff()).norm();
}

double surface_area(const Eigen::MatrixXd& V, const Eigen::MatrixXi& F) {
  return triangle_areas(V, F).sum();
}

Eigen::VectorXd tet_volumes(const Eigen::MatrixXd& V, const Eigen::MatrixXi& T) {
  Eigen::VectorXd vol(T.rows());
#pragma omp parallel for schedule(static)
  for (Eigen::Index t = 0; t < T.rows(); ++t) {
    Eigen::Vector3d a = V.row(T(t, 0));
    Eigen::Vector3d b = V.row(T(t, 1)), c = V.row(T(t, 2)), d = V.row(T(t, 3));
    vol(t) = signed_tet_volume(a, b, c, d);
  }
  return vol;
}

int positive_origin_cones(const Eigen::MatrixXd& V, const Eigen::MatrixXi& F) {
  int k = 0;
  for (Eigen::Index f = 0; f < F.rows(); ++f) {
    const Eigen::Vector3d a = V.row(F(f, 0)), b = V.row(F(f, 1)), c = V.row(F(f, 2));
    if (a.dot(b.cross(c)) > 0) ++k;
  }
  return k;
}

double signed_volume(const Eigen::MatrixXd& V, const Eigen::MatrixXi& T) {
  return tet_volumes(V, T).sum();
}

double enclosed_volume(const Eigen::MatrixXd& V, const Eigen::MatrixXi& F) {
  // Divergence theorem: sum of signed volumes of the cones from the origin.
  double vol = 0;
  for (Eigen::Index f = 0; f < F.rows(); ++f) {
    Eigen::Vector3d a = V.row(F(f, 0)), b = V.row(F(f, 1)), c = V.row(F(f, 2));
    vol += a.dot(b.cross(c)) / 6.0;
  }
  return vol;
}

Eigen::MatrixXd face_normals(const Eigen::MatrixXd& V, const Eigen::MatrixXi& F) {
  Eigen::MatrixXd N(F.rows(), 3);
#pragma omp parallel for schedule(static)
  for (Eigen::Index f = 0; f < F.rows(); ++f) {
    Eigen::Vector3d a = V.row(F(f, 0)), b = V.row(F(f, 1)), c = V.row(F(f, 2));
    Eigen::Vector3d n = (b - a).cross(c - a);
    double len = n.norm();
    N.row(f) = len > 0 ? Eigen::Vector3d(n / len) : Eigen::Vector3d::Zero();
  }
  return N;
}

Eigen::MatrixXd vertex_normals(const Eigen::MatrixXd& V, const Eigen::MatrixXi& F) {
  // Area-weighted: accumulate unnormalized face normals (twice the area) serially so
  // the result does not depend on the thread count.
  Eigen::MatrixXd N = Eigen::MatrixXd::Zero(V.rows(), 3);
  for (Eigen::Index f = 0; f < F.rows(); ++f) {
    Eigen::Vector3d a = V.row(F(f, 0)), b = V.row(F(f, 1)), c = V.row(F(f, 2));
    Eigen::RowVector3d n = (b - a).cross(c - a).transpose();
    for (int j = 0; j < 3; ++j) N.row(F(f, j)) += n;
  }
  for (Eigen::Index i = 0; i < N.rows(); ++i) {
    double len = N.row(i).norm();
    if (len > 0) N.row(i) /= len;
  }
  return N;
}

Eigen::MatrixXd Normalization::apply(const Eigen::MatrixXd& V) const {
  return (V.rowwise() - center) * scale;
}

Eigen::MatrixXd Normalization::undo(const Eigen::MatrixXd& V) const {
  return (V / scale).rowwise() + center;
}

Normalization unit_area_normalization(const TriMesh& mesh) {
  Eigen::VectorXd A = triangle_areas(mesh.V, mesh.F);
  double total = A.sum();
  if (!std::isfinite(total)) throw InputError("surface area overflows (coordinates too large)");
  if (!(total > 0)) throw InputError("surface has zero area");
  Eigen::RowVector3d c = Eigen::RowVector3d::Zero();
  for (Eigen::Index f = 0; f < mesh.F.rows(); ++f)
    c += A(f) * (mesh.V.row(mesh.F(f, 0)) + mesh.V.row(mesh.F(f, 1)) + mesh.V.row(mesh.F(f, 2))) / 3.0;
  Normalization n;
  n.center = c / total;
  n.scale = 1.0 / std::sqrt(total);
  return n;
}

Normalization unit_volume_normalization(const TetMesh& mesh) {
  Eigen::VectorXd vol = tet_volumes(mesh.V, mesh.T);
  double total = vol.cwiseAbs().sum();
  if (!std::isfinite(total)) throw InputError("tetrahedral mesh volume overflows (coordinates too large)");
  if (!(total > 0)) throw InputError("tetrahedral mesh has zero volume");
  Eigen::RowVector3d c = Eigen::RowVector3d::Zero();
  for (Eigen::Index t = 0; t < mesh.T.rows(); ++t) {
    Eigen::RowVector3d m = Eigen::RowVector3d::Zero();
    for (int j = 0; j < 4; ++j) m += mesh.V.row(mesh.T(t, j));
    c += std::abs(vol(t)) * m / 4.0;
  }
  Normalization n;
  n.center = c / total;
  n.scale = 1.0 / std::cbrt(total);
  return n;
}

TetBoundary boundary_surface(const TetMesh& mesh) {
  const Eigen::MatrixXi& T = mesh.T;
  const int n = mesh.num_vertices();
  // Faces opposite each corner, oriented outward for a positively oriented tet.
  static const int kFace[4][3] = {{1, 2, 3}, {0, 3, 2}, {0, 1, 3}, {0, 2, 1}};
  struct Entry {
    std::array<int, 3> key;
    int tet, corner;
  };
  std::vector<Entry> faces;
  faces.reserve(size_t(T.rows()) * 4);
  for (Eigen::Index t = 0; t < T.rows(); ++t)
    for (int c = 0; c < 4; ++c) {
      std::array<int, 3> k = {T(t, kFace[c][0]), T(t, kFace[c][1]), T(t, kFace[c][2])};
      std::sort(k.begin(), k.end());
      faces.push_back({k, int(t), c});
    }
  std::sort(faces.begin(), faces.end(), [](const Entry& a, const Entry& b) {
    return a.key != b.key ? a.key < b.key : a.tet < b.tet;
  });
  std::vector<std::array<int, 3>> bf;
  std::vector<int> btet;
  for (size_t i = 0; i < faces.size();) {
    size_t j = i;
    while (j < faces.size() && faces[j].key == faces[i].key) ++j;
    if (j - i == 1) {
      const Entry& e = faces[i];
      bool positive = true;
      {
        Eigen::Vector3d a = mesh.V.row(T(e.tet, 0)), b = mesh.V.row(T(e.tet, 1)),
                        c = mesh.V.row(T(e.tet, 2)), d = mesh.V.row(T(e.tet, 3));
        positive = signed_tet_volume6(a, b, c, d) >= 0;
      }
      std::array<int, 3> f = {T(e.tet, kFace[e.corner][0]), T(e.tet, kFace[e.corner][1]),
                              T(e.tet, kFace[e.corner][2])};
      if (!positive) std::swap(f[1], f[2]);
      bf.push_back(f);
      btet.push_back(e.tet);
    }
    i = j;
  }
  TetBoundary b;
  b.to_surface = Eigen::VectorXi::Constant(n, -1);
  std::vector<int> to_volume;
  for (auto& f : bf)
    for (int v : f)
      if (b.to_surface(v) < 0) {
        b.to_surface(v) = int(to_volume.size());
        to_volume.push_back(v);
      }
  // Number surface vertices in increasing volume order (deterministic, readable).
  std::sort(to_volume.begin(), to_volume.end());
  for (size_t i = 0; i < to_volume.size(); ++i) b.to_surface(to_volume[i]) = int(i);
  b.to_volume = Eigen::Map<Eigen::VectorXi>(to_volume.data(), Eigen::Index(to_volume.size()));
  b.surface.V.resize(Eigen::Index(to_volume.size()), 3);
  for (size_t i = 0; i < to_volume.size(); ++i) b.surface.V.row(Eigen::Index(i)) = mesh.V.row(to_volume[i]);
  b.surface.F.resize(Eigen::Index(bf.size()), 3);
  b.face_tet.resize(Eigen::Index(bf.size()));
  for (size_t i = 0; i < bf.size(); ++i) {
    for (int j = 0; j < 3; ++j) b.surface.F(Eigen::Index(i), j) = b.to_surface(bf[i][j]);
    b.face_tet(Eigen::Index(i)) = btet[i];
  }
  return b;
}

void require_element_indices(const Eigen::MatrixXi& E, Eigen::Index n, int cols, const char* what) {
  if (E.cols() != cols)
    throw InputError(std::string(what) + ": expected " + std::to_string(cols) + " columns, got " +
                     std::to_string(E.cols()));
  if (E.size() > 0 && (E.minCoeff() < 0 || E.maxCoeff() >= n))
    throw InputError(std::string(what) + ": vertex index out of range [0," + std::to_string(n) + ")");
}

}  // namespace shapemap
