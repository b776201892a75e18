#!/usr/bin/python3
"""Symmetric volume maps on real shapes (issue 19), run through the command-line tool.

Pairs (the real ones read ../shared/data, or $SHAPEMAP_DATA; skipped when it is absent):
  airplane -> bird   shrec07-61 -> 248, the data's 3 landmarks       (--landmarks alone: the
                     tool's default, --init auto guided by them when fewer than 20)
  cat -> lion        tosca-cat-00 -> tosca-lion-00, 20 landmarks     (--landmarks: --init landmarks)
  airplane-bird-auto, cat-lion-auto: the same shapes, mapped fully automatically (the landmarks
                     unused): BIM + elastic surface map, computed once (--init surface-map)
  glasses 41 -> 44   BIM + elastic surface map, computed once         (--init surface-map)
  busts 302 -> 314   BIM + elastic surface map, computed once         (--init surface-map);
                     upside down until BIM's stretch guide (docs/methods.md, "The busts:
                     upside down"), so the busts are also scored by whether heads stay up
  glasses-tets, busts-tets: the same pairs from their tet meshes alone (--init auto: BIM +
                     elastic on the meshes' boundary surfaces), as issue 19 specifies them
  busts-landmarks    the busts with 4 landmarks the bench places (bench/landmarks/README.md)
                     (--landmarks: the tool's default start with them), judged against the
                     busts' baseline
  camel 01 -> 02     gallop poses as scans come (non-manifold edges, crossings; repaired,
                     tetrahedralized), BIM + elastic surface map      (--init surface-map)
  gen-30k, gen-100k  generated non-isometric creature pairs with ground truth, 12 landmarks
                     at farthest points of A and their true images    (--init landmarks)
Surfaces are tetrahedralized once (`tetrahedralize --tets 30000`; the paper's pair has 30k /
27k tets) and cached with the surface maps in WORK/cache, so that the solvers compared
start from the same tet meshes and the same initial maps. Landmark indices of a surface are
written as x y z lines, which volume-map snaps to the nearest boundary vertex.

Per pair and solver (default: newton and lbfgs, --solvers; lbfgs runs today's code as the
solver was before issue 19, with the boundary-fixed stage from landmarks too; "before" runs the
tool built from the commit the issue measured, ac3f50b, given by --before-build: its
defaults, nothing else, so the ratio targets compare against the issue's own baseline), per
direction: n_inv of the
positions X, d^max and d^avg (x1e-2), mean |det J^|, E_R and E_ARAP (x1e-3), n_inv of the map
files, and the run's time (the optimization alone and the command), peak memory, the stages'
stop reasons. Then the issue's targets, newton against "before" (else lbfgs) on each real pair:
d^max, d^avg <= 1/2, E_R <= 1/5, n_inv <= 5, map files' n_inv = X's, every stage stopped by
its convergence test (stages 2, 4, stage 4's second run at --alpha-final and the interiors' last
relaxation at it); and time: <= 60 s
for gen-30k, <= 300 s for gen-100k, <= 4 GB; on the busts, heads up (bench/surface_real.py's
heads_up on the map files: >= 90%).
Generated pairs also get a reference row "exact": the generator's map (truth_vol_AB.txt) with
B -> A its piecewise-linear inverse, evaluated like the others: what two piecewise-linear
maps on these meshes can reach (E_R above all; docs/methods.md, "What E_R measures").

With --jitter N, each real pair is mapped N more times by the newton solver with A (its tet
mesh and its landmark file) translated by k x 1e-9 of its bounding-box diagonal, k = 1..N: a
change at the level of rounding, which the maps should not feel. They do on some pairs (cat ->
lion's E_R spreads by about 20%; docs/methods.md, "How much of a figure is chance"): the spread
(min / median / max of the 1 + N runs) is printed per pair and direction, and the ratio targets
are also judged on the median.

Usage: bench/volume_map_real.sh [--pairs a,b,...] [--solvers newton,lbfgs] [--build DIR]
                                [--work DIR] [--extra "ARGS"] [--before-build DIR] [--jitter N]
  e.g. git worktree add /tmp/before ac3f50b && cmake -S /tmp/before -B /tmp/before/build
       -DCMAKE_BUILD_TYPE=Release && cmake --build /tmp/before/build --target shapemap, then
       --solvers newton,before --before-build /tmp/before/build
Writes WORK/volume_real.md (default bench/out/volume_real) and WORK/results.json.
Exit status 1 when a run failed or a target is missed, 0 otherwise.
"""
import argparse
import json
import math
import os
import shlex
import subprocess
import sys
import time

