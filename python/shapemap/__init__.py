"""shapemap: dense correspondences between shapes, from Python.

numpy in, numpy out (float64 positions, integer indices); options are keyword arguments
with the command line's names (``--elastic-eta`` -> ``elastic_eta``) and defaults. Long
calls release the GIL, report progress to ``progress(stage, fraction)`` when given, and
stop on Ctrl-C with KeyboardInterrupt. Bad input raises ValueError (shapemap.InputError)
with the library's one-line message.

    import shapemap
    VA, FA = shapemap.read_surface("A.obj")
    VB, FB = shapemap.read_surface("B.obj")
    m = shapemap.surface_map(VA, FA, VB, FB, method="bim")
    m.points()        # positions of A's vertices on B
    m.to_sparse()     # scipy CSR: m.to_sparse() @ VB == m.points()
"""
import json

import numpy as np

from . import _shapemap
from ._version import __version__

InputError = _shapemap.InputError
Error = _shapemap.Error

__all__ = ["Map", "read_surface", "read_volume", "write_surface", "write_volume", "read_map", "write_map", "tetrahedralize",
           "prepare_surface", "surface_map", "volume_map", "ball", "register", "evaluate_surface", "evaluate_volume",
           "evaluate_ball", "InputError", "Error", "__version__"]


class Map:
    """A dense map: source vertex i goes to ``bary[i] @ target_V[target_elements[element[i]]]``.

    element: (n,) int, index of a target triangle (bary n x 3) or tet (bary n x 4).
    target_V, target_elements: the target mesh (needed by points(), to_sparse(), to_vertex_map()).
    reverse: the map of the other direction (symmetric methods), else None.
    report: the dict that report.json holds.
    """

    def __init__(self, element, bary, target_V=None, target_elements=None, reverse=None, report=None):
        self.element = np.asarray(element, dtype=np.int64)
        self.bary = np.asarray(bary, dtype=np.float64)
        self.target_V = None if target_V is None else np.asarray(target_V, dtype=np.float64)
        self.target_elements = None if target_elements is None else np.asarray(target_elements, dtype=np.int64)
        self.reverse = reverse
        self.report = report if report is not None else {}

    def __len__(self):
        return len(self.element)

    def __repr__(self):
        kind = "triangles" if self.bary.shape[1] == 3 else "tets"
        return f"<shapemap.Map {len(self)} vertices -> {kind}{', symmetric' if self.reverse else ''}>"

    def _target(self):
        if self.target_V is None or self.target_elements is None:
            raise ValueError("this map has no target mesh: set target_V and target_elements")
        return self.target_V, self.target_elements

    def corners(self):
        """(n, 3 or 4) target vertex indices of each source vertex's element."""
        return self._target()[1][self.element]

    def points(self):
        """(n, 3) mapped positions on the target."""
        V, _ = self._target()
        return np.einsum("ij,ijk->ik", self.bary, V[self.corners()])

    def to_sparse(self):
        """scipy.sparse CSR (n_source x n_target_vertices): to_sparse() @ target_V == points()."""
        import scipy.sparse
        V, _ = self._target()
        n, k = self.bary.shape
        rows = np.repeat(np.arange(n), k)
        return scipy.sparse.csr_matrix((self.bary.ravel(), (rows, self.corners().ravel())), shape=(n, len(V)))

    def to_vertex_map(self):
        """(n,) nearest target vertex of each mapped point (pyFM's p2p convention)."""
        from scipy.spatial import cKDTree
        V, _ = self._target()
        return cKDTree(V).query(self.points())[1].astype(np.int64)

    def _raw(self):
        return (np.ascontiguousarray(self.element, dtype=np.int32), np.ascontiguousarray(self.bary))


def _raw(m):
    if m is None:
        return None
    if isinstance(m, Map):
        return m._raw()
    e, b = m
    return (np.ascontiguousarray(e, dtype=np.int32), np.ascontiguousarray(b, dtype=np.float64))


def _v(V):
    return np.ascontiguousarray(V, dtype=np.float64)


def _e(E):
    return np.ascontiguousarray(E, dtype=np.int32)


def read_surface(path):
    """(V n x 3 float64, F m x 3 int) of an .obj .off .ply .stl file."""
    return _shapemap.read_surface(str(path))


def read_volume(path):
    """(V n x 3 float64, T m x 4 int) of a .vtk .mesh .msh .node/.ele file."""
    return _shapemap.read_volume(str(path))


def write_surface(path, V, F):
    """Writes a triangle mesh (.obj .off .ply .stl by the extension)."""
    _shapemap.write_surface(str(path), _v(V), _e(F))


