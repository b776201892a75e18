# The Python API on a small generated pair: maps, Map methods against brute force, metrics,
# errors, and the same map from the CLI and the module.
import json
import os

import numpy as np
import pytest

import shapemap


@pytest.fixture(scope="module")
def surfaces(pair):
    return shapemap.read_surface(pair / "A.obj"), shapemap.read_surface(pair / "B.obj")


# BIM with 128 samples and 1000 candidates instead of the defaults (256, 10000): the tests
# below compare maps, the CLI with the module and the API's outputs, which do not depend on
# the counts, and the defaults' consistency matrix is most of the time. Measured on this pair
# (shapemap surface-map --truth): geodesic error mean 0.020 (defaults: 0.016; 64 samples with
# 200 candidates: 0.72), CPU 1.3 s instead of 4.7 s.
FAST_BIM = dict(samples=128, candidates=1000)
FAST_BIM_CLI = ("--samples", 128, "--candidates", 1000)


@pytest.fixture(scope="module")
def bim(surfaces):
    (VA, FA), (VB, FB) = surfaces
    return shapemap.surface_map(VA, FA, VB, FB, method="bim", symmetric=True, seed=1, **FAST_BIM)


def test_read(surfaces, pair):
    (VA, FA), _ = surfaces
    assert VA.dtype == np.float64 and VA.shape[1] == 3 and FA.shape[1] == 3
    V, T = shapemap.read_volume(pair / "A.vtk")
    assert T.shape[1] == 4 and T.max() < len(V)
    m = shapemap.read_map(pair / "truth_AB.txt")
    assert len(m) == len(VA) and m.bary.shape == (len(VA), 3)


def test_surface_map_bim(bim, surfaces, pair):
    (VA, FA), (VB, FB) = surfaces
    assert len(bim) == len(VA) and bim.reverse is not None and len(bim.reverse) == len(VB)
    assert bim.reverse.reverse is bim
    assert np.allclose(bim.bary.sum(axis=1), 1)
    assert bim.report["method"] == "bim" and "AB" in bim.report["bim"]
    truth = shapemap.read_map(pair / "truth_AB.txt")
    ev = shapemap.evaluate_surface(VA, FA, VB, FB, bim, truth=truth)
    assert ev["geodesic_within_0_1"] > 0.5
    assert "reversibility" in ev
    # BIM's matching search (docs/methods.md): on by default, never worse than the groups' best
    for d in ("AB", "BA"):
        ms = bim.report["bim"][d]["matching_search"]
        assert ms["evaluations"] > 0 and not ms["over_budget"]
        assert bim.report["bim"][d].get("own_integrated_confidence",
                                        bim.report["bim"][d]["integrated_confidence"]) >= \
            max(bim.report["bim"][d]["group_integrated_confidence"]) - 1e-12
    off = shapemap.surface_map(VA, FA, VB, FB, method="bim", symmetric=True, seed=1, matching_search=0, **FAST_BIM)
    assert "matching_search" not in off.report["bim"]["AB"]
    assert off.report["parameters"]["matching_search"] == 0


def test_points_sparse_vertex_map(bim, surfaces):
    (VA, FA), (VB, FB) = surfaces
    P = bim.points()
    brute = np.array([sum(bim.bary[i, j] * VB[FB[bim.element[i], j]] for j in range(3)) for i in range(len(VA))])
    assert np.allclose(P, brute)
    S = bim.to_sparse()
    assert S.shape == (len(VA), len(VB)) and S.format == "csr"
    assert np.allclose(S @ VB, P)
    vm = bim.to_vertex_map()
    d = ((P[:, None, :] - VB[None, :, :]) ** 2).sum(axis=2)
    assert np.allclose(d[np.arange(len(VA)), vm], d.min(axis=1))


def test_write_read_map_roundtrip(bim, tmp_path):
    shapemap.write_map(tmp_path / "m.txt", bim)
    back = shapemap.read_map(tmp_path / "m.txt")
    assert np.array_equal(back.element, bim.element) and np.allclose(back.bary, bim.bary, atol=1e-12)