ROOT = os.path.dirname(os.path.dirname(os.path.abspath(__file__)))


def read_off_or_obj_vertices(path):
    """Vertex positions of an OFF or OBJ surface (enough of each grammar for the data)."""
    with open(path) as f:
        text = f.read().split("\n")
    if path.endswith(".obj"):
        return [tuple(map(float, l.split()[1:4])) for l in text if l.startswith("v ")]
    tokens = []
    for line in text:
        line = line.split("#")[0].strip()
        if line:
            tokens.extend(line.split())
    assert tokens[0].upper().endswith("OFF"), path
    nv = int(tokens[1])
    vals = tokens[4:4 + 3 * nv]
    return [tuple(map(float, vals[3 * i:3 * i + 3])) for i in range(nv)]


def write_xyz(path, points):
    with open(path, "w") as f:
        for p in points:
            f.write("%.17g %.17g %.17g\n" % p)


def landmark_xyz(surface, index_file, out):
    V = read_off_or_obj_vertices(surface)
    with open(index_file) as f:
        idx = [int(l.split()[0]) for l in f if l.strip() and not l.lstrip().startswith("#")]
    write_xyz(out, [V[i] for i in idx])


def busts_heads_up(build, A, B, out):
    """bench/surface_real.py's heads_up (upright shapes: heads onto heads, bases onto bases) on
    the map files between the busts' tet meshes."""
    sys.path.insert(0, os.path.join(build, "python"))
    sys.path.insert(0, os.path.dirname(os.path.abspath(__file__)))
    import shapemap
    from surface_real import heads_up
    VA, TA = shapemap.read_volume(A)[:2]
    VB, TB = shapemap.read_volume(B)[:2]
    P = shapemap.read_map(os.path.join(out, "map_AB.txt"), VB, TB).points()
    Q = shapemap.read_map(os.path.join(out, "map_BA.txt"), VA, TA).points()
    return heads_up(VA, VB, P, Q)


class Runner:
    def __init__(self, build, work, log):
        self.bin = os.path.join(build, "shapemap")
        self.work = work
        self.log = open(log, "a")

    def run(self, args, timeout=3600):
        """Runs the CLI under GNU time; returns (exit code, wall seconds, peak MB)."""
        rss_file = os.path.join(self.work, "time.txt")
        cmd = ["/usr/bin/time", "-f", "%M", "-o", rss_file, self.bin] + args
        self.log.write("== " + " ".join(shlex.quote(a) for a in cmd) + "\n")
        self.log.flush()
        t0 = time.time()
        try:
            p = subprocess.run(cmd, stdout=self.log, stderr=self.log, timeout=timeout,
                               env=dict(os.environ, OMP_WAIT_POLICY="passive"))
            code = p.returncode
        except subprocess.TimeoutExpired:
            code = -1
        wall = time.time() - t0
        peak = None
        try:
            with open(rss_file) as f:
                peak = int(f.read().strip().split("\n")[-1]) / 1024.0
        except (OSError, ValueError):
            pass
        return code, wall, peak

    def need(self, path, args, what):
        if os.path.exists(path):
            return True
        code, wall, _ = self.run(args)
        if code != 0:
            print("bench: %s failed (exit %d), see %s" % (what, code, self.log.name), file=sys.stderr)
            return False
        print("bench: %s: %.1f s" % (what, wall), file=sys.stderr)
        return True


TETS_ONLY = ("tets only",)  # prepare_real's landmarks for the pairs mapped from their tet meshes alone


def translated_copy(src, dst, fraction):
    """Writes the legacy-VTK tet mesh SRC to DST with every point moved by FRACTION of its
    bounding-box diagonal along (1, 1, 1); returns that offset (per coordinate), or None when
    SRC is not an ASCII legacy VTK file."""
    lines = open(src).read().split("\n")
    start = next((i for i, l in enumerate(lines) if l.startswith("POINTS ")), None)
    if start is None or "ASCII" not in lines[:4]:
        return None
    n = int(lines[start].split()[1])
    rows, i = [], start + 1
    while sum(len(r) for r in rows) < 3 * n:
        rows.append([float(t) for t in lines[i].split()])
        i += 1
    flat = [x for r in rows for x in r]
    lo = [min(flat[c::3]) for c in range(3)]
    hi = [max(flat[c::3]) for c in range(3)]
    offset = fraction * math.dist(lo, hi)
    lines[start + 1:i] = [" ".join(repr(x + offset) for x in r) for r in rows]
    with open(dst, "w") as f:
        f.write("\n".join(lines))
    return offset


