// The compiled part of the Python package `shapemap` (pybind11): thin bindings of the
// library's pipelines (surface_map_pipeline.h, volume_map_pipeline.h, ball, register,
// metrics). numpy in, numpy out; maps come back as (element, bary) pairs and reports as
// JSON text, which python/shapemap/__init__.py turns into Map objects and dicts.
// Long calls release the GIL; the progress callback takes it back to call Python and to
// check for Ctrl-C (PyErr_CheckSignals), which aborts the computation by an exception.
#include "shapemap/checks.h"
#include "shapemap/error.h"
#include "shapemap/eval/ball_metrics.h"
#include "shapemap/eval/volume_metrics.h"
#include "shapemap/io.h"
#include "shapemap/maps.h"
#include "shapemap/surface/prepared_surface_io.h"
#include "shapemap/surface/surface_map_pipeline.h"
#include "shapemap/volume/ball_param.h"
#include "shapemap/volume/register.h"
#include "shapemap/volume/tetrahedralize.h"
#include "shapemap/volume/volume_map_pipeline.h"
#include <omp.h>
#include <pybind11/eigen.h>
#include <pybind11/functional.h>
#include <pybind11/pybind11.h>
#include <pybind11/stl.h>
#include <atomic>
#include <chrono>
#include <memory>
#include <thread>

namespace py = pybind11;
using namespace shapemap;

namespace {

using RowMatrixXd = Eigen::Matrix<double, Eigen::Dynamic, Eigen::Dynamic, Eigen::RowMajor>;
using RowMatrixXi = Eigen::Matrix<int, Eigen::Dynamic, Eigen::Dynamic, Eigen::RowMajor>;
using PyMap = std::pair<Eigen::VectorXi, RowMatrixXd>;  // (element, bary) from Python

// Thrown from the progress callback after Ctrl-C; the library unwinds (RAII) and the
// binding raises KeyboardInterrupt once it holds the GIL again.
struct Interrupted {};

// The progress callback handed to the library. Called from any thread: Python is only
// entered from the thread that made the call, outside OpenMP parallel regions, and at most
// every 20 ms; there it checks for signals (Ctrl-C) and calls the user's callback.
struct PyProgress {
  py::object callback;  // None or callable(stage: str, fraction: float)
  std::thread::id owner = std::this_thread::get_id();
  std::atomic<long long> last_ms{0};
  std::atomic<bool> interrupted{false};

