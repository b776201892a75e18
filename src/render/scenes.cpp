// Scenes of maps: scalar fields, texture and normal transfer, landmarks, volume slices
// and the ball.
#include "shapemap/render/scenes.h"
#include "shapemap/error.h"
#include "shapemap/generate.h"
#include <Eigen/Eigenvalues>
#include <algorithm>
#include <cmath>
#include <map>

namespace shapemap {

namespace {

Eigen::Vector3f kGrey(0.78f, 0.80f, 0.86f);
Eigen::Vector3f kRed(0.85f, 0.08f, 0.08f);

Image draw_single(const Eigen::MatrixXd& V, const Eigen::MatrixXi& F, const Eigen::MatrixXd& A,
                  const Shader& shader, const SceneOptions& opt, const Eigen::MatrixXd* frame_V = nullptr) {
  Camera cam = fit_camera(frame_V ? *frame_V : V, opt.view_dir);
  Rasterizer r(opt.render, cam);
  r.draw(V, F, A, shader, opt.wireframe);
  return r.resolve();
}

bool checker2(double u, double v) { return (int(std::floor(u)) + int(std::floor(v))) & 1; }
bool checker3(double u, double v, double w) {
  return (int(std::floor(u)) + int(std::floor(v)) + int(std::floor(w))) & 1;
}

// Principal axes of a point set (columns, by decreasing variance) and its centroid.
void principal_axes(const Eigen::MatrixXd& P, Eigen::RowVector3d& c, Eigen::Matrix3d& axes) {
  c = P.colwise().mean();
  Eigen::MatrixXd Q = P.rowwise() - c;
  Eigen::SelfAdjointEigenSolver<Eigen::Matrix3d> es(Q.transpose() * Q);
  axes = es.eigenvectors().rowwise().reverse();
}

Eigen::Vector3f checker_colour(bool on) {
  Eigen::Vector3f a(0.95f, 0.55f, 0.15f), b(0.15f, 0.35f, 0.75f);
  return on ? a : b;
}

}  // namespace

Image render_mesh(const TriMesh& mesh, const SceneOptions& opt, const Eigen::Vector3f& color) {
  return draw_single(mesh.V, mesh.F, Eigen::MatrixXd(mesh.V.rows(), 0),
                     [color](const double*, int) { return color; }, opt);
}

Image render_scalar(const TriMesh& mesh, const Eigen::VectorXd& values, const std::string& label,
                    const SceneOptions& opt, double vmin, double vmax) {
  const bool per_face = values.size() == mesh.F.rows() && values.size() != mesh.V.rows();
  if (!per_face && values.size() != mesh.V.rows())
    throw InputError("scalar field has " + std::to_string(values.size()) + " values; the mesh has " +
                     std::to_string(mesh.V.rows()) + " vertices and " + std::to_string(mesh.F.rows()) + " faces");
  if (!std::isfinite(vmin) || !std::isfinite(vmax)) {
    std::vector<double> v;
    for (Eigen::Index i = 0; i < values.size(); ++i)
      if (std::isfinite(values(i))) v.push_back(values(i));
    if (v.empty()) v.push_back(0);
    std::sort(v.begin(), v.end());
    // Robust range: 1st to 99th percentile, so a few outliers do not wash out the picture.
    if (!std::isfinite(vmin)) vmin = v[size_t(0.01 * (v.size() - 1))];
    if (!std::isfinite(vmax)) vmax = v[size_t(0.99 * (v.size() - 1))];
  }
  if (!(vmax > vmin)) vmax = vmin + 1e-12;
  const bool diverging = vmin < 0 && vmax > 0;
  if (diverging) vmax = std::max(-vmin, vmax), vmin = -vmax;
  auto cmap = [=](double x) {
    double t = (x - vmin) / (vmax - vmin);
    return diverging ? colormap_diverging(t) : colormap_viridis(t);
  };
  Image img;
  if (per_face) {
    img = draw_single(mesh.V, mesh.F, Eigen::MatrixXd(mesh.V.rows(), 0),
                      [&](const double*, int f) { return cmap(values(f)); }, opt);
  } else {
    Eigen::MatrixXd A = values;
    img = draw_single(mesh.V, mesh.F, A, [&](const double* a, int) { return cmap(a[0]); }, opt);
  }
  // Widen the canvas for the colour bar.
  Image out(img.width + 110, img.height, opt.render.background);
  for (int y = 0; y < img.height; ++y)
    for (int x = 0; x < img.width; ++x) out.at(x, y) = img.at(x, y);
  draw_colorbar(out, img.width + 10, 40, 22, img.height - 80, vmin, vmax, label, diverging);
  return out;
}

Image render_texture_transfer(const TriMesh& A, const TriMesh& B, const Eigen::MatrixXd& A_on_B,
                              const SceneOptions& opt) {
  if (A_on_B.rows() != A.V.rows() || A_on_B.cols() != 3)
    throw InputError("texture transfer: mapped positions do not match the source mesh");
  Eigen::RowVector3d c;
  Eigen::Matrix3d axes;
  principal_axes(B.V, c, axes);
  // Planar projection onto the two main axes; squares sized from the main extent.
  Eigen::MatrixXd uvB = (B.V.rowwise() - c) * axes.leftCols(2);
  double extent = (uvB.colwise().maxCoeff() - uvB.colwise().minCoeff()).maxCoeff();
  double s = opt.checker_squares / std::max(extent, 1e-12);
  uvB *= s;
  Eigen::MatrixXd uvA = ((A_on_B.rowwise() - c) * axes.leftCols(2)) * s;
  Shader shader = [](const double* a, int) { return checker_colour(checker2(a[0], a[1])); };
  Image target = draw_single(B.V, B.F, uvB, shader, opt);
  Image source = draw_single(A.V, A.F, uvA, shader, opt);
  return hconcat({target, source}, {"target B (texture)", "source A (texture pulled back)"});
}

Image render_normal_transfer(const TriMesh& A, const TriMesh& B, const BarycentricMap& map_AB,
                             const SceneOptions& opt) {
  Eigen::MatrixXd NB = vertex_normals(B.V, B.F);
  Eigen::MatrixXd NA = map_positions(map_AB, NB, B.F);
  for (Eigen::Index i = 0; i < NA.rows(); ++i) {
    double l = NA.row(i).norm();
    if (l > 0) NA.row(i) /= l;
  }
  Shader shader = [](const double* a, int) {
    Eigen::Vector3f n = Eigen::Vector3f(float(a[0]), float(a[1]), float(a[2]));
    return Eigen::Vector3f((n.array() * 0.5f + 0.5f).matrix());
  };
  SceneOptions o = opt;
  o.render.ambient = 1.0f;  // the colour is the information: no shading
  Image target = draw_single(B.V, B.F, NB, shader, o);
  Image source = draw_single(A.V, A.F, NA, shader, o);
  return hconcat({target, source}, {"target B (normals)", "source A (normals of B)"});
}

Image render_landmarks(const TriMesh& mesh, const std::vector<int>& landmarks, const SceneOptions& opt) {
  Camera cam = fit_camera(mesh.V, opt.view_dir);
  Rasterizer r(opt.render, cam);
  r.draw(mesh.V, mesh.F, Eigen::MatrixXd(mesh.V.rows(), 0), [](const double*, int) { return kGrey; },
         opt.wireframe);
  const double diag = bbox_diagonal(mesh.V);
  TriMesh ball = make_sphere(160, 0.02 * diag);
  for (size_t l = 0; l < landmarks.size(); ++l) {
    int v = landmarks[l];
    if (v < 0 || v >= mesh.V.rows()) throw InputError("landmark " + std::to_string(v) + " out of range");
    Eigen::MatrixXd P = ball.V.rowwise() + mesh.V.row(v);
    Eigen::Vector3f col = colormap_viridis(landmarks.size() > 1 ? double(l) / (landmarks.size() - 1) : 0.5);
    r.draw(P, ball.F, Eigen::MatrixXd(P.rows(), 0), [col](const double*, int) { return col; });
  }
  return r.resolve();
}

namespace {
// The part of a tet mesh (positions P) on the side x[axis] <= mid of a plane, drawn as
// its outer boundary clipped exactly by the plane plus the exact cross-section (each
// tet the plane crosses contributes a triangle or a quad). Texture positions T (n×3)
// are interpolated linearly along cut edges, which is exact for a piecewise-linear map,
// so the checkerboard on the section is the true image of the slice.
struct Section {
  std::vector<Eigen::Vector3d> V, A;  // positions and texture positions
  std::vector<Eigen::Vector3i> F;
  std::vector<int> tet;                // tet of each face (for inverted-tet colouring)
};

Section clipped_half(const TetMesh& mesh, const Eigen::MatrixXd& P, const Eigen::MatrixXd& T, int axis) {
  const double mid = 0.5 * (P.col(axis).minCoeff() + P.col(axis).maxCoeff());
  auto side = [&](int v) { return P(v, axis) - mid; };
  Section s;
  auto edge_point = [&](int u, int v) {  // side(u) <= 0 < side(v)
    double t = side(u) / (side(u) - side(v));
    s.V.push_back(P.row(u).transpose() + t * (P.row(v) - P.row(u)).transpose());
    s.A.push_back(T.row(u).transpose() + t * (T.row(v) - T.row(u)).transpose());
    return int(s.V.size()) - 1;
  };
  // Outer boundary, clipped (Sutherland-Hodgman on each triangle). Shared vertices and
  // shared edge points are deduplicated so shading stays smooth.
  TetBoundary b = boundary_surface(mesh);
  std::vector<int> vid(size_t(P.rows()), -1);
  std::map<std::pair<int, int>, int> eid;
  auto vertex = [&](int v) {
    if (vid[size_t(v)] < 0) {
      s.V.push_back(P.row(v).transpose());
      s.A.push_back(T.row(v).transpose());
      vid[size_t(v)] = int(s.V.size()) - 1;
    }
    return vid[size_t(v)];
  };
  auto cut = [&](int u, int v) {  // u inside, v outside
    auto key = std::make_pair(std::min(u, v), std::max(u, v));
    auto it = eid.find(key);
    if (it != eid.end()) return it->second;
    int id = edge_point(u, v);
    eid[key] = id;
    return id;
  };
  for (Eigen::Index f = 0; f < b.surface.F.rows(); ++f) {
    int c[3];
    for (int j = 0; j < 3; ++j) c[j] = b.to_volume(b.surface.F(f, j));
    std::vector<int> poly;
    for (int j = 0; j < 3; ++j) {
      int u = c[j], v = c[(j + 1) % 3];
      bool iu = side(u) <= 0, iv = side(v) <= 0;
      if (iu) poly.push_back(vertex(u));
      if (iu != iv) poly.push_back(iu ? cut(u, v) : cut(v, u));
    }
    for (size_t k = 2; k < poly.size(); ++k) {
      s.F.emplace_back(poly[0], poly[k - 1], poly[k]);
      s.tet.push_back(b.face_tet(f));
    }
  }
  // Cross-section: points on the crossing edges of each tet, ordered around the polygon.
  for (Eigen::Index t = 0; t < mesh.T.rows(); ++t) {
    int in[4], out[4], ni = 0, no = 0;
    for (int j = 0; j < 4; ++j) {
      int v = mesh.T(t, j);
      (side(v) <= 0 ? in[ni++] : out[no++]) = v;
    }
    if (ni == 0 || no == 0) continue;
    if (ni == 1 || no == 1) {  // triangle
      int a, o[3];
      if (ni == 1) {
        a = in[0];
        for (int j = 0; j < 3; ++j) o[j] = edge_point(a, out[j]);
      } else {
        a = out[0];
        for (int j = 0; j < 3; ++j) o[j] = edge_point(in[j], a);
      }
      s.F.emplace_back(o[0], o[1], o[2]);
      s.tet.push_back(int(t));
    } else {  // quad: edges (i0,o0), (i0,o1), (i1,o1), (i1,o0) form a cycle
      int q0 = edge_point(in[0], out[0]), q1 = edge_point(in[0], out[1]);
      int q2 = edge_point(in[1], out[1]), q3 = edge_point(in[1], out[0]);
      s.F.emplace_back(q0, q1, q2);
      s.F.emplace_back(q0, q2, q3);
      s.tet.push_back(int(t));
      s.tet.push_back(int(t));
    }
  }
  return s;
}

Image slice_picture(const TetMesh& mesh, const Eigen::MatrixXd& P, const Eigen::MatrixXd& texture_pos,
                    const std::vector<char>& bad, int axis, const SceneOptions& opt) {
  Section sec = clipped_half(mesh, P, texture_pos, axis);
  if (sec.F.empty()) throw InputError("volume slice: empty mesh");
  double diag = (texture_pos.colwise().maxCoeff() - texture_pos.colwise().minCoeff()).norm();
  double scale = opt.checker_squares / std::max(diag, 1e-12);
  Eigen::MatrixXd V(Eigen::Index(sec.V.size()), 3), A(Eigen::Index(sec.V.size()), 3);
  for (size_t i = 0; i < sec.V.size(); ++i) {
    V.row(Eigen::Index(i)) = sec.V[i].transpose();
    A.row(Eigen::Index(i)) = sec.A[i].transpose() * scale;
  }
  Eigen::MatrixXi F(Eigen::Index(sec.F.size()), 3);
  for (size_t f = 0; f < sec.F.size(); ++f) F.row(Eigen::Index(f)) = sec.F[f].transpose();
  Shader shader = [&](const double* a, int f) {
    if (bad[size_t(sec.tet[size_t(f)])]) return kRed;
    return checker_colour(checker3(a[0], a[1], a[2]));
  };
  // Look at the cut face (it faces +axis); frame the whole mesh so halves line up.
  SceneOptions o = opt;
  o.view_dir = Eigen::Vector3d::Zero();
  o.view_dir[axis] = -1.0;
  o.view_dir[(axis + 1) % 3] = -0.5;
  o.view_dir[(axis + 2) % 3] = -0.35;
  return draw_single(V, F, A, shader, o, &P);
}
}  // namespace

Image render_volume_slices(const TetMesh& source, const Eigen::MatrixXd& X, int axis, const SceneOptions& opt) {
  if (X.rows() != source.V.rows()) throw InputError("volume slices: mapped positions do not match the source");
  Eigen::VectorXd vol = tet_volumes(X, source.T);
  std::vector<char> bad(size_t(source.T.rows()));
  for (Eigen::Index t = 0; t < source.T.rows(); ++t) bad[size_t(t)] = !(vol(t) > 0);
  return slice_picture(source, source.V, X, bad, axis, opt);
}

Image render_ball(const TetMesh& mesh, const Eigen::MatrixXd& ball, const SceneOptions& opt) {
  if (ball.rows() != mesh.V.rows()) throw InputError("ball picture: ball positions do not match the mesh");
  Eigen::VectorXd v0 = tet_volumes(mesh.V, mesh.T), v1 = tet_volumes(ball, mesh.T);
  std::vector<char> bad(size_t(mesh.T.rows()));
  for (Eigen::Index t = 0; t < mesh.T.rows(); ++t) bad[size_t(t)] = (v0(t) > 0) != (v1(t) > 0);
  TetMesh bm{ball, mesh.T};
  return slice_picture(bm, ball, mesh.V, bad, 2, opt);
}

}  // namespace shapemap