def jittered_inputs(cache, name, A, init, k):
    """A translated by k x 1e-9 of its diagonal, with the landmark file of A (if any) moved
    along; returns (A_k, init_k) or None."""
    A_k = os.path.join(cache, "%s-jitter%d.vtk" % (name, k))
    offset = translated_copy(A, A_k, k * 1e-9)
    if offset is None:
        return None
    init_k = list(init)
    if "--landmarks" in init_k:
        i = init_k.index("--landmarks") + 1
        la_k = os.path.join(cache, "%s-jitter%d.xyz" % (name, k))
        pts = [tuple(float(t) + offset for t in l.split()) for l in open(init_k[i]) if l.strip()]
        write_xyz(la_k, pts)
        init_k[i] = la_k
    return A_k, init_k


def prepare_real(r, data, cache, name, a, b, landmarks):
    """Tet meshes (cached), and the init arguments of volume-map. landmarks: True for the data's
    landmark files, a folder for the bench's own (bench/landmarks), False for none (a surface
    map of the surfaces), TETS_ONLY for none and no surfaces (--init auto on the tet meshes)."""
    ta, tb = os.path.join(cache, a + ".vtk"), os.path.join(cache, b + ".vtk")
    sa, sb = os.path.join(data, a + ".off"), os.path.join(data, b + ".off")
    for s, t in ((sa, ta), (sb, tb)):
        # 30k tets as the paper's pair; thin shapes (the cat's tail) need the default size.
        if not (r.need(t, ["tetrahedralize", s, "-o", t, "--tets", "30000", "--quiet"], "tetrahedralize " + s) or
                r.need(t, ["tetrahedralize", s, "-o", t, "--quiet"], "tetrahedralize (default size) " + s)):
            return None
    if landmarks == TETS_ONLY:
        return ta, tb, ["--init", "auto"], None
    if landmarks:
        la, lb = os.path.join(cache, a + ".xyz"), os.path.join(cache, b + ".xyz")
        folder = landmarks if isinstance(landmarks, str) else data
        landmark_xyz(sa, os.path.join(folder, a + ".landmarks"), la)
        landmark_xyz(sb, os.path.join(folder, b + ".landmarks"), lb)
        # The tool's default with landmarks (--init landmarks, or auto guided by them when there are
        # fewer than 20 pairs); the old tool's default is --init landmarks.
        return ta, tb, ["--landmarks", la, lb], None
    smap = os.path.join(cache, name + "-surface-map")
    if not r.need(os.path.join(smap, "map_BA.txt"),
                  ["surface-map", sa, sb, "-o", smap, "--method", "elastic", "--quiet"],
                  "surface map (BIM + elastic) " + name):
        return None
    return ta, tb, ["--init", "surface-map", "--surface-map", os.path.join(smap, "map_AB.txt"),
                    os.path.join(smap, "map_BA.txt"), "--surface-map-meshes", sa, sb], None


