// How well the image of the source's boundary covers the target's boundary, kept up to date
// under moves of single image vertices (ours, issue 19). The landing's later steps move
// boundary images along dM_j (reconcile_boundary.h); each such move may pull the image away
// from a tip or ridge of dM_j and leave one of its vertices uncovered, which d^ (Eq. 28's
// backward half: dM_j's vertices to the image) measures. This guard refuses those moves.
#pragma once
#include <Eigen/Core>
#include <functional>
#include <vector>

namespace shapemap {

class TargetCoverage {
 public:
  // Image surface: triangles Fi over surface vertices s at X.row(rows[s]); target vertices
  // Vj (k×3), points of dM_j. X is read here and by move(), not kept.
  TargetCoverage(const Eigen::MatrixXd& X, const Eigen::MatrixXi& Fi, const std::vector<int>& rows,
                 const Eigen::MatrixXd& Vj);

  // Surface vertex of X's row (-1: not on the image's boundary).
  int surface_vertex(int row) const { return row < int(to_surface_.size()) ? to_surface_[row] : -1; }

  // Tries move(row of s), which moves X.row(row) or returns false. The move is kept when no
  // target vertex whose closest image face is at s (the only ones it can uncover) ends
  // farther from the image than max(allowed, the largest of their distances before),
  // measured against the faces at s and at its neighbours (an upper bound of the true
  // distance); else X.row is put back. Returns whether it was kept.
  bool move(Eigen::MatrixXd& X, int s, const std::function<bool(int)>& move, double allowed);

  const std::vector<double>& distances() const { return dist_; }  // per target vertex

 private:
  const Eigen::MatrixXi& Fi_;
  const std::vector<int>& rows_;
  const Eigen::MatrixXd& Vj_;
  std::vector<int> to_surface_, face_;
  std::vector<double> dist_;
  std::vector<std::vector<int>> vf_, ring_, by_face_;
};

// Where the image does not cover the target (the landing's local gamma round): the vertices
// of dM_j (Vj, faces Fj) farther than `far` from the image surface (Fi over X.row(rows[s])),
// grown by `rings` rings of Fj (marked_j, per target vertex), and the image's surface
// vertices s within `reach` of one of those far vertices (marked_i, per s). Returns the
// number of far vertices (0: nothing marked).
int mark_uncovered(const Eigen::MatrixXd& X, const Eigen::MatrixXi& Fi, const std::vector<int>& rows,
                   const Eigen::MatrixXd& Vj, const Eigen::MatrixXi& Fj, double far, int rings, double reach,
                   std::vector<char>& marked_i, std::vector<char>& marked_j);

}  // namespace shapemap
