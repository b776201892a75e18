// Discrete thin-shell deformation energy of elastic correspondence
// (elastic-correspondence.txt, Sec. 4):
//   W_def(X, Y) = alpha * W_mem(X, Y) + eta * W_bnd(X, Y)                       (Eq. 2)
//   W_mem = sum_t a^_t W(G_t),  G_t = g^_t^{-1} g_t,                             (Eq. 7)
//   W(A)  = mu/2 tr A + lambda/4 det A - (mu/2 + lambda/4) log det A - mu - lambda/4,
//           with -log d replaced below d < eps by its C^1 linear extension
//           -log eps - (d - eps)/eps (Sec. 4.1), so collapsed triangles stay finite;
//   W_bnd = sum_{admissible e} (cos th^_e - cos th_e)^2 l^_e^2 / d^_e           (Eq. 9)
//           cos th_e = <n_t, n_t'>, d^_e = (a^_t + a^_t')/3, and an edge is admissible
//           when neither adjacent triangle is degenerate, re-evaluated at every
//           evaluation (Sec. 5.2, "Masking edge sets").
// X (reference, hats) is fixed at construction; Y is the deformed configuration with
// the same connectivity. The energy is invariant to rigid motions of Y and zero at Y = X.
// Gradients are exact; evaluation of large meshes is parallel over faces then vertices
// (OpenMP) with per-element results gathered in a fixed order (the serial path adds the
// same terms in the same order), so results do not depend on the thread count.
#pragma once
#include <Eigen/Core>
#include <vector>

namespace shapemap {

struct ShellEnergyOptions {
  double alpha = 20.0;          // membrane weight, Eq. 2 (Sec. 5.2: alpha = 20)
  double eta = 0.1;             // bending weight, Eq. 2 (Sec. 6.1 SHREC'07: eta = 0.1)
  double lambda = 1.0;          // Lame coefficient lambda, Eq. 7 (Sec. 4.1: lambda = mu = 1)
  double mu = 1.0;              // Lame coefficient mu, Eq. 7
  double log_eps = 1e-4;        // Sec. 4.1: -log det linearly extended below det G < eps
  double degenerate_tol = 1e-8; // Sec. 5.2: triangle degenerate if |n_t(Y)| <= tol * |n_t(X)|
                                //   (n unnormalized: twice the area); such triangles mask edges
  // freeze_mask(y, true) also leaves out the edges of slivers, |n_t(Y)| < mask_tol |n_t(X)|
  // (ours, issue 20; the elastic Y steps ask for it when their line search fails, see
  // ElasticOptions::mask_tol): a sliver's unit normal turns over under moves far smaller than
  // a quasi-Newton step, so the bending term of Eq. 9 at its edges jumps between trial points.
  double mask_tol = 1e-2;
  // Evaluate with OpenMP only from this many faces on (not from the paper). One evaluation
  // of a 5k-vertex mesh takes ~0.8 ms on one core; on the shared 2-core machine a parallel
  // region per evaluation made it 10-25x slower (threads wait for a descheduled partner),
  // so mid-size meshes run serially; even on an idle machine the parallel path was slower at
  // 8.5k faces (1,423 against 1,146 us, 5 Dec 2026) and no faster at 10k vertices a side.
  // At 46.6k faces (a generated 25k-vertex mesh) one evaluation is faster (4.73 against
  // 6.33 ms), but the SHREC'07 busts' Y steps (50k faces a side) with the limit at 32k were
  // only 3-13% faster (two runs each, 6 Dec 2026), so the limit stays.
  // Results are bitwise identical either way.
  int parallel_min_faces = 1 << 16;
};

// The parts of one evaluation.
struct ShellEnergyTerms {
  double membrane = 0;          // W_mem (unweighted)
  double bending = 0;           // W_bnd (unweighted, admissible edges only)
  double total = 0;             // alpha W_mem + eta W_bnd
  int admissible_edges = 0;     // edges that entered W_bnd
  int degenerate_faces = 0;     // faces of Y with |n| <= degenerate_tol |n^|
};

// Precompute-then-evaluate solver object. Not thread-safe (uses internal scratch
// buffers so that evaluations do not allocate).
class ShellEnergy {
 public:
  ShellEnergy() = default;
  // X: n×3 reference positions; F: m×3 triangles (manifold; boundary edges allowed and
  // simply carry no bending term).
  ShellEnergy(const Eigen::MatrixXd& X, const Eigen::MatrixXi& F,
              const ShellEnergyOptions& opt = {});