def prepare_generated(r, cache, name, tets, verts):
    d = os.path.join(cache, name)
    if not r.need(os.path.join(d, "truth_vol_AB.txt"),
                  ["generate", "-o", d, "--shape", "pair", "--kind", "non-isometric", "--seed", "1",
                   "--vertices", str(verts), "--tets", "--tet-count", str(tets), "--quiet"],
                  "generate " + name):
        return None
    # Landmarks: 12 farthest points of A's surface and their true images on B (truth_AB.txt:
    # face of B + barycentric per vertex of A).
    VA = read_off_or_obj_vertices(os.path.join(d, "A.obj"))
    VB = read_off_or_obj_vertices(os.path.join(d, "B.obj"))
    FB = []
    with open(os.path.join(d, "B.obj")) as f:
        for l in f:
            if l.startswith("f "):
                FB.append([int(t.split("/")[0]) - 1 for t in l.split()[1:4]])
    with open(os.path.join(d, "truth_AB.txt")) as f:
        rows = [l.split() for l in f if l.strip() and not l.startswith("#")][1:]  # after the header
    chosen = [0]
    dist = [math.dist(VA[0], v) for v in VA]
    while len(chosen) < 12:
        i = max(range(len(VA)), key=lambda k: dist[k])
        chosen.append(i)
        dist = [min(dist[k], math.dist(VA[i], VA[k])) for k in range(len(VA))]
    img = []
    for i in chosen:
        face, bary = int(rows[i][0]), list(map(float, rows[i][1:4]))
        img.append(tuple(sum(bary[c] * VB[FB[face][c]][x] for c in range(3)) for x in range(3)))
    la, lb = os.path.join(d, "LA.xyz"), os.path.join(d, "LB.xyz")
    write_xyz(la, [VA[i] for i in chosen])
    write_xyz(lb, img)
    return (os.path.join(d, "A.vtk"), os.path.join(d, "B.vtk"),
            ["--init", "landmarks", "--landmarks", la, lb], os.path.join(d, "truth_vol_AB.txt"))


PAIRS = {
    "airplane-bird": ("real", "shrec07-61", "shrec07-248", True),
    "cat-lion": ("real", "tosca-cat-00", "tosca-lion-00", True),
    "airplane-bird-auto": ("real", "shrec07-61", "shrec07-248", False),
    "cat-lion-auto": ("real", "tosca-cat-00", "tosca-lion-00", False),
    "glasses": ("real", "shrec07-41", "shrec07-44", False),
    "busts": ("real", "shrec07-302", "shrec07-314", False),
    "busts-landmarks": ("real", "shrec07-302", "shrec07-314", os.path.join(ROOT, "bench", "landmarks")),
    "glasses-tets": ("real", "shrec07-41", "shrec07-44", TETS_ONLY),
    "busts-tets": ("real", "shrec07-302", "shrec07-314", TETS_ONLY),
    "camel": ("real", "camel-gallop-01", "camel-gallop-02", False),
    "gen-30k": ("generated", 30000, 6000),
    "gen-100k": ("generated", 100000, 16000),
}


def main():
    ap = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    ap.add_argument("--pairs", default=",".join(PAIRS))
    ap.add_argument("--solvers", default="newton,lbfgs")
    ap.add_argument("--build", default=os.environ.get("BUILD", os.path.join(ROOT, "build")))
    ap.add_argument("--work", default=os.path.join(ROOT, "bench", "out", "volume_real"))
    ap.add_argument("--extra", default="", help="more volume-map arguments, for every run")
    ap.add_argument("--before-build", default="",
                    help="build folder of the tool at the issue's commit (solver 'before')")
    ap.add_argument("--jitter", type=int, default=0,
                    help="N more newton runs per real pair with A translated by k x 1e-9 of its diagonal")
    args = ap.parse_args()
    data = os.environ.get("SHAPEMAP_DATA", os.path.join(ROOT, "..", "shared", "data"))
    cache = os.path.join(args.work, "cache")
    os.makedirs(cache, exist_ok=True)
    r = Runner(args.build, args.work, os.path.join(args.work, "log.txt"))
    if not os.access(r.bin, os.X_OK):
        sys.exit("bench: %s not found (make build first)" % r.bin)
    before = Runner(args.before_build, args.work, os.path.join(args.work, "log.txt")) if args.before_build else None
    if "before" in args.solvers.split(",") and not (before and os.access(before.bin, os.X_OK)):
        sys.exit("bench: solver 'before' needs --before-build DIR with DIR/shapemap")
    results, failed = [], 0
    for name in args.pairs.split(","):
        spec = PAIRS[name]
        if spec[0] == "real":
            if not os.path.isdir(data):
                print("bench: %s skipped (no %s)" % (name, data), file=sys.stderr)
                continue
            prep = prepare_real(r, data, cache, name, spec[1], spec[2], spec[3])
        else:
            prep = prepare_generated(r, cache, name, spec[1], spec[2])
        if prep is None:
            failed += 1
            continue
        A, B, init, truth = prep
        for solver in args.solvers.split(","):
            results.append(run_row(before if solver == "before" else r, args, name, solver, A, B, init, truth))
            failed += results[-1]["exit_code"] != 0
        for k in range(1, args.jitter + 1 if spec[0] == "real" else 1):
            moved = jittered_inputs(cache, name, A, init, k)
            if moved is None:
                print("bench: %s: no jitter (A is not an ASCII legacy VTK file)" % name, file=sys.stderr)
                break
            results.append(run_row(r, args, name, "newton~%d" % k, moved[0], B, moved[1], None))
            failed += results[-1]["exit_code"] != 0
        if spec[0] == "generated":
            row = exact_row(r, args.work, name, A, B, truth)
            if row:
                results.append(row)
    json.dump(results, open(os.path.join(args.work, "results.json"), "w"), indent=1)
    missed = report(results, os.path.join(args.work, "volume_real.md"))
    sys.exit(1 if failed or missed else 0)


