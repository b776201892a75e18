// Limited-memory BFGS with a line search (strong Wolfe by default, Armijo backtracking
// as an option, which elastic correspondence Algorithm 1 uses).
#pragma once
#include <Eigen/Core>
#include <functional>
#include <vector>

namespace shapemap {

// Returns f(x) and writes the gradient into g (already sized like x).
using Objective = std::function<double(const Eigen::VectorXd& x, Eigen::VectorXd& g)>;

struct LbfgsOptions {
  int max_iterations = 50;
  int memory = 10;
  double grad_tol = 1e-8;       // stop when ||g||_inf < grad_tol
  double f_decrease_tol = 0;    // stop when f_old - f_new < f_decrease_tol * max(1,|f|) (0 = off)
  bool wolfe = true;            // strong Wolfe (c1=1e-4, c2=0.9) if true, else Armijo backtracking
  double c1 = 1e-4, c2 = 0.9;
  int max_line_search = 40;
};

struct LbfgsResult {
  int iterations = 0;
  int evaluations = 0;
  double f = 0, grad_norm = 0;
  bool converged = false;  // a tolerance was met (not max_iterations, not a failed line search)
};

LbfgsResult lbfgs_minimize(const Objective& f, Eigen::VectorXd& x, const LbfgsOptions& opt = {});

// L-BFGS over the rows `free_rows` of an n×3 X (the others fixed) of an objective f(X, grad)
// on the full X (grad: n×3, resized by f). `iterations` and `memory` as in LbfgsOptions;
// stops on ||g||_inf < 1e-10 or a relative decrease below 1e-12. Returns the result with f
// and the Euclidean grad_norm at the final X.
LbfgsResult minimize_rows(const std::function<double(const Eigen::MatrixXd&, Eigen::MatrixXd*)>& f,
                          Eigen::MatrixXd& X, const std::vector<int>& free_rows, int iterations, int memory);

}  // namespace shapemap
