// Moved images located in the target, rows that turn a tet over put back (locate_keeping_positive.h).
#include "shapemap/volume/locate_keeping_positive.h"
#include "shapemap/volume/symmetric_map.h"

namespace shapemap {

int take_rows_keeping_positive(const ArapEnergy& arap, const TetMesh& Mj, const BarycentricMap& candidate,
                               std::vector<char> moved, BarycentricMap& located, Eigen::MatrixXd& X, int rounds) {
  BarycentricMap m = located;
  for (Eigen::Index v = 0; v < m.elem.size(); ++v)
    if (moved[size_t(v)]) {
      m.elem(v) = candidate.elem(v);
      m.bary.row(v) = candidate.bary.row(v);
    }
  // Before this, one such tet undid all the moves of a map (cat -> lion: a whole stage of
  // relaxation, or every round of one map's reconciliation).
  const Eigen::VectorXd det_before = arap.determinants(X);
  const Eigen::MatrixXi& T = arap.tets();
  int put_back = 0;
  for (int round = 0; round < rounds; ++round) {
    Eigen::MatrixXd P = map_positions(m, Mj.V, Mj.T);
    const Eigen::VectorXd det = arap.determinants(P);
    int turned = 0;
    const int before_round = put_back;
    for (Eigen::Index k = 0; k < det.size(); ++k) {
      if (!(det(k) <= 0) || det_before(k) <= 0) continue;  // as count_inverted counts
      ++turned;
      for (int c = 0; c < 4; ++c) {
        const int v = T(k, c);
        if (!moved[size_t(v)]) continue;
        m.elem(v) = located.elem(v);
        m.bary.row(v) = located.bary.row(v);
        moved[size_t(v)] = 0;
        ++put_back;
      }
    }
    if (turned == 0) {
      X = std::move(P);
      located = std::move(m);
      return put_back;
    }
    if (put_back == before_round) break;  // only rows that did not move: no progress
  }
  return -1;
}

int relocate_interior(const ArapEnergy& arap, const TetMesh& Mj, const std::vector<int>& interior,
                      const Eigen::MatrixXd& X_before, Eigen::MatrixXd& X, BarycentricMap& located, int rounds) {
  Eigen::MatrixXd Q(interior.size(), 3);
  for (size_t q = 0; q < interior.size(); ++q) Q.row(Eigen::Index(q)) = X.row(interior[q]);
  const BarycentricMap inside = locate_in_tets(Mj, Q);
  BarycentricMap candidate = located;
  std::vector<char> moved(size_t(X.rows()), 0);
  for (size_t q = 0; q < interior.size(); ++q) {
    const int v = interior[q];
    candidate.elem(v) = inside.elem(Eigen::Index(q));
    candidate.bary.row(v) = inside.bary.row(Eigen::Index(q));
    moved[size_t(v)] = X.row(v) != X_before.row(v);  // the others stay as located before
  }
  X = X_before;
  return take_rows_keeping_positive(arap, Mj, candidate, std::move(moved), located, X, rounds);
}

}  // namespace shapemap