def run_row(r, args, name, solver, A, B, init, truth):
    """One volume-map run of pair NAME (solver "newton", "lbfgs", "before" with R the old tool's
    runner, or "newton~k", a jittered copy) and its row of results."""
    out = os.path.join(args.work, name + "-" + solver)
    # "lbfgs" is the solver as it was before issue 19: L-BFGS X-steps, stage 2 always, no landing.
    today = ["--boundary-fixed-stage", "on", "--no-land-on-target", "--boundary-fixed-iteration-factor", "1"] \
        if solver == "lbfgs" else []
    if solver == "before":  # the issue's own baseline: that tool's defaults
        code, wall, peak = r.run(["volume-map", A, B, "-o", out, "--quiet"] + init + shlex.split(args.extra))
    else:
        code, wall, peak = r.run(["volume-map", A, B, "-o", out, "--solver", solver.split("~")[0], "--quiet"] +
                                 today + init + shlex.split(args.extra))
    row = {"pair": name, "solver": solver, "exit_code": code, "seconds": wall, "peak_mb": peak}
    if code == 0:
        rep = json.load(open(os.path.join(out, "report.json")))
        row["metrics"] = rep["metrics"]
        row["map_files"] = rep["metrics_map_files"]
        # The optimization's time ("map" since the command became a library pipeline).
        row["optimize_seconds"] = rep["timings"].get("optimize", rep["timings"].get("map"))
        row["stages"] = [(s["name"], s["stop_reason"], s["iterations"]) for s in rep["algorithm_stages"]]
        if name.startswith("busts"):
            row["heads_up"] = busts_heads_up(args.build, A, B, out)
        if truth:
            tr = os.path.join(out, "eval.json")
            c2, _, _ = r.run(["--quiet", "evaluate", "volume", A, B, os.path.join(out, "map_AB.txt"),
                              "--truth", truth, "-o", tr])
            if c2 == 0:
                row["truth"] = json.load(open(tr))["metrics"]
    print("bench: %s %s: exit %d, %.1f s" % (name, solver, code, wall), file=sys.stderr)
    return row


def pl_inverse(pydir, A, B, map_ab, out):
    """Writes the piecewise-linear inverse of the volume map MAP_AB as a map file B -> A: each
    vertex of B in the tet of A whose image contains it (the nearest one, clamped, where the
    image of A's boundary misses it)."""
    sys.path.insert(0, pydir)
    import numpy as np
    from scipy.spatial import cKDTree
    import shapemap
    VA, TA = shapemap.read_volume(A)
    VB, TB = shapemap.read_volume(B)
    P = shapemap.read_map(map_ab, VB, TB).points()[TA]  # A's tets at their images
    _, near = cKDTree(P.mean(1)).query(VB, k=48)
    best_t = np.zeros(len(VB), int)
    best_b = np.zeros((len(VB), 4))
    best_m = np.full(len(VB), -np.inf)
    for c in range(near.shape[1]):
        t = near[:, c]
        M = np.stack([P[t, k] - P[t, 0] for k in (1, 2, 3)], axis=2)
        ok = np.abs(np.linalg.det(M)) > 1e-18
        lam = np.zeros((len(VB), 3))
        lam[ok] = np.linalg.solve(M[ok], (VB - P[t, 0])[ok][..., None])[..., 0]
        b = np.column_stack([1 - lam.sum(1), lam])
        worst = np.where(ok, b.min(1), -np.inf)  # > best: deeper inside (or less outside)
        better = worst > best_m
        best_m[better], best_t[better], best_b[better] = worst[better], t[better], b[better]
    b = np.clip(best_b, 0, None)
    b /= b.sum(1)[:, None]
    with open(out, "w") as f:
        f.write("shapemap-map 1 %d 4\n" % len(VB))
        for t, bb in zip(best_t, b):
            f.write("%d %.17g %.17g %.17g %.17g\n" % (t, *bb))