  // y: 3n values, row-major positions (y[3i+k] = Y(i,k)). Returns alpha W_mem + eta W_bnd.
  // grad (may be null): 3n values, overwritten with the gradient. terms (may be null).
  double evaluate(const double* y, double* grad, ShellEnergyTerms* terms = nullptr) const;
  // Convenience: Y n×3; G (may be null) receives n×3.
  double evaluate(const Eigen::MatrixXd& Y, Eigen::MatrixXd* G = nullptr,
                  ShellEnergyTerms* terms = nullptr) const;

  // Freezes the admissible edge set at configuration y (3n values): until unfreeze_mask(),
  // evaluations use this set instead of recomputing it, so the energy is continuous along
  // a line search (Sec. 5.2 updates the set between quasi-Newton iterations, not within
  // them). A frozen-admissible edge whose face collapses exactly makes the energy +inf.
  // Returns true when the set differs from the one frozen by the previous call (or there
  // was none), so that a caller may keep an evaluation made under the previous set.
  // leave_out_slivers: also the edges of faces below mask_tol of their rest area.
  bool freeze_mask(const double* y, bool leave_out_slivers = false);
  void unfreeze_mask() { frozen_ = false; }
  void set_weights(double alpha, double eta) { opt_.alpha = alpha; opt_.eta = eta; }
  const ShellEnergyOptions& options() const { return opt_; }
  int num_vertices() const { return n_; }
  int num_faces() const { return int(F_.rows()); }
  int num_edges() const { return int(E_.rows()); }
  // Interior edges (two faces) with a non-degenerate reference pair: k×4 rows
  // [f0, f1, v_a, v_b] (shared edge (v_a, v_b)).
  const Eigen::MatrixXi& interior_edges() const { return E_; }

 private:
  // evaluate()'s two passes over face f at configuration y (3n values). Pass 1: normal,
  // degeneracy, membrane energy and its gradient w.r.t. the edge vectors (Eq. 7). Pass 2:
  // the bending terms (Eq. 9) of f's interior edges from the stored normals, and f's 9
  // corner gradients (corner-major) into out when want_grad.
  void membrane_face(int f, const double* y, bool want_grad) const;
  void bending_face(int f, const double* y, bool want_grad, bool do_bend, double* out) const;
  ShellEnergyOptions opt_;
  int n_ = 0;
  Eigen::MatrixXi F_;
  Eigen::MatrixXd ginv_;       // m×3: (g^-1)_00, (g^-1)_01, (g^-1)_11 of the reference
  Eigen::VectorXd area_;       // m: reference areas a^_t
  Eigen::VectorXd detg_;       // m: det g^_t = |n^_t|^2 (= 4 a^_t^2)
  Eigen::VectorXd nref_;       // m: |n^_t| (unnormalized normal length)
  Eigen::MatrixXi E_;          // k×4 interior edges (see interior_edges())
  Eigen::VectorXd cos_ref_;    // k: cos th^_e
  Eigen::VectorXd weight_;     // k: l^_e^2 / d^_e
  Eigen::MatrixXi face_edge_;  // m×3: interior edge index of each face slot, or -1
  Eigen::MatrixXi face_side_;  // m×3: 0 if the face is E_(e,0) for that edge, else 1
  std::vector<int> vf_start_, vf_face_, vf_corner_;  // vertex -> (face, corner) CSR
  // scratch, per evaluation
  mutable std::vector<char> fdeg_;    // m: face of Y degenerate
  mutable std::vector<double> fNlen_; // m: |N_t(Y)| (unnormalized normal length)
  mutable std::vector<double> fn_;    // 3m: unit normals of Y (0 if collapsed)
  mutable std::vector<double> fmem_;  // 6m: membrane gradient w.r.t. e1, e2 per face
  mutable std::vector<double> fgrad_; // 9m: per-face corner gradients, face-major
  mutable Eigen::VectorXd fenergy_;   // m membrane energy per face (weighted by a^)
  mutable std::vector<double> fbend_; // m: bending energy of the edges whose side-0 face it is
  mutable std::vector<char> fadm_;    // m: number of those edges that are admissible
  // Face slot j (edge opposite corner j): interior edge e (or -1), the face's side of it,
  // the neighbour h across it, and the edge's cos th^ and weight l^2/d^ (copies, packed).
  struct Slot {
    int e = -1, side = 0, h = -1;
    double cosr = 0, w = 0;
  };
  std::vector<Slot> slots_;           // 3m
  bool frozen_ = false;
  std::vector<char> frozen_adm_;    // k, admissible set of freeze_mask()
  bool frozen_once_ = false;        // freeze_mask() was called (frozen_adm_ is its set)
};

// Membrane density W of Eq. 7 with the linear extension, as a function of
// t = tr G and d = det G; writes dW/dt and dW/dd if non-null (for tests and metrics).
double membrane_density(double t, double d, double lambda, double mu, double eps,
                        double* dW_dt = nullptr, double* dW_dd = nullptr);

}  // namespace shapemap