def test_cli_and_module_same_map(cli, pair, bim, tmp_path):
    cli("--seed", 1, "surface-map", pair / "A.obj", pair / "B.obj", "--symmetric", *FAST_BIM_CLI,
        "-o", tmp_path / "out")
    shapemap.write_map(tmp_path / "py_AB.txt", bim)
    shapemap.write_map(tmp_path / "py_BA.txt", bim.reverse)
    for d in ("AB", "BA"):
        assert (tmp_path / "out" / f"map_{d}.txt").read_text() == (tmp_path / f"py_{d}.txt").read_text(), d
    rep = json.loads((tmp_path / "out" / "report.json").read_text())
    assert rep["metrics"]["AB"] == pytest.approx(bim.report["metrics"]["AB"])


def test_bad_input_raises_one_line(surfaces, tmp_path):
    (VA, FA), (VB, FB) = surfaces
    bad = FA.copy()
    bad[0, 0] = len(VA) + 5
    with pytest.raises(ValueError) as e:
        shapemap.surface_map(VA, bad, VB, FB)
    assert "\n" not in str(e.value) and str(e.value)
    with pytest.raises(ValueError, match="no-such.obj"):
        shapemap.read_surface(tmp_path / "no-such.obj")
    with pytest.raises(ValueError):
        shapemap.surface_map(VA, FA, VB, FB, method="nope")
    # A hole: repaired by default (a note in the report), refused with strict=True.
    with pytest.raises(ValueError, match="^A: .*strict"):
        shapemap.surface_map(VA, FA[:-10], VB, FB, strict=True)


def test_progress_callback(surfaces):
    (VA, FA), (VB, FB) = surfaces
    stages = []
    shapemap.surface_map(VA, FA, VB, FB, samples=64, candidates=200,
                         progress=lambda s, f: stages.append((s, f)))
    assert stages and all(0 <= f <= 1 for _, f in stages)


def test_volume_map_and_evaluate(surfaces):
    # Surfaces in (3 columns): tetrahedralized first, as `shapemap volume-map A.obj B.obj`.
    (VA, FA), (VB, FB) = surfaces
    m = shapemap.volume_map(VA, FA, VB, FB, tets=1000, auto_surface_map="bim", max_iterations=3)
    (WA, TA), (WB, TB) = m.mesh_A, m.mesh_B
    assert TA.shape[1] == 4 and len(m) == len(WA) and m.bary.shape[1] == 4 and len(m.reverse) == len(WB)
    assert np.allclose(m.to_sparse() @ WB, m.points())
    ev = shapemap.evaluate_volume(WA, TA, WB, TB, m)
    assert ev["num_tets"] == len(TA) and "n_inv" in ev
    assert m.report["metrics"]["AB"]["n_inv"] == m.report["metrics"]["AB"]["n_inv"]
    assert m.report["inputs"]["A_tetrahedralized"]
    # The automatic start's BIM directions (volume-map --no-reverse-candidates).
    assert "(reverse candidates)" in m.report["parameters"]["init"]
    own = shapemap.volume_map(VA, FA, VB, FB, tets=1000, auto_surface_map="bim", max_iterations=1,
                              reverse_candidates=False)
    assert "BIM" in own.report["parameters"]["init"] and "reverse" not in own.report["parameters"]["init"]


def test_ball_and_register(pair):
    V, T = shapemap.read_volume(pair / "A.vtk")
    f, rep = shapemap.ball(V, T)
    assert f.shape == V.shape and np.linalg.norm(f, axis=1).max() < 1.01
    ev = shapemap.evaluate_ball(V, T, f)
    assert ev["num_tets"] == len(T) and ev == pytest.approx(rep["metrics"])


def test_tetrahedralize(surfaces):
    (VA, FA), _ = surfaces
    V, T = shapemap.tetrahedralize(VA, FA, tets=800)
    assert T.shape[1] == 4 and 200 < len(T) < 4000


