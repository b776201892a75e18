// Local untangling of folded tets in a ball map (see the header).
#include "shapemap/volume/untangle.h"
#include "shapemap/geometry/tet_volume.h"
#include <algorithm>
#include <limits>
#include <vector>

namespace shapemap {

namespace {

// One vertex's neighbourhood: its tets and its edge neighbours, built once.
struct TetStars {
  std::vector<std::vector<int>> tets, neighbours;
  TetStars(const Eigen::MatrixXi& T, int n) : tets(n), neighbours(n) {
    for (Eigen::Index t = 0; t < T.rows(); ++t)
      for (int c = 0; c < 4; ++c) {
        tets[T(t, c)].push_back(int(t));
        for (int d = 0; d < 4; ++d)
          if (d != c) neighbours[T(t, c)].push_back(T(t, d));
      }
    for (auto& v : neighbours) {
      std::sort(v.begin(), v.end());
      v.erase(std::unique(v.begin(), v.end()), v.end());
    }
  }
};

class Untangler {
 public:
  Untangler(const Eigen::MatrixXi& T, const UntangleRules& rules, Eigen::MatrixXd& f)
      : T_(T), rules_(rules), f_(f), star_(T, int(f.rows())) {}

  double volume(int t) const {
    return signed_tet_volume(f_.row(T_(t, 0)), f_.row(T_(t, 1)), f_.row(T_(t, 2)), f_.row(T_(t, 3)));
  }
  int count_folded() const {
    int k = 0;
    for (Eigen::Index t = 0; t < T_.rows(); ++t) k += !(volume(int(t)) > 0);
    return k;
  }
  // Smallest incident volume of vertex i; nf = its non-positive incident tets.
  double local(int i, int& nf) const {
    nf = 0;
    double worst = std::numeric_limits<double>::infinity();
    for (int t : star_.tets[i]) {
      const double v = volume(t);
      if (!(v > 0)) ++nf;
      worst = std::min(worst, v);
    }
    return worst;
  }

  // Whether vertex i where it is now has fewer non-positive incident tets than best_nf, or
  // as many and a larger smallest volume than best_w; if so, they become its values.
  bool improves(int i, int& best_nf, double& best_w) const {
    int nf;
    const double w = local(i, nf);
    if (!(nf < best_nf || (nf == best_nf && w > best_w))) return false;
    best_nf = nf;
    best_w = w;
    return true;
  }

  // One Gauss-Seidel sweep over the vertices of folded tets, and with rings > 0 over the
  // vertices up to that many edges from them, which then raise the smallest volume of their
  // own tets (making room for the folded ones).
  void sweep(int rings) {
    const int n = int(f_.rows());
    std::vector<char> mark(n, 0);
    for (Eigen::Index t = 0; t < T_.rows(); ++t)
      if (!(volume(int(t)) > 0))
        for (int c = 0; c < 4; ++c) mark[T_(t, c)] = 1;
    for (int r = 0; r < rings; ++r) {
      std::vector<char> grown = mark;
      for (int i = 0; i < n; ++i)
        if (mark[i])
          for (int j : star_.neighbours[i]) grown[j] = 1;
      mark.swap(grown);
    }
    for (int i = 0; i < n; ++i)
      if (mark[i]) relax_vertex(i, rings > 0);
  }

 private:
  // Towards the neighbours' mean, then max-min ascent (Freitag & Plassmann 2000, local
  // optimization-based untangling).
  void relax_vertex(int i, bool ring) {
    const bool bnd = rules_.boundary(i);
    Eigen::RowVector3d c = Eigen::RowVector3d::Zero();
    int k = 0;
    for (int j : star_.neighbours[i])
      if (!bnd || rules_.boundary(j)) {
        c += f_.row(j);
        ++k;
      }
    if (k == 0) return;
    c /= double(k);
    if (bnd && !(c.norm() > 0)) return;  // no direction (the ball: the sphere's centre)
    const Eigen::RowVector3d old = f_.row(i);
    int best_nf;
    double best_w = local(i, best_nf);
    if (best_nf == 0 && !ring) return;  // only vertices of folded tets move
    const auto& place = best_nf == 0 && bnd && rules_.place_boundary_ring ? rules_.place_boundary_ring : rules_.place;
    Eigen::RowVector3d best = old;
    for (double s = 1; s > 0.1; s *= 0.5) {
      Eigen::RowVector3d y = (1 - s) * old + s * c;
      place(i, y);
      f_.row(i) = y;
      if (improves(i, best_nf, best_w)) best = f_.row(i);
    }
    f_.row(i) = best;
    ascend_smallest_volume(i, place, best_nf, best_w, ring ? 3 : 0);
  }