  ProgressCallback function() {
    return [this](const std::string& stage, double fraction) {
      // Never from inside a parallel region, active or not (omp_get_level, not
      // omp_in_parallel: with one thread the region is inactive, and an exception thrown
      // there to stop the call would end the process).
      if (std::this_thread::get_id() != owner || omp_get_level() > 0) return;
      const long long now = std::chrono::duration_cast<std::chrono::milliseconds>(
                                std::chrono::steady_clock::now().time_since_epoch()).count();
      if (interrupted) throw Interrupted{};
      if (now - last_ms < 20 && fraction < 1.0) return;
      last_ms = now;
      py::gil_scoped_acquire gil;
      if (PyErr_CheckSignals() != 0) {
        PyErr_Clear();
        interrupted = true;
        throw Interrupted{};
      }
      if (!callback.is_none()) callback(stage, fraction);
    };
  }
};

// Runs f with the GIL released; Ctrl-C becomes KeyboardInterrupt. Library errors keep
// their one-line message (InputError -> ValueError, Error -> RuntimeError).
template <class F>
auto without_gil(PyProgress& p, F&& f) {
  try {
    py::gil_scoped_release release;
    return f(p.function());
  } catch (const Interrupted&) {
    PyErr_SetNone(PyExc_KeyboardInterrupt);
    throw py::error_already_set();
  }
}

void set_threads(int threads) {
  if (threads > 0) omp_set_num_threads(threads);
}

TriMesh tri_mesh(const RowMatrixXd& V, const RowMatrixXi& F, const char* what) {
  if (V.cols() != 3) throw InputError(std::string(what) + ": vertices must be n x 3");
  TriMesh m{V, F};
  require_element_indices(m.F, m.V.rows(), 3, what);
  return m;
}

TetMesh tet_mesh(const RowMatrixXd& V, const RowMatrixXi& T, const char* what) {
  if (V.cols() != 3) throw InputError(std::string(what) + ": vertices must be n x 3");
  TetMesh m{V, T};
  require_element_indices(m.T, m.V.rows(), 4, what);
  return m;
}

BarycentricMap to_map(const PyMap& m) { return {m.first, m.second}; }
py::tuple from_map(const BarycentricMap& m) { return py::make_tuple(m.elem, RowMatrixXd(m.bary)); }

// surface_map(VA, FA, VB, FB, options): the library's run_surface_map.
py::dict surface_map(const RowMatrixXd& VA, const RowMatrixXi& FA, const RowMatrixXd& VB, const RowMatrixXi& FB,
                     const py::dict& o, py::object progress) {
  SurfaceMapRequest req;
  req.method = o["method"].cast<std::string>();
  req.symmetric = o["symmetric"].cast<bool>();
  req.strict = o["strict"].cast<bool>();
  req.bim.seed = o["seed"].cast<std::uint64_t>();
  req.bim.max_features = o["features"].cast<int>();
  req.bim.max_candidates = o["candidates"].cast<int>();
  req.bim.num_even = o["samples"].cast<int>();
  req.bim.reverse_candidates = o["reverse_candidates"].cast<bool>();
  req.bim.matching_search_sweeps = o["matching_search"].cast<int>();
  req.bim.landmark_feature_points = o["landmark_features"].cast<bool>();
  req.bim.blend_min_features = o["blend_features"].cast<int>();
  req.bim.blend_retry_triples = o["blend_triples"].cast<int>();
  req.bim.blend_guide_maps = o["blend_guide_maps"].cast<int>();
  std::tie(req.bim.name_A, req.bim.name_B) = o["names"].cast<std::pair<std::string, std::string>>();
  if (!o["landmarks"].is_none()) {
    auto l = o["landmarks"].cast<std::pair<std::vector<int>, std::vector<int>>>();
    req.bim.landmarks_A = l.first;
    req.bim.landmarks_B = l.second;
    tidy_landmark_pairs(req.bim.landmarks_A, req.bim.landmarks_B, "landmarks A", "landmarks B");
  }
  if (!o["init"].is_none()) req.init_AB = to_map(o["init"].cast<PyMap>());
  if (!o["init_reverse"].is_none()) req.init_BA = to_map(o["init_reverse"].cast<PyMap>());
  if (!o["prepared"].is_none())
    std::tie(req.prepared_A, req.prepared_B) =
        o["prepared"].cast<std::pair<std::shared_ptr<PreparedSurface>, std::shared_ptr<PreparedSurface>>>();
  if (!o["truth"].is_none()) req.truth_AB = to_map(o["truth"].cast<PyMap>());
  ElasticSettings& e = req.elastic;
  e.preset = o["elastic_preset"].cast<std::string>();
  e.eta = o["elastic_eta"].cast<double>();
  e.alpha = o["elastic_alpha"].cast<double>();
  e.iterations = o["elastic_iterations"].cast<int>();
  e.injective = o["elastic_injective"].cast<bool>();
  e.partial = o["elastic_partial"].cast<bool>();
  e.keep_worse = o["elastic_keep_worse"].cast<bool>();
  e.untangle = o["elastic_untangle"].cast<bool>();
  e.wide_untangle = o["elastic_wide_untangle"].cast<bool>();
  e.sliver_untangle = o["elastic_sliver_untangle"].cast<bool>();
  e.bridge_untangle = o["elastic_bridge_untangle"].cast<bool>();
  e.search_untangle = o["elastic_search_untangle"].cast<bool>();
  e.untangle_passes = o["elastic_untangle_passes"].cast<int>();
  e.feature_anchors = o["elastic_feature_anchors"].cast<bool>();
  e.collapsed_parts = o["elastic_collapsed_parts"].cast<bool>();
  e.plain_projection = o["elastic_plain_projection"].cast<bool>();
  e.plain_projection_in_ramp = o["elastic_plain_projection_in_ramp"].cast<bool>();
  e.guard_before_untangling = o["elastic_guard_before_untangling"].cast<bool>();
  e.anchor_hold_to_end = o["elastic_anchors_hold_to_end"].cast<bool>();
  e.anchor_weight = o["elastic_anchor_weight"].cast<double>();
  e.anchor_tolerance = o["elastic_anchor_tolerance"].cast<double>();
  set_threads(o["threads"].cast<int>());
  const TriMesh A = tri_mesh(VA, FA, req.bim.name_A.c_str()), B = tri_mesh(VB, FB, req.bim.name_B.c_str());
  PyProgress p{progress};
  SurfaceMapRun r = without_gil(p, [&](const ProgressCallback& cb) { return run_surface_map(A, B, req, cb); });
  py::dict out;
  out["AB"] = from_map(r.AB);
  out["BA"] = r.has_BA() ? py::object(from_map(r.BA)) : py::none();
  r.report["notes"] = r.notes;
  r.report["warnings"] = r.warnings;
  out["report"] = r.report.dump();
  return out;
}

SymmetricVolumeMapOptions volume_options(const py::dict& o) {
  SymmetricVolumeMapOptions v;
  v.alpha = o["alpha"].cast<double>();
  v.alpha_final = o["alpha_final"].cast<double>();
  v.gamma = o["gamma"].cast<double>();
  v.beta_start = o["beta_start"].cast<double>();
  v.beta_end = o["beta_end"].cast<double>();
  v.max_iterations = o["max_iterations"].cast<int>();
  v.solver = o["solver"].cast<std::string>() == "lbfgs" ? XStepSolver::Lbfgs : XStepSolver::Newton;
  v.land_on_target = o["land_on_target"].cast<bool>();
  return v;
}

// A volume input: tets (4 columns) as they are, or a closed surface (3 columns) tetrahedralized.
VolumeInput volume_input(const RowMatrixXd& V, const RowMatrixXi& E, const std::string& name, const py::dict& o,
                         const ProgressCallback& cb) {
  if (E.cols() == 4) return volume_input_from_tets(tet_mesh(V, E, name.c_str()), name);
  const TriMesh s = tri_mesh(V, E, name.c_str());
  return volume_input_from_surface(s, name, o["tets"].cast<int>(), o["seed"].cast<std::uint64_t>(),
                                   o["strict"].cast<bool>(), cb);
}

py::dict volume_map(const RowMatrixXd& VA, const RowMatrixXi& EA, const RowMatrixXd& VB, const RowMatrixXi& EB,
                    const py::dict& o, py::object progress) {
  VolumeMapRequest req;
  const bool default_init = o["init"].is_none();  // as volume-map without --init
  req.init = default_init ? (!o["landmarks"].is_none()      ? "landmarks"
                             : !o["surface_map"].is_none() ? "surface-map"
                                                           : "auto")
                          : o["init"].cast<std::string>();
  req.auto_surface = o["auto_surface_map"].cast<std::string>();
  req.auto_reverse_candidates = o["reverse_candidates"].cast<bool>();
  req.boundary_stage = o["boundary_fixed_stage"].cast<std::string>();
  req.interior_init = o["interior_init"].cast<std::string>();
  req.strict = o["strict"].cast<bool>();
  req.opt = volume_options(o);
  std::vector<int> la, lb;
  if (!o["landmarks"].is_none())
    std::tie(la, lb) = o["landmarks"].cast<std::pair<std::vector<int>, std::vector<int>>>();
  if (!o["surface_map"].is_none()) {
    auto sm = o["surface_map"].cast<std::pair<PyMap, PyMap>>();
    req.surface_map_AB = to_map(sm.first);
    req.surface_map_BA = to_map(sm.second);
  }
  set_threads(o["threads"].cast<int>());
  PyProgress p{progress};
  auto run = without_gil(p, [&](const ProgressCallback& cb) {
    const auto names = o["names"].cast<std::pair<std::string, std::string>>();
    auto A = std::make_shared<VolumeInput>(volume_input(VA, EA, names.first, o, cb));
    auto B = std::make_shared<VolumeInput>(volume_input(VB, EB, names.second, o, cb));
    req.landmarks_A = carry_landmarks_to_volume(*A, la);
    req.landmarks_B = carry_landmarks_to_volume(*B, lb);
    const bool sparse = default_init && req.init == "landmarks" &&
                        sparse_landmark_start(req.landmarks_A, req.landmarks_B, *A, *B, req.strict);
    if (sparse) req.init = "auto";
    VolumeMapRun r = run_volume_map(*A, *B, req, cb);
    if (sparse) r.notes.insert(r.notes.begin(), sparse_landmark_start_note());
    return std::make_tuple(A, B, std::move(r));
  });
  auto& [A, B, r] = run;
  py::dict out;
  out["AB"] = from_map(r.result.map12);
  out["BA"] = from_map(r.result.map21);
  out["X_AB"] = RowMatrixXd(r.result.X12);
  out["X_BA"] = RowMatrixXd(r.result.X21);
  out["VA"] = RowMatrixXd(A->mesh.V);
  out["TA"] = RowMatrixXi(A->mesh.T);
  out["VB"] = RowMatrixXd(B->mesh.V);
  out["TB"] = RowMatrixXi(B->mesh.T);
  nlohmann::json rep = r.report;
  rep["inputs"] = {{"A_vertices", A->mesh.num_vertices()}, {"A_tets", A->mesh.num_tets()},
                   {"B_vertices", B->mesh.num_vertices()}, {"B_tets", B->mesh.num_tets()},
                   {"A_tetrahedralized", A->from_surface}, {"B_tetrahedralized", B->from_surface}};
  rep["notes"] = r.notes;
  out["report"] = rep.dump();
  return out;
}

nlohmann::json ball_metrics_dict(const BallMetrics& m) {
  return {{"num_vertices", m.num_vertices}, {"num_tets", m.num_tets},
          {"D_V_mean", m.dv_mean}, {"D_V_sd", m.dv_sd}, {"D_V_p50", m.dv_p50}, {"D_V_p95", m.dv_p95},
          {"D_V_max", m.dv_max}, {"E_I", m.energy}, {"positive_tets", m.positive_tets},
          {"negative_tets", m.negative_tets}, {"folded_tets", m.folded_tets},
          {"flipped_boundary_faces", m.flipped_boundary_faces}, {"overlap_fraction", m.overlap_fraction},
          {"uncovered_fraction", m.uncovered_fraction}, {"boundary_sphere_error", m.boundary_sphere_error},
          {"max_radius", m.max_radius}};
}

py::tuple ball(const RowMatrixXd& V, const RowMatrixXi& T, int threads, py::object progress) {
  set_threads(threads);
  const TetMesh M = tet_mesh(V, T, "mesh");
  PyProgress p{progress};
  BallParamResult r = without_gil(p, [&](const ProgressCallback& cb) { return ball_parameterization(M, {}, cb); });
  nlohmann::json rep = {{"metrics", ball_metrics_dict(ball_metrics(M, r.f))}, {"iterations", r.iterations},
                        {"energy_vsem", r.energy_vsem}, {"energy_final", r.energy_final},
                        {"seconds_total", r.seconds_total}};
  return py::make_tuple(RowMatrixXd(r.f), rep.dump());
}

py::dict register_volumes(const RowMatrixXd& VA, const RowMatrixXi& TA, const RowMatrixXd& VB,
                          const RowMatrixXi& TB, int threads, py::object progress) {
  set_threads(threads);
  const TetMesh A = tet_mesh(VA, TA, "A"), B = tet_mesh(VB, TB, "B");
  PyProgress p{progress};
  RegisterResult r =
      without_gil(p, [&](const ProgressCallback& cb) { return register_through_ball(A, B, {}, cb); });
  const VolumeMapMetrics m12 = volume_map_metrics(A, B, r.A_on_B), m21 = volume_map_metrics(B, A, r.B_on_A);
  nlohmann::json rep = {{"d_phi", r.d_phi}, {"d_phi_relative", r.d_phi_relative},
                        {"metrics", volume_metrics_json(m12)}, {"metrics_BA", volume_metrics_json(m21)},
                        {"seconds_total", r.seconds_total}};
  py::dict out;
  out["AB"] = from_map(r.map_AB);
  out["BA"] = from_map(r.map_BA);
  out["report"] = rep.dump();
  return out;
}

void bind_io(py::module_& m) {
  m.def("read_surface", [](const std::string& path) {
    const TriMesh s = read_surface(path);
    return py::make_tuple(RowMatrixXd(s.V), RowMatrixXi(s.F));
  });
  m.def("read_volume", [](const std::string& path) {
    const TetMesh s = read_volume(path);
    return py::make_tuple(RowMatrixXd(s.V), RowMatrixXi(s.T));
  });
  m.def("write_surface", [](const std::string& path, const RowMatrixXd& V, const RowMatrixXi& F) {
    write_surface(path, tri_mesh(V, F, path.c_str()));
  });
  m.def("write_volume", [](const std::string& path, const RowMatrixXd& V, const RowMatrixXi& T) {
    write_volume(path, tet_mesh(V, T, path.c_str()));
  });
  m.def("read_map", [](const std::string& path) { return from_map(read_map(path)); });
  m.def("write_map", [](const std::string& path, const Eigen::VectorXi& elem, const RowMatrixXd& bary) {
    write_map(path, BarycentricMap{elem, bary});
  });
  m.def("tetrahedralize", [](const RowMatrixXd& V, const RowMatrixXi& F, int tets, std::uint64_t seed,
                             bool strict, py::object progress) {
    PyProgress p{progress};
    VolumeInput in = without_gil(p, [&](const ProgressCallback& cb) {
      return volume_input_from_surface(tri_mesh(V, F, "surface"), "surface", tets, seed, strict, cb);
    });
    return py::make_tuple(RowMatrixXd(in.mesh.V), RowMatrixXi(in.mesh.T));
  });
}

void bind_evaluate(py::module_& m) {
  m.def("evaluate_surface", [](const RowMatrixXd& VA, const RowMatrixXi& FA, const RowMatrixXd& VB,
                               const RowMatrixXi& FB, const PyMap& P,
                               std::optional<PyMap> Q,
                               std::optional<PyMap> truth) {
    const TriMesh A = tri_mesh(VA, FA, "A"), B = tri_mesh(VB, FB, "B");
    const BarycentricMap p = to_map(P), q = Q ? to_map(*Q) : BarycentricMap{};
    const BarycentricMap t = truth ? to_map(*truth) : BarycentricMap{};
    validate_map(p, A.num_vertices(), B.num_faces(), 3, "map");
    if (Q) validate_map(q, B.num_vertices(), A.num_faces(), 3, "reverse map");
    if (truth) validate_map(t, A.num_vertices(), B.num_faces(), 3, "truth");
    return surface_map_metrics_json(A, B, p, Q ? &q : nullptr, truth ? &t : nullptr).dump();
  });
  m.def("evaluate_volume", [](const RowMatrixXd& VA, const RowMatrixXi& TA, const RowMatrixXd& VB,
                              const RowMatrixXi& TB, const PyMap& P,
                              std::optional<PyMap> Q) {
    const TetMesh A = tet_mesh(VA, TA, "A"), B = tet_mesh(VB, TB, "B");
    const BarycentricMap p = to_map(P);
    validate_map(p, A.num_vertices(), B.num_tets(), 4, "map");
    const Eigen::MatrixXd X = map_positions(p, B.V, B.T);
    if (!Q) return volume_metrics_json(volume_map_metrics(A, B, X, &p)).dump();
    const BarycentricMap q = to_map(*Q);
    validate_map(q, B.num_vertices(), A.num_tets(), 4, "reverse map");
    const Eigen::MatrixXd Y = map_positions(q, A.V, A.T);
    return volume_metrics_json(volume_map_metrics(A, B, X, &p, &Y)).dump();
  });
  m.def("evaluate_ball", [](const RowMatrixXd& V, const RowMatrixXi& T, const RowMatrixXd& f) {
    const TetMesh M = tet_mesh(V, T, "mesh");
    if (f.rows() != M.num_vertices() || f.cols() != 3) throw InputError("ball map: must be n x 3");
    return ball_metrics_dict(ball_metrics(M, f)).dump();
  });
}

void bind_prepare(py::module_& m) {
  py::class_<PreparedSurface, std::shared_ptr<PreparedSurface>>(m, "PreparedSurface")
      .def_property_readonly("num_vertices", [](const PreparedSurface& p) { return p.repair.mesh.num_vertices(); })
      .def_property_readonly("notes", [](const PreparedSurface& p) { return p.repair.notes; })
      // BIM's feature points: with the other surface's, they fix the number of candidate
      // maps, and so the cost of a pair (batch runs the costliest pairs first).
      .def_property_readonly("num_features",
                             [](const PreparedSurface& p) { return p.bim ? int(p.bim->features.size()) : 0; })
      // Picklable, so one preparation serves pairs on every Dask worker (batch).
      // Both directions without the GIL (0.08 s each for 1500 vertices, under load): worker
      // threads of a batch pickle their shapes for its cache while the others run.
      .def(py::pickle([](const PreparedSurface& p) {
                        std::string s;
                        {
                          py::gil_scoped_release nogil;
                          s = save_prepared_surface(p);
                        }
                        return py::bytes(s);
                      },
                      [](const py::bytes& b) {
                        const std::string s = b;
                        py::gil_scoped_release nogil;
                        return load_prepared_surface(s);
                      }));
  m.def("prepare_surface", [](const RowMatrixXd& V, const RowMatrixXi& F, const std::string& name, std::uint64_t seed,
                              int features, int samples, bool strict, int threads, py::object progress) {
    set_threads(threads);
    BIMOptions o;
    o.seed = seed;
    o.max_features = features;
    o.num_even = samples;
    const TriMesh mesh = tri_mesh(V, F, name.c_str());
    PyProgress p{progress};
    return without_gil(p, [&](const ProgressCallback& cb) { return prepare_surface(mesh, name, o, strict, cb); });
  });
}

}  // namespace

PYBIND11_MODULE(_shapemap, m) {
  m.doc() = "shapemap's compiled core; use the package `shapemap`";
  m.attr("__version__") = SHAPEMAP_VERSION;
  py::register_exception<InputError>(m, "InputError", PyExc_ValueError);
  py::register_exception<Error>(m, "Error", PyExc_RuntimeError);
  bind_io(m);
  bind_evaluate(m);
  bind_prepare(m);
  m.def("surface_map", &surface_map);
  m.def("volume_map", &volume_map);
  m.def("ball", &ball);
  m.def("register", &register_volumes);
  m.def("volume_defaults", [] {
    const SymmetricVolumeMapOptions o;
    py::dict d;
    d["alpha"] = o.alpha;
    d["alpha_final"] = o.alpha_final;
    d["gamma"] = o.gamma;
    d["beta_start"] = o.beta_start;
    d["beta_end"] = o.beta_end;
    d["max_iterations"] = o.max_iterations;
    return d;
  });
}