def write_volume(path, V, T):
    """Writes a tet mesh (.vtk .mesh .msh by the extension)."""
    _shapemap.write_volume(str(path), _v(V), _e(T))


def read_map(path, target_V=None, target_elements=None):
    """A Map from a map file (docs/formats.md)."""
    e, b = _shapemap.read_map(str(path))
    return Map(e, b, target_V, target_elements)


def write_map(path, m):
    """Writes a Map (or an (element, bary) pair) as a map file."""
    e, b = _raw(m)
    _shapemap.write_map(str(path), e, b)


def tetrahedralize(V, F, tets=0, seed=1, strict=False, progress=None):
    """(V, T) of a closed genus-0 surface, about `tets` tets (0: the default, ~30k)."""
    return _shapemap.tetrahedralize(_v(V), _e(F), int(tets), int(seed), bool(strict), progress)


def _pair(a, b, target_A, target_B, report):
    reverse = Map(b[0], b[1], target_A[0], target_A[1], report=report) if b is not None else None
    m = Map(a[0], a[1], target_B[0], target_B[1], reverse=reverse, report=report)
    if reverse is not None:
        reverse.reverse = m
    return m


def prepare_surface(V, F, seed=1, features=10, samples=256, strict=False, name="A", threads=0, progress=None):
    """A surface repaired, checked and prepared for BIM once (geodesics, sampling, features,
    flattening), for many surface_map(..., prepared=(pA, pB)) calls without landmarks.
    The options must be those of the surface_map calls (else it is not used).
    threads: OpenMP threads of this call (0: OMP_NUM_THREADS, else all cores)."""
    return _shapemap.prepare_surface(_v(V), _e(F), str(name), int(seed), int(features), int(samples),
                                     bool(strict), int(threads), progress)