  // Move along the volume gradient of the smallest incident tet while the smallest
  // incident volume increases (at most 30 steps while it is not positive, then at most
  // `positive_steps` more).
  void ascend_smallest_volume(int i, const std::function<void(int, Eigen::RowVector3d&)>& place, int& best_nf,
                              double& best_w, int positive_steps) {
    double scale = 0;
    for (int j : star_.neighbours[i]) scale = std::max(scale, (f_.row(j) - f_.row(i)).norm());
    for (int it = 0; it < 30 && (best_w <= 0 || positive_steps-- > 0); ++it) {
      int tmin = -1;
      double vmin = std::numeric_limits<double>::infinity();
      for (int t : star_.tets[i]) {
        const double v = volume(t);
        if (v < vmin) {
          vmin = v;
          tmin = t;
        }
      }
      int c = 0;
      while (T_(tmin, c) != i) ++c;
      // d vol / d f_i = (1/6) (f_b - f_a) x (f_c - f_a) for the opposite face (a, b, c)
      // ordered so that the volume is (f_i - f_a) . ((f_b - f_a) x (f_c - f_a)) / 6 > 0.
      static const int opp[4][3] = {{1, 3, 2}, {0, 2, 3}, {0, 3, 1}, {0, 1, 2}};
      const Eigen::Vector3d fa = f_.row(T_(tmin, opp[c][0])), fb = f_.row(T_(tmin, opp[c][1])),
                            fc = f_.row(T_(tmin, opp[c][2]));
      Eigen::Vector3d d = (fb - fa).cross(fc - fa);
      if (rules_.tangent) rules_.tangent(i, d);
      if (!(d.norm() > 0)) return;
      d.normalize();
      const Eigen::RowVector3d o = f_.row(i);
      bool moved = false;
      for (double st = 0.5 * scale; st > 1e-6 * scale; st *= 0.5) {
        Eigen::RowVector3d y = o + st * d.transpose();
        place(i, y);
        f_.row(i) = y;
        if (improves(i, best_nf, best_w)) {
          moved = true;
          break;
        }
      }
      if (!moved) {
        f_.row(i) = o;
        return;
      }
    }
  }

  const Eigen::MatrixXi& T_;
  const UntangleRules& rules_;
  Eigen::MatrixXd& f_;
  const TetStars star_;
};

}  // namespace

int untangle_tets(const Eigen::MatrixXi& T, const UntangleRules& rules, int max_rounds, Eigen::MatrixXd& f) {
  Untangler u(T, rules, f);
  int folded = u.count_folded();
  // The folded tets' vertices alone first, then (rules.rings > 0) with their rings too.
  for (int rings : {0, rules.rings}) {
    int stall = 0;
    for (int round = 0; round < max_rounds && folded > 0; ++round) {
      u.sweep(rings);
      const int fn = u.count_folded();
      if (fn >= folded && ++stall >= 2) break;
      folded = fn;
    }
    if (rules.rings <= 0) break;
  }
  return folded;
}

// On the ball: boundary vertices stay on the unit sphere and ascend along its tangent plane.
// No rings (unlike the sphere's untangling and the landing's): measured, growing the
// neighbourhoods only smoothed away volume accuracy (spot E_I 0.018 -> 0.023) without
// removing more folds.
int untangle_ball_map(const Eigen::MatrixXi& T, int nI, int max_rounds, Eigen::MatrixXd& f) {
  UntangleRules rules;
  rules.boundary = [nI](int i) { return i >= nI; };
  rules.place = [nI](int i, Eigen::RowVector3d& y) {
    if (i >= nI) y.normalize();
  };
  rules.tangent = [nI, &f](int i, Eigen::Vector3d& d) {
    if (i < nI) return;
    const Eigen::Vector3d y = f.row(i);
    d -= d.dot(y) * y;
  };
  return untangle_tets(T, rules, max_rounds, f);
}

}  // namespace shapemap