def exact_row(r, work, name, A, B, truth):
    """The reference row of a generated pair: its exact map and that map's PL inverse."""
    out = os.path.join(work, name + "-exact")
    os.makedirs(out, exist_ok=True)
    inv = os.path.join(out, "map_BA.txt")
    pl_inverse(os.path.join(os.path.dirname(r.bin), "python"), A, B, truth, inv)
    row = {"pair": name, "solver": "exact", "exit_code": 0, "seconds": None, "peak_mb": None,
           "metrics": {}, "reference": True}
    for d, (S, T, m, rev) in (("AB", (A, B, truth, inv)), ("BA", (B, A, inv, truth))):
        ev = os.path.join(out, "eval_%s.json" % d)
        code, _, _ = r.run(["--quiet", "evaluate", "volume", S, T, m, "--map-ba", rev, "-o", ev])
        if code != 0:
            return None
        row["metrics"][d] = json.load(open(ev))["metrics"]
    return row


def fmt(x, scale=1.0, digits=3):
    if x is None or (isinstance(x, float) and math.isnan(x)):
        return "-"
    return "%.*g" % (digits, x * scale)


def baseline(by, pair):
    """(name, row) of the run PAIR's ratio targets compare against: "before" when it ran, else
    "lbfgs" (row None when neither did). An "-auto" pair is judged against the baseline of the
    same shapes from their landmarks, "busts-landmarks" and "-tets" against the busts' or
    glasses' (the issue's run)."""
    shapes = pair
    for suffix in ("-auto", "-landmarks", "-tets"):
        if pair.endswith(suffix):
            shapes = pair[:-len(suffix)]
    name = "before" if (shapes, "before") in by else "lbfgs"
    return name, by.get((shapes, name))


def report(results, path):
    lines = ["| pair | solver | dir | n_inv | n_inv files | d^max x1e-2 | d^avg x1e-2 | mean abs det J^ | "
             "E_R x1e-3 | E_ARAP x1e-3 | optimize s | total s | peak MB | stages (stop, iterations) |",
             "|---|---|---|---|---|---|---|---|---|---|---|---|---|---|"]
    for row in results:
        if row["exit_code"] != 0:
            lines.append("| %s | %s | | failed (exit %d) | | | | | | | | %.1f | | |" %
                         (row["pair"], row["solver"], row["exit_code"], row["seconds"]))
            continue
        for d in ("AB", "BA"):
            m = row["metrics"][d]
            if row.get("reference"):
                lines.append("| %s | %s | %s | %d | | %s | %s | %s | %s | %s | | | | reference: the exact map |" % (
                    row["pair"], row["solver"], d, m["n_inv"], fmt(m["d_max_hat"], 100), fmt(m["d_avg_hat"], 100),
                    fmt(m["det_J_mean"], 1, 4), fmt(m.get("E_R"), 1000), fmt(m["E_ARAP"], 1000)))
                continue
            f = row["map_files"][d]
            stages = ", ".join("%s %s %d" % s for s in row["stages"][1:]) if d == "AB" else ""
            lines.append("| %s | %s | %s | %d | %d | %s | %s | %s | %s | %s | %s | %s | %s | %s |" % (
                row["pair"], row["solver"], d, m["n_inv"], f["n_inv"], fmt(m["d_max_hat"], 100),
                fmt(m["d_avg_hat"], 100), fmt(m["det_J_mean"], 1, 4), fmt(m.get("E_R"), 1000),
                fmt(m["E_ARAP"], 1000), fmt(row["optimize_seconds"], 1, 3) if d == "AB" else "",
                fmt(row["seconds"], 1, 3) if d == "AB" else "",
                fmt(row["peak_mb"], 1, 4) if d == "AB" else "", stages))
    # Targets (issue 19).
    checks = []
    by = {(r["pair"], r["solver"]): r for r in results if r["exit_code"] == 0}
    for (pair, solver), row in sorted(by.items()):
        if solver != "newton":
            continue
        base_name, base = baseline(by, pair)
        for d in ("AB", "BA"):
            m, f = row["metrics"][d], row["map_files"][d]
            checks.append(("%s %s n_inv <= 5" % (pair, d), m["n_inv"] <= 5, str(m["n_inv"])))
            checks.append(("%s %s map files' n_inv = X's" % (pair, d), f["n_inv"] == m["n_inv"],
                           "%d vs %d" % (f["n_inv"], m["n_inv"])))
            if base and not pair.startswith("gen"):
                b = base["metrics"][d]
                for key, ratio in (("d_max_hat", 0.5), ("d_avg_hat", 0.5), ("E_R", 0.2)):
                    ok = m[key] <= ratio * b[key]
                    checks.append(("%s %s %s <= %g x %s" % (pair, d, key, ratio, base_name), ok,
                                   "%.3g vs %.3g" % (m[key], b[key])))
        if "heads_up" in row:
            checks.append(("%s heads up (>= 90%% of each bust's top and bottom 15%% in the same half of the other, "
                           "both directions)" % pair, row["heads_up"] >= 0.9, "worst %.0f%%" % (100 * row["heads_up"])))
        opt_stages = [s for s in row["stages"] if s[0] in ("boundary-fixed", "full", "full-reversible", "interior-reversible")]
        conv = all(s[1] in ("gradient", "decrease") for s in opt_stages)
        checks.append(("%s stages end on convergence" % pair, conv,
                       ", ".join("%s:%s" % (s[0], s[1]) for s in opt_stages)))
        limit = {"gen-30k": 60, "gen-100k": 300}.get(pair)
        if limit:
            checks.append(("%s optimize <= %d s" % (pair, limit), row["optimize_seconds"] <= limit,
                           "%.1f s" % row["optimize_seconds"]))
        if row["peak_mb"]:
            checks.append(("%s peak <= 4 GB" % pair, row["peak_mb"] <= 4096, "%.0f MB" % row["peak_mb"]))
    checks += spread(results, by, lines)
    lines.append("")
    lines.append("| target | met | measured |")
    lines.append("|---|---|---|")
    for name, ok, val in checks:
        lines.append("| %s | %s | %s |" % (name, "PASS" if ok else "FAIL", val))
    missed = sum(1 for c in checks if not c[1])
    lines.append("")
    lines.append("%d of %d targets met" % (len(checks) - missed, len(checks)))
    text = "\n".join(lines) + "\n"
    open(path, "w").write(text)
    print(text)
    return missed