def _boundary_vertices(T):
    faces = np.sort(np.concatenate([T[:, [0, 1, 2]], T[:, [0, 1, 3]], T[:, [0, 2, 3]], T[:, [1, 2, 3]]]), axis=1)
    u, c = np.unique(faces, axis=0, return_counts=True)
    return np.unique(u[c == 1])


def _pair_landmarks(pair, n):
    """n boundary vertices of A and the boundary vertices of B nearest their true images."""
    VA, TA = shapemap.read_volume(pair / "A.vtk")
    VB, TB = shapemap.read_volume(pair / "B.vtk")
    bA, bB = _boundary_vertices(TA), _boundary_vertices(TB)
    LA = bA[:: len(bA) // n][:n]
    P = shapemap.read_map(pair / "truth_vol_AB.txt", VB, TB).points()[LA]
    LB = bB[((P[:, None, :] - VB[bB][None, :, :]) ** 2).sum(axis=2).argmin(axis=1)]
    return (VA, TA), (VB, TB), LA, LB


@pytest.mark.parametrize("alpha_final", [None, -1.0])
def test_cli_and_module_same_volume_map(cli, pair, tmp_path, alpha_final):
    (VA, TA), (VB, TB), LA, LB = _pair_landmarks(pair, 20)
    np.savetxt(tmp_path / "LA.txt", LA, fmt="%d")
    np.savetxt(tmp_path / "LB.txt", LB, fmt="%d")
    extra = () if alpha_final is None else ("--alpha-final", alpha_final)
    cli("--seed", 1, "volume-map", pair / "A.vtk", pair / "B.vtk", "--landmarks", tmp_path / "LA.txt",
        tmp_path / "LB.txt", "--max-iterations", 3, *extra, "-o", tmp_path / "out")
    # The same default initialization: landmarks when given (20 distinct pairs, enough for it).
    m = shapemap.volume_map(VA, TA, VB, TB, landmarks=(LA, LB), max_iterations=3, seed=1, alpha_final=alpha_final)
    assert m.report["parameters"]["init"].startswith("landmarks"), m.report["parameters"]["init"]
    stages = [s["name"] for s in m.report["algorithm_stages"]]
    assert ("full-reversible" in stages) == (alpha_final is None), stages
    shapemap.write_map(tmp_path / "py_AB.txt", m)
    shapemap.write_map(tmp_path / "py_BA.txt", m.reverse)
    for d in ("AB", "BA"):
        assert (tmp_path / "out" / f"map_{d}.txt").read_text() == (tmp_path / f"py_{d}.txt").read_text(), d


def test_few_landmarks_guide_the_automatic_start_by_default(pair):
    """As volume-map without --init: with fewer than 20 distinct landmark pairs the landmark
    initialization is too coarse a start, so they guide the automatic one, and a note says so."""
    (VA, TA), (VB, TB), LA, LB = _pair_landmarks(pair, 3)
    m = shapemap.volume_map(VA, TA, VB, TB, landmarks=(LA, LB), auto_surface_map="bim", max_iterations=1)
    assert m.report["parameters"]["init"].startswith("auto (BIM guided by landmarks"), m.report["parameters"]["init"]
    assert any("fewer than 20 distinct landmark pairs" in n for n in m.report["notes"])


def test_prepared_surfaces_give_the_same_map(surfaces, bim):
    (VA, FA), (VB, FB) = surfaces
    pA = shapemap.prepare_surface(VA, FA, name="A", samples=FAST_BIM["samples"])
    pB = shapemap.prepare_surface(VB, FB, name="B", samples=FAST_BIM["samples"])
    m = shapemap.surface_map(VA, FA, VB, FB, symmetric=True, prepared=(pA, pB), **FAST_BIM)
    assert np.array_equal(m.element, bim.element) and np.array_equal(m.bary, bim.bary)
    assert np.array_equal(m.reverse.element, bim.reverse.element) and np.array_equal(m.reverse.bary, bim.reverse.bary)
    assert m.report["bim"]["stages"]["A/sampling_geodesics"] == 0  # not done again


def test_pickled_prepared_surfaces_give_the_same_map(surfaces, bim):
    # How shapemap batch shares one preparation between Dask workers (and its cache file).
    import pickle
    (VA, FA), (VB, FB) = surfaces
    pA, pB = (pickle.loads(pickle.dumps(shapemap.prepare_surface(V, F, name=n, samples=FAST_BIM["samples"])))
              for V, F, n in ((VA, FA, "A"), (VB, FB, "B")))
    assert pA.num_vertices == len(VA)
    m = shapemap.surface_map(VA, FA, VB, FB, symmetric=True, prepared=(pA, pB), **FAST_BIM)
    assert np.array_equal(m.element, bim.element) and np.array_equal(m.bary, bim.bary)
    assert np.array_equal(m.reverse.element, bim.reverse.element) and np.array_equal(m.reverse.bary, bim.reverse.bary)


def test_prepared_surfaces_elastic_same_map(surfaces):
    (VA, FA), (VB, FB) = surfaces
    prepared = (shapemap.prepare_surface(VA, FA, samples=FAST_BIM["samples"]),
                shapemap.prepare_surface(VB, FB, samples=FAST_BIM["samples"]))
    a = shapemap.surface_map(VA, FA, VB, FB, method="elastic", elastic_iterations=3, **FAST_BIM)
    b = shapemap.surface_map(VA, FA, VB, FB, method="elastic", elastic_iterations=3, prepared=prepared, **FAST_BIM)
    assert np.array_equal(a.element, b.element) and np.array_equal(a.bary, b.bary)


def test_elastic_untangle_option(surfaces):
    """elastic_untangle=False is `--elastic-no-untangle`: the report says so; with the stage
    the returned maps have no more flipped or collapsed triangles than without it."""
    (VA, FA), (VB, FB) = surfaces
    on = shapemap.surface_map(VA, FA, VB, FB, method="elastic", elastic_iterations=3, **FAST_BIM)
    off = shapemap.surface_map(VA, FA, VB, FB, method="elastic", elastic_iterations=3, elastic_untangle=False,
                               **FAST_BIM)
    assert on.report["elastic"]["untangle"]["enabled"] is True
    assert off.report["elastic"]["untangle"] == {"enabled": False}
    for d in ("AB", "BA"):
        u = on.report["elastic"]["untangle"][d]
        m = off.report["metrics"]["final"][d]
        assert u["bad_triangles_before"] == m["flipped_triangles"] + m["degenerate_triangles"]
        assert u["bad_triangles_after"] <= u["bad_triangles_before"]
        w = on.report["elastic"]["untangle"]["wide"][d]
        if on.report["elastic"]["untangle"]["passes"] == 1:
            assert w["bad_triangles_before"] == u["bad_triangles_after"]
        assert w["bad_triangles_after"] <= w["bad_triangles_before"]
    # elastic_untangle_passes=1: the stages once (the first pass of the default run)
    one = shapemap.surface_map(VA, FA, VB, FB, method="elastic", elastic_iterations=3, elastic_untangle_passes=1,
                               **FAST_BIM)
    assert one.report["elastic"]["untangle"]["passes"] == 1
    assert 1 <= on.report["elastic"]["untangle"]["passes"] <= 3
    # elastic_feature_anchors=False: no stage 0 (--elastic-no-feature-anchors)
    assert one.report["elastic"]["anchors"]["enabled"] is True
    free = shapemap.surface_map(VA, FA, VB, FB, method="elastic", elastic_iterations=3,
                                elastic_feature_anchors=False, **FAST_BIM)
    assert free.report["elastic"]["anchors"]["enabled"] is False
    assert free.report["elastic"]["anchors"]["count"] == 0
    for d in ("AB", "BA"):
        assert (on.report["elastic"]["untangle"]["slivers"][d]["bad_triangles_after"]
                <= one.report["elastic"]["untangle"]["slivers"][d]["bad_triangles_after"])
    # elastic_bridge_untangle=False: no stage 5 (--elastic-no-bridge-untangle); with it, never a fold more
    assert on.report["elastic"]["untangle"]["bridges"]["enabled"] is True
    nob = shapemap.surface_map(VA, FA, VB, FB, method="elastic", elastic_iterations=3,
                               elastic_bridge_untangle=False, **FAST_BIM)
    assert nob.report["elastic"]["untangle"]["bridges"] == {"enabled": False}
    for d in ("AB", "BA"):
        b = on.report["elastic"]["untangle"]["bridges"][d]
        assert b["bad_triangles_after"] <= b["bad_triangles_before"]
    # elastic_search_untangle=False: no stage 6 (--elastic-no-search-untangle); it runs only on
    # folds left, and never adds one
    search = on.report["elastic"]["untangle"]["search"]
    assert search["enabled"] is True
    for d in ("AB", "BA") if search["ran"] else ():
        assert search[d]["bad_triangles_after"] <= search[d]["bad_triangles_before"]
    nos = shapemap.surface_map(VA, FA, VB, FB, method="elastic", elastic_iterations=3,
                               elastic_search_untangle=False, **FAST_BIM)
    assert nos.report["elastic"]["untangle"]["search"] == {"enabled": False, "ran": False}


def test_cli_and_module_same_elastic_map_with_model_options(cli, pair, surfaces, tmp_path):
    """The elastic model's options (the projection, the guard's rule, the anchors) reach the
    library from the module as from the command line: the same maps, the report says which."""
    (VA, FA), (VB, FB) = surfaces
    cli("--seed", 1, "surface-map", pair / "A.obj", pair / "B.obj", "--method", "elastic", *FAST_BIM_CLI,
        "--elastic-iterations", 4, "--elastic-plain-projection-in-ramp", "--elastic-guard-before-untangling",
        "--elastic-anchors-hold-to-end", "--elastic-anchor-weight", 5, "--elastic-anchor-tolerance", 0.02,
        "-o", tmp_path / "out")
    m = shapemap.surface_map(VA, FA, VB, FB, method="elastic", elastic_iterations=4, seed=1,
                             elastic_plain_projection_in_ramp=True, elastic_guard_before_untangling=True,
                             elastic_anchors_hold_to_end=True, elastic_anchor_weight=5, elastic_anchor_tolerance=0.02,
                             **FAST_BIM)
    shapemap.write_map(tmp_path / "py_AB.txt", m)
    shapemap.write_map(tmp_path / "py_BA.txt", m.reverse)
    for d in ("AB", "BA"):
        assert (tmp_path / "out" / f"map_{d}.txt").read_text() == (tmp_path / f"py_{d}.txt").read_text(), d
    p = m.report["parameters"]
    assert p["safe_projection"] is True and p["safe_projection_in_ramp"] is False
    assert m.report["elastic"]["guard"]["judged_untangled"] is False
    plain = shapemap.surface_map(VA, FA, VB, FB, method="elastic", elastic_iterations=4, seed=1,
                                 elastic_plain_projection=True, **FAST_BIM)
    assert plain.report["parameters"]["safe_projection"] is False
    assert plain.report["elastic"]["guard"]["judged_untangled"] is True


def test_elastic_landmarks_are_the_anchors(surfaces, pair):
    """With landmarks, the elastic refinement's anchors (stage 0) are the landmarks themselves
    (docs/methods.md, "Feature anchors"); without, the AGD maxima the initial maps pair up."""
    (VA, FA), (VB, FB) = surfaces
    truth = shapemap.read_map(pair / "truth_AB.txt", VB, FB).points()
    LA = np.arange(0, len(VA), len(VA) // 6)[:6]
    LB = ((truth[LA][:, None, :] - VB[None, :, :]) ** 2).sum(axis=2).argmin(axis=1)
    m = shapemap.surface_map(VA, FA, VB, FB, method="elastic", landmarks=(LA, LB), elastic_iterations=3,
                             **FAST_BIM)
    an = m.report["elastic"]["anchors"]
    assert an["source"] == "landmarks"
    assert an["A"] == [int(i) for i in LA] and an["B"] == [int(i) for i in LB]
    f = shapemap.surface_map(VA, FA, VB, FB, method="elastic", elastic_iterations=3, **FAST_BIM)
    af = f.report["elastic"]["anchors"]
    assert af["source"] == "features" and af["count"] == len(af["A"]) == len(af["distance"])
    assert all(d <= 0.005 for d in af["distance"])


def test_landmarks_guide_bim_or_replace_its_features(surfaces, pair):
    """landmark_features (`--no-landmark-features` when False): with 3 landmarks BIM keeps its own
    AGD maxima as features and the candidates that agree with the landmarks; without, the one
    landmark triple is the only candidate (docs/methods.md, "Landmarks among the feature points")."""
    (VA, FA), (VB, FB) = surfaces
    truth = shapemap.read_map(pair / "truth_AB.txt", VB, FB).points()
    LA = np.arange(0, len(VA), len(VA) // 3)[:3]
    LB = ((truth[LA][:, None, :] - VB[None, :, :]) ** 2).sum(axis=2).argmin(axis=1)
    g = shapemap.surface_map(VA, FA, VB, FB, landmarks=(LA, LB), **FAST_BIM)
    t = shapemap.surface_map(VA, FA, VB, FB, landmarks=(LA, LB), landmark_features=False, **FAST_BIM)
    assert t.report["bim"]["AB"]["num_candidates"] == 1 and len(t.report["bim"]["features_A"]) == 3
    assert len(g.report["bim"]["features_A"]) > 3 and g.report["bim"]["features_A"][:3] == [int(i) for i in LA]
    assert g.report["bim"]["AB"]["num_candidates"] >= 1


def test_too_few_features_to_blend_runs_bim_again(surfaces):
    """blend_features (`--blend-features`): with 3 features a side no two of BIM's candidate maps can
    be blended; BIM then runs again with spread samples, guided by the single map's triple, and
    reports it (docs/methods.md, "Too few features to blend"); 0 keeps the single map."""
    (VA, FA), (VB, FB) = surfaces
    fast = dict(FAST_BIM, features=3)
    single = shapemap.surface_map(VA, FA, VB, FB, blend_features=0, **fast)
    again = shapemap.surface_map(VA, FA, VB, FB, **fast)
    assert len(single.report["bim"]["features_A"]) == 3 and "blend_retry" not in single.report["bim"]
    r = again.report["bim"]["blend_retry"]
    assert r["confidence"] > 0
    assert len(again.report["bim"]["features_A"]) == (12 if r["kept"] else 3)
    if r["kept"]:
        assert again.report["bim"]["AB"]["integrated_confidence"] > single.report["bim"]["AB"]["integrated_confidence"]
    # blend_triples (`--blend-triples`): that run once for each of the most confident single maps.
    assert r["runs"] == 1 and again.report["parameters"]["blend_triples"] == 1
    more = shapemap.surface_map(VA, FA, VB, FB, blend_triples=3, **fast)
    m = more.report["bim"]["blend_retry"]
    assert 1 <= m["runs"] <= 3 and m["confidence"] >= r["confidence"]
    # blend_guide_maps (`--blend-guide-maps`): the stretch guide's candidates, reported.
    assert again.report["parameters"]["blend_guide_maps"] == 32
    off = shapemap.surface_map(VA, FA, VB, FB, blend_guide_maps=0, **fast)
    assert off.report["parameters"]["blend_guide_maps"] == 0 and not off.report["bim"]["blend_retry"]["stretch_guide"]