def surface_map(VA, FA, VB, FB, method="bim", landmarks=None, init=None, init_reverse=None, symmetric=False,
                seed=1, threads=0, features=10, candidates=10000, samples=256, reverse_candidates=True,
                matching_search=8, landmark_features=True, blend_features=12, blend_triples=1, blend_guide_maps=32,
                truth=None, strict=False, elastic_preset="auto", elastic_eta=-1.0, elastic_alpha=20.0,
                elastic_iterations=300, elastic_injective=False, elastic_partial=False,
                elastic_keep_worse=False, elastic_untangle=True, elastic_wide_untangle=True,
                elastic_sliver_untangle=True, elastic_bridge_untangle=True, elastic_search_untangle=True,
                elastic_untangle_passes=3, elastic_feature_anchors=True, elastic_plain_projection=False,
                elastic_plain_projection_in_ramp=False, elastic_guard_before_untangling=False,
                elastic_anchors_hold_to_end=False, elastic_anchor_weight=-1.0, elastic_anchor_tolerance=-1.0,
                elastic_collapsed_parts=True, names=("A", "B"),
                prepared=None, progress=None):
    """Map between two closed genus-0 surfaces (`shapemap surface-map`).

    method: "bim" (Blended Intrinsic Maps) or "elastic" (refinement of BIM, of landmarks, or
    of `init`). landmarks: (LA, LB) vertex index lists; names: A's and B's in error
    messages. Returns a Map A -> B (with .reverse B -> A for symmetric=True and for the
    elastic bijective model). prepared: (prepare_surface(A), prepare_surface(B)), for BIM
    (and elastic's BIM initial maps) without landmarks: the per-surface stage is not done
    again (the same map). elastic_untangle=False: `--elastic-no-untangle` (the refined maps
    without the final untangling stages); elastic_wide_untangle=False:
    `--elastic-no-wide-untangle` (without the untangling's second pass over wide regions);
    elastic_sliver_untangle=False: `--elastic-no-sliver-untangle` (slivers left as they are);
    elastic_bridge_untangle=False: `--elastic-no-bridge-untangle` (corners mapped across a thin
    part not re-seated); elastic_search_untangle=False: `--elastic-no-search-untangle` (the folds
    the other stages leave are left);
    elastic_untangle_passes: `--elastic-untangle-passes` (the stages repeated while folds fall);
    elastic_collapsed_parts=False: `--elastic-no-collapsed-parts` (the initial maps' collapsed parts
    left collapsed); elastic_feature_anchors=False: `--elastic-no-feature-anchors`; elastic_anchors_hold_to_end,
    elastic_anchor_weight, elastic_anchor_tolerance: `--elastic-anchors-hold-to-end`,
    `--elastic-anchor-weight`, `--elastic-anchor-tolerance` (-1: the default). The projection
    (Sec. 5.1): elastic_plain_projection=True is `--elastic-plain-projection` (the plain P/Q steps
    throughout), elastic_plain_projection_in_ramp=True `--elastic-plain-projection-in-ramp` (while
    beta ramps up); elastic_guard_before_untangling=True: `--elastic-guard-before-untangling` (the
    collapse guard judges the iterates as the refinement leaves them). matching_search: BIM's
    `--matching-search` (at most this many changes of the selected group's feature matching;
    0: Sec. 6.2's groups alone; report["bim"][dir]["matching_search"]). landmark_features=False:
    `--no-landmark-features` (with landmarks, BIM over their triples alone instead of its own
    feature points' maps that agree with them). blend_features: `--blend-features` (when no two
    of BIM's candidate maps can be blended, a second run with spread samples up to this many
    features a side, guided by a single map's triple; 0: off; report["bim"]["blend_retry"]);
    blend_triples: `--blend-triples` (that run once for each of the most confident single maps);
    blend_guide_maps: `--blend-guide-maps` (when no such run is more confident than the single map,
    one more guided by the least stretched of this many candidate maps on the spread samples; 0: off;
    report["bim"]["blend_retry"]["stretch_guide"]).
    """
    if method not in ("bim", "elastic"):
        raise ValueError(f"method {method!r}: expected 'bim' or 'elastic'")
    if landmarks is not None:
        landmarks = ([int(i) for i in landmarks[0]], [int(i) for i in landmarks[1]])
    opts = dict(method=method, symmetric=bool(symmetric), strict=bool(strict), seed=int(seed),
                features=int(features), candidates=int(candidates), samples=int(samples),
                reverse_candidates=bool(reverse_candidates), matching_search=int(matching_search),
                landmark_features=bool(landmark_features), blend_features=int(blend_features), blend_triples=int(blend_triples),
                blend_guide_maps=int(blend_guide_maps), landmarks=landmarks, init=_raw(init),
                init_reverse=_raw(init_reverse), truth=_raw(truth), elastic_preset=elastic_preset,
                elastic_eta=float(elastic_eta), elastic_alpha=float(elastic_alpha),
                elastic_iterations=int(elastic_iterations), elastic_injective=bool(elastic_injective),
                elastic_partial=bool(elastic_partial), elastic_keep_worse=bool(elastic_keep_worse),
                elastic_untangle=bool(elastic_untangle), elastic_wide_untangle=bool(elastic_wide_untangle),
                elastic_sliver_untangle=bool(elastic_sliver_untangle),
                elastic_bridge_untangle=bool(elastic_bridge_untangle),
                elastic_search_untangle=bool(elastic_search_untangle),
                elastic_untangle_passes=int(elastic_untangle_passes),
                elastic_feature_anchors=bool(elastic_feature_anchors),
                elastic_collapsed_parts=bool(elastic_collapsed_parts),
                elastic_plain_projection=bool(elastic_plain_projection),
                elastic_plain_projection_in_ramp=bool(elastic_plain_projection_in_ramp),
                elastic_guard_before_untangling=bool(elastic_guard_before_untangling),
                elastic_anchors_hold_to_end=bool(elastic_anchors_hold_to_end),
                elastic_anchor_weight=float(elastic_anchor_weight),
                elastic_anchor_tolerance=float(elastic_anchor_tolerance),
                threads=int(threads),
                names=(str(names[0]), str(names[1])), prepared=None if prepared is None else tuple(prepared))
    VA, FA, VB, FB = _v(VA), _e(FA), _v(VB), _e(FB)
    r = _shapemap.surface_map(VA, FA, VB, FB, opts, progress)
    return _pair(r["AB"], r["BA"], (VA, FA), (VB, FB), json.loads(r["report"]))


