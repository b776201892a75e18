// Binary format: a magic word and version, then the fields in a fixed order; matrices as
// rows, cols and the raw column-major doubles or ints (bit-exact, same machine class:
// little-endian, 64-bit doubles, as every worker of one batch).
#include "shapemap/surface/prepared_surface_io.h"
#include "shapemap/error.h"
#include <cstdint>
#include <cstring>
#include <type_traits>

namespace shapemap {
namespace {

constexpr char kMagic[8] = {'S', 'M', 'P', 'R', 'E', 'P', '0', '3'};

struct Writer {
  std::string out;
  template <class T>
  void pod(const T& v) {
    static_assert(std::is_trivially_copyable<T>::value, "raw bytes only");
    out.append(reinterpret_cast<const char*>(&v), sizeof(T));
  }
  template <class T>
  void field(const T& v) { pod(v); }
  template <class T>
  void raw(const T* p, std::size_t n) { out.append(reinterpret_cast<const char*>(p), n * sizeof(T)); }
  template <class M>
  void mat(const M& m) {
    pod<std::int64_t>(m.rows());
    pod<std::int64_t>(m.cols());
    raw(m.data(), std::size_t(m.size()));
  }
  template <class T>
  void vec(const std::vector<T>& v) {
    pod<std::int64_t>(std::int64_t(v.size()));
    raw(v.data(), v.size());
  }
  void str(const std::string& s) {
    pod<std::int64_t>(std::int64_t(s.size()));
    out.append(s);
  }
  void sparse(const Eigen::SparseMatrix<double, Eigen::RowMajor>& m) {
    if (!m.isCompressed()) throw Error("prepared surface: interpolation matrix not compressed");
    pod<std::int64_t>(m.rows());
    pod<std::int64_t>(m.cols());
    pod<std::int64_t>(m.nonZeros());
    raw(m.outerIndexPtr(), std::size_t(m.outerSize()) + 1);
    raw(m.innerIndexPtr(), std::size_t(m.nonZeros()));
    raw(m.valuePtr(), std::size_t(m.nonZeros()));
  }
};

struct Reader {
  const std::string& in;
  std::size_t at = 0;
  void need(std::size_t n) {
    if (n > in.size() - at) throw Error("prepared surface: truncated data");
  }
  template <class T>
  T pod() {
    need(sizeof(T));
    T v;
    std::memcpy(&v, in.data() + at, sizeof(T));
    at += sizeof(T);
    return v;
  }
  template <class T>
  void raw(T* p, std::size_t n) {
    if (n > (in.size() - at) / sizeof(T)) throw Error("prepared surface: truncated data");
    std::memcpy(p, in.data() + at, n * sizeof(T));
    at += n * sizeof(T);
  }
  template <class T>
  void field(T& v) { v = pod<T>(); }
  void sparse(Eigen::SparseMatrix<double, Eigen::RowMajor>& m) {
    const auto rows = count(), cols = count(), nnz = count();
    if (std::size_t(rows) > in.size() || std::size_t(nnz) > in.size()) throw Error("prepared surface: bad size");
    m.resize(Eigen::Index(rows), Eigen::Index(cols));
    m.resizeNonZeros(Eigen::Index(nnz));
    raw(m.outerIndexPtr(), std::size_t(rows) + 1);
    raw(m.innerIndexPtr(), std::size_t(nnz));
    raw(m.valuePtr(), std::size_t(nnz));
  }