def spread(results, by, lines):
    """The jittered runs (--jitter): min / median / max of the newton run and its jittered copies
    per pair and direction, appended to LINES; returns the ratio targets judged on the medians."""
    checks = []
    pairs = sorted({r["pair"] for r in results if r["solver"].startswith("newton~")})
    if not pairs:
        return checks
    lines += ["", "Spread over the newton run and its jittered copies (A moved by k x 1e-9 of its diagonal): "
              "min / median / max", "", "| pair | dir | runs | d^max x1e-2 | d^avg x1e-2 | E_R x1e-3 | E_ARAP x1e-3 |",
              "|---|---|---|---|---|---|---|"]
    for pair in pairs:
        runs = [r for r in results if r["pair"] == pair and r["exit_code"] == 0 and
                (r["solver"] == "newton" or r["solver"].startswith("newton~"))]
        base_name, base = baseline(by, pair)
        for d in ("AB", "BA"):
            cells, med = [], {}
            for key, scale in (("d_max_hat", 100), ("d_avg_hat", 100), ("E_R", 1000), ("E_ARAP", 1000)):
                v = sorted(r["metrics"][d][key] for r in runs)
                med[key] = v[len(v) // 2] if len(v) % 2 else 0.5 * (v[len(v) // 2 - 1] + v[len(v) // 2])
                cells.append("%s / %s / %s" % (fmt(v[0], scale), fmt(med[key], scale), fmt(v[-1], scale)))
            lines.append("| %s | %s | %d | %s |" % (pair, d, len(runs), " | ".join(cells)))
            if base and not pair.startswith("gen"):
                for key, ratio in (("d_max_hat", 0.5), ("d_avg_hat", 0.5), ("E_R", 0.2)):
                    b = base["metrics"][d][key]
                    what = "%s %s %s <= %g x %s, median of %d runs" % (pair, d, key, ratio, base_name, len(runs))
                    checks.append((what, med[key] <= ratio * b, "%.3g vs %.3g" % (med[key], b)))
    return checks


if __name__ == "__main__":
    main()