def volume_map(VA, TA, VB, TB, init=None, landmarks=None, surface_map=None, tets=0, auto_surface_map="elastic",
               reverse_candidates=True, alpha=None, alpha_final=None, gamma=None, beta_start=None, beta_end=None,
               max_iterations=None, solver="newton",
               boundary_fixed_stage="auto", interior_init="closest", land_on_target=True, seed=1, threads=0, strict=False, names=("A", "B"),
               progress=None):
    """Symmetric volume map (`shapemap volume-map`) between two tet meshes (T: m x 4), or two
    closed surfaces (m x 3: tetrahedralized first, about `tets` tets).

    init: "auto" (surface map by BIM + elastic; guided by landmarks when given), "landmarks"
    ((LA, LB) vertex lists; of the surfaces for surface inputs), "ball" (registration through
    ball maps) or "surface-map" (surface_map=(map_AB, map_BA) between the boundary or input
    surfaces); None (the default, as `volume-map` without --init): "landmarks" when landmarks
    are given ("auto" guided by them when fewer than 20 distinct pairs, too few for a good
    landmark start; a note says so), "surface-map" when surface_map is, else "auto". interior_init:
    "closest" (Sec. 5.1) or "harmonic" (the boundary's images extended harmonically).
    reverse_candidates (init "auto" without landmarks): the less confident BIM direction takes the
    inverse of the other's blend, as surface_map does (False: each direction's own blend). alpha_final
    (`--alpha-final`): the alpha of a second stage 4 run from the map found at alpha (negative: none).
    Returns a Map
    A -> B with .reverse; .mesh_A / .mesh_B are the tet meshes the maps index, .X the
    optimized positions.
    """
    d = _volume_defaults()
    opts = dict(init=init, auto_surface_map=auto_surface_map, reverse_candidates=bool(reverse_candidates),
                boundary_fixed_stage=boundary_fixed_stage,
                interior_init=interior_init,
                strict=bool(strict), tets=int(tets), seed=int(seed), threads=int(threads), solver=solver,
                names=(str(names[0]), str(names[1])),
                land_on_target=bool(land_on_target),
                alpha=d["alpha"] if alpha is None else float(alpha),
                alpha_final=d["alpha_final"] if alpha_final is None else float(alpha_final),
                gamma=d["gamma"] if gamma is None else float(gamma),
                beta_start=d["beta_start"] if beta_start is None else float(beta_start),
                beta_end=d["beta_end"] if beta_end is None else float(beta_end),
                max_iterations=d["max_iterations"] if max_iterations is None else int(max_iterations),
                landmarks=None if landmarks is None else ([int(i) for i in landmarks[0]], [int(i) for i in landmarks[1]]),
                surface_map=None if surface_map is None else (_raw(surface_map[0]), _raw(surface_map[1])))
    r = _shapemap.volume_map(_v(VA), _e(TA), _v(VB), _e(TB), opts, progress)
    m = _pair(r["AB"], r["BA"], (r["VA"], r["TA"]), (r["VB"], r["TB"]), json.loads(r["report"]))
    m.mesh_A, m.mesh_B = (r["VA"], r["TA"]), (r["VB"], r["TB"])
    m.X, m.reverse.X = r["X_AB"], r["X_BA"]
    return m


def _volume_defaults():
    # SymmetricVolumeMapOptions' defaults (the CLI's), read once from the library.
    return _shapemap.volume_defaults()


def ball(V, T, threads=0, progress=None):
    """Isovolumetric ball map of a tet mesh (`shapemap ball`): (f n x 3, report dict)."""
    f, rep = _shapemap.ball(_v(V), _e(T), int(threads), progress)
    return f, json.loads(rep)


def register(VA, TA, VB, TB, threads=0, progress=None):
    """Volume-preserving registration through the ball (`shapemap register`): Map A -> B with .reverse."""
    VA, TA, VB, TB = _v(VA), _e(TA), _v(VB), _e(TB)
    r = _shapemap.register(VA, TA, VB, TB, int(threads), progress)
    return _pair(r["AB"], r["BA"], (VA, TA), (VB, TB), json.loads(r["report"]))


def evaluate_surface(VA, FA, VB, FB, m, reverse=None, truth=None):
    """Surface-map metrics (elastic-correspondence Sec. 6.1) as a dict; geodesic error with truth."""
    if reverse is None and isinstance(m, Map) and m.reverse is not None:
        reverse = m.reverse
    return json.loads(_shapemap.evaluate_surface(_v(VA), _e(FA), _v(VB), _e(FB), _raw(m), _raw(reverse), _raw(truth)))


def evaluate_volume(VA, TA, VB, TB, m, reverse=None):
    """Volume-map metrics (symmetric-volume-maps Table 3) as a dict."""
    if reverse is None and isinstance(m, Map) and m.reverse is not None:
        reverse = m.reverse
    return json.loads(_shapemap.evaluate_volume(_v(VA), _e(TA), _v(VB), _e(TB), _raw(m), _raw(reverse)))


def evaluate_ball(V, T, f):
    """Ball-map metrics (isovolumetric paper, Tables 1-2) as a dict."""
    return json.loads(_shapemap.evaluate_ball(_v(V), _e(T), _v(f)))