  std::int64_t count() {
    const auto n = pod<std::int64_t>();
    if (n < 0) throw Error("prepared surface: bad size");
    return n;
  }
  template <class M>
  void mat(M& m) {
    const auto r = count(), c = count();
    if (c > 0 && r > std::int64_t(in.size()) / c) throw Error("prepared surface: bad size");
    m.resize(r, c);
    raw(m.data(), std::size_t(m.size()));
  }
  template <class T>
  void vec(std::vector<T>& v) {
    const auto n = count();
    if (std::size_t(n) > in.size()) throw Error("prepared surface: bad size");
    v.resize(std::size_t(n));
    raw(v.data(), v.size());
  }
  std::string str() {
    const auto n = count();
    need(std::size_t(n));
    std::string s = in.substr(at, std::size_t(n));
    at += std::size_t(n);
    return s;
  }
};

void save_map(Writer& w, const BarycentricMap& m) {
  w.mat(m.elem);
  w.mat(m.bary);
}

void load_map(Reader& r, BarycentricMap& m) {
  r.mat(m.elem);
  r.mat(m.bary);
}

// Every BIMOptions field that is a number (landmarks are never part of a prepared surface).
template <class IO, class O>
void options_fields(IO&& io, O& o) {
  io(o.max_features, o.min_features, o.feature_radius, o.max_candidates, o.num_even, o.interpolation_sigma,
     o.candidate_pool, o.sigma, o.eigenvalue_fraction, o.entry_fraction, o.num_eigenvectors, o.max_groups,
     o.symmetrize_consistency, o.consistency_skip, o.implied_radius, o.matching_search_sweeps,
     o.matching_search_min_gain, o.matching_search_max_work, o.symmetric, o.reverse_candidates, o.seed,
     o.heat_t_factor, o.min_vertices);
}

// The arrays in their order on disk, one function for saving (Ar = Writer, const data) and
// loading (Ar = Reader).
template <class Ar, class... M>
void matrices(Ar& a, M&... m) {
  (a.mat(m), ...);
}

template <class Ar, class Repair>
void repair_arrays(Ar& a, Repair& r) {
  matrices(a, r.mesh.V, r.mesh.F, r.vertex_from, r.face_from, r.input_vertex);
}

template <class Ar, class Surface>
void bim_arrays(Ar& a, Surface& s) {
  matrices(a, s.mesh.V, s.mesh.F, s.V_input, s.F_input);
  a.raw(s.normalization.center.data(), 3);
  a.field(s.normalization.scale);
  a.mat(s.mass);
  a.vec(s.even);
  a.vec(s.even_chain);
  a.mat(s.even_dist);
  a.sparse(s.interp);
  a.mat(s.agd);
  a.vec(s.features);
  a.mat(s.feature_dist);
  a.mat(s.flat.plane);
  a.mat(s.flat.sphere);
  a.mat(s.flat.area_factor);
  a.field(s.flat.pole_face);
  a.field(s.flat.centroid_norm);
  a.field(s.flat.flipped_faces);
  a.vec(s.hom);
  a.vec(s.bfs_order);
  a.vec(s.bfs_parent);
}

}  // namespace

std::string save_prepared_surface(const PreparedSurface& p) {
  if (!p.bim) throw Error("prepared surface: no BIM stage to save");
  Writer w;
  w.raw(kMagic, sizeof kMagic);
  // repair
  const SurfaceRepair& r = p.repair;
  repair_arrays(w, r);
  save_map(w, r.input_on_repaired);
  w.pod<std::int64_t>(std::int64_t(r.notes.size()));
  for (const auto& s : r.notes) w.str(s);
  // options
  options_fields([&](auto&... f) { (w.pod(f), ...); }, p.options);
  w.str(p.options.name_A);
  w.str(p.options.name_B);
  // BIM's per-surface stage
  const BIMSurface& s = *p.bim;
  bim_arrays(w, s);
  w.pod<std::int64_t>(std::int64_t(s.timings.size()));
  for (const auto& t : s.timings) {
    w.str(t.first);
    w.pod(t.second);
  }
  return std::move(w.out);
}

std::shared_ptr<PreparedSurface> load_prepared_surface(const std::string& bytes) {
  Reader rd{bytes};
  char magic[sizeof kMagic];
  rd.raw(magic, sizeof magic);
  if (std::memcmp(magic, kMagic, sizeof kMagic) != 0)
    throw Error("prepared surface: not a saved prepared surface (or another format version)");
  auto p = std::make_shared<PreparedSurface>();
  SurfaceRepair& r = p->repair;
  repair_arrays(rd, r);
  load_map(rd, r.input_on_repaired);
  r.notes.resize(std::size_t(rd.count()));
  for (auto& s : r.notes) s = rd.str();
  options_fields([&](auto&... f) { ((f = rd.pod<std::decay_t<decltype(f)>>()), ...); }, p->options);
  p->options.name_A = rd.str();
  p->options.name_B = rd.str();
  auto s = std::make_shared<BIMSurface>();
  bim_arrays(rd, *s);
  s->timings.resize(std::size_t(rd.count()));
  for (auto& t : s->timings) {
    t.first = rd.str();
    t.second = rd.pod<double>();
  }
  if (rd.at != bytes.size()) throw Error("prepared surface: trailing data");
  // Rebuilt as bim_prepare builds them (deterministic functions of the arrays above).
  s->locator = std::make_shared<SphereLocator>(s->flat.sphere, s->mesh.F);
  s->closest = std::make_shared<ClosestPoint3>(s->mesh.V, s->mesh.F);
  p->bim = std::move(s);
  return p;
}

}  // namespace shapemap
