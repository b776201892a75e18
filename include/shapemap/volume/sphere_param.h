// Spherical area-preserving parameterization of a genus-0 closed triangle surface: the
// boundary map of the ball parameterization (isovolumetric-ball-parameterization.txt,
// Algorithm 1 step 6, which cites [28, Alg. 4.3]).
//
// Method (docs/methods.md, "Isovolumetric ball parameterization"):
//  1. Linear spherical map: one face is sent to infinity; the rest solves the cotangent
//     Laplace equation in the plane with that face's three vertices fixed (Angenent/Haker
//     style puncture), then inverse stereographic projection.
//  2. Conformal energy minimization on the sphere (Yueh, Lin, Wu, Yau 2017): alternate the
//     hemispheres by the inversion z -> z/|z|^2 and re-solve the harmonic problem inside the
//     disk |z| < R_c with the outside fixed, while the conformal energy decreases.
//  3. Stretch energy minimization (Yueh, Lin, Wu, Yau 2019, "A novel stretch energy
//     minimization algorithm for equiareal parameterizations"): the same alternation with
//     the stretch Laplacian L_S(f), cotangent weights of the image divided by the stretch
//     factor sigma = (target area share) / (image area share), while E_S - A decreases.
// CEM steps that would increase the energy or the number of folded triangles are rejected
// (and stop the stage). SEM is run as published (not monotone); the iterate with the lowest
// authalic energy E_A is kept, its folded faces (if any) are untangled locally, then the
// Riemannian refinement below (4.) polishes E_A without creating folds.
// Steps 3-4 run for several candidates (published SEM and a damped SEM, each from the CEM
// result and from the linear map when CEM changed it; see stretch_fold_allowance and
// try_linear_start) and the result that has not collapsed a part (latitude_start_distortion),
// then with the fewest folded faces, then the lowest E_A, is kept: on coarse creatures the
// undamped SEM fixed point folds hundreds of faces.
#pragma once
#include "shapemap/mesh.h"
#include "shapemap/progress.h"

namespace shapemap {

struct SphereParamOptions {
  int conformal_iterations = 20;     // CEM hemisphere alternations (Yueh et al. 2017)
  double conformal_tolerance = 1e-6; // stop CEM when the energy decrease is below this
  double conformal_radius = 1.2;     // disk |z| < R re-solved in each CEM step
  int stretch_iterations = 50;       // SEM alternations (Yueh et al. 2019)
  double stretch_tolerance = 1e-7;   // stop SEM when the relative decrease is below this
  double stretch_radius = 1.3;       // disk |z| < R re-solved in each SEM step
  // Damped SEM candidate (not in Yueh et al. 2019; added for coarse creatures, where the
  // undamped fixed point folds hundreds of faces): a step whose image has more than
  // max(folds of the start, stretch_fold_allowance * #faces) folded faces is damped
  // (t = 1/2, ..., 1/64 of the way); SEM stops when no damped step is within it. It runs
  // besides the published (undamped) SEM and the result with fewer folded faces, then lower
  // E_A, is kept. >= 1 = only the published SEM.
  double stretch_fold_allowance = 0.01;
  // Also run SEM + refinement from the linear map (skipping CEM) when CEM changed it
  // (CEM can compress thin parts further); selection as above.
  bool try_linear_start = true;
  // A result whose max area distortion |share ratio - 1| exceeds this has collapsed a part:
  // it loses the selection to any result that has not (whatever their folded faces), and
  // SEM + refinement are also run from the latitude-longitude map of Brechbuehler, Gerig,
  // Kuebler 1995 (harmonic latitude between two far-apart poles, harmonic longitude with a
  // date line, polar angle by area), which does not shrink long thin parts exponentially
  // as the conformal starts do. Not run on every folded result: on shrec07-61 (1 folded
  // face, distortion 2.9) it wins the selection but the ball map gets worse (mean D_V
  // 0.062 -> 0.080). 0 = off (selection by folded faces, then E_A, only).
  double latitude_start_distortion = 10;
  // 4. Riemannian refinement of the authalic energy E_A (Sutti & Yueh 2024, "Riemannian
  // gradient descent methods for spherical area-preserving mappings"): projected-gradient
  // steps on the product of spheres with retraction by normalization, preconditioned by
  // the (shifted) cotangent Laplacian of the sphere mesh, Polak-Ribiere+ CG directions,
  // Armijo backtracking, and no step may increase the number of folded faces.
  int authalic_iterations = 400;     // 0 = off (the SEM result is used as is)
  double authalic_tolerance = 1e-9;  // stop when the relative decrease of E_A is below this
};

struct SphereParamResult {
  Eigen::MatrixXd S;                 // n×3, unit vectors, outward orientation preserved
  int conformal_iterations = 0, stretch_iterations = 0;
  double conformal_energy = 0;       // E_C = 1/2 tr(S^T L S) - A(S) after CEM
  double stretch_energy_initial = 0; // E_S - A(S) before SEM
  double stretch_energy = 0;         // E_S - A(S) after SEM
  int stretch_folded_faces = 0;      // folded faces of the best SEM iterate (before untangling)
  int stretch_damped_steps = 0;      // SEM steps that were damped (t < 1)
  int start_stage = 0;               // start of SEM kept: 0 = CEM result, 1 = linear map,
                                     // 2 = latitude-longitude map
  bool stretch_damped = false;       // the kept result used the damped SEM (fold allowance)
  int authalic_iterations = 0;       // Riemannian refinement iterations taken
  double authalic_energy_initial = 0; // E_A = A(e)/A(S) E_S - A(S) (shares) before refinement
  double authalic_energy = 0;         // E_A at the end
  // Area distortion of the result: mean and max over faces of |a_S/A(S) / (w/W) - 1|.
  double area_distortion_mean = 0, area_distortion_max = 0;
  int folded_faces = 0;              // faces whose image is negatively oriented
  double seconds = 0;
};

// surface: closed genus-0 triangle mesh, outward oriented (V n×3, F m×3).
// face_weights: optional m target area shares (default: the triangle areas of surface).
// Throws InputError for a surface that is too small or not closed.
SphereParamResult spherical_area_preserving_map(const TriMesh& surface,
                                                const Eigen::VectorXd& face_weights = {},
                                                const SphereParamOptions& opt = {},
                                                const ProgressCallback& progress = {});

// Number of faces of F whose image on the sphere S (n×3) is negatively oriented
// (S_i . (S_j x S_k) <= 0).
int spherical_folded_faces(const Eigen::MatrixXd& S, const Eigen::MatrixXi& F);

}  // namespace shapemap
