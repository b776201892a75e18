#!/usr/bin/python3
"""Surface maps on real shapes (issue 20): BIM and BIM + elastic through the command-line tool.

Pairs (they read ../shared/data, or $SHAPEMAP_DATA; skipped when it is absent):
  cat-lion        tosca-cat-00 -> tosca-lion-00, 20 landmarks (ground truth)
  airplane-bird   shrec07-61 -> shrec07-248, 3 landmarks (ground truth)
  camel-II-JJ     camel-gallop-II -> camel-gallop-JJ, near-isometric poses without ground
                  truth, scored by reversibility and distortion
  glasses         shrec07-41 -> shrec07-44 (the volume bench's pair), no landmarks: scored by
                  reversibility, distortion, where each arm lands (BIM's symmetric flip
                  sends an arm to the other side: docs/methods.md, "Too few features to blend")
                  and whether an arm collapses onto a point (the arm spread)
  busts           shrec07-302 -> shrec07-314 (the volume bench's pair), no ground truth: scored
                  also by whether heads stay up (BIM maps them upside down: docs/methods.md,
                  "The busts: upside down")
  busts-landmarks the busts, BIM and elastic guided by 4 landmarks the bench places
                  (bench/landmarks/README.md), scored as busts
--pairs takes names and these groups: camel-01 (01 -> 02..10, 9 pairs), camel-all (the 45
pairs II < JJ), all (cat-lion, airplane-bird, glasses, busts, busts-landmarks and camel-all). Default:
cat-lion, airplane-bird, camel-01.

Per pair: `surface-map A B --method bim --symmetric`, then `surface-map A B --method elastic
--init <the BIM folder>`, and `evaluate surface` on each result (with --landmarks where
there are landmarks, --map-ba always). Columns per method and direction: landmarks within
0.05 and 0.1, mean and max geodesic error (/ sqrt(area(B))), flipped and collapsed
triangles, mean conformal distortion (MIPS - 2, collapsed triangles count as 1e4) and mean
|log area ratio| on unit-area copies, reversibility (mean |P Q x - x| over A's bounding-box
diagonal, in %), and seconds (BIM: the whole command; elastic: the refinement alone, from
report.json). Then the issue's targets, PASS/FAIL.

Results are cached per pair and method in WORK/<pair>/<method>/row.json together with a hash
of the shapemap binary: a rerun with the same binary only prints; --fresh recomputes;
--any-binary keeps rows made by another binary (for a change known not to alter the maps).

Usage: bench/surface_real.sh [--pairs a,b,...] [--build DIR] [--work DIR] [--threads N]
                             [--fresh] [--any-binary] [--extra="ARGS"] [--caption TEXT]
Writes WORK/surface_real.md (default bench/out/surface_real) and WORK/results.json.
Exit status 1 when a run failed or a target is missed, 0 otherwise.
"""
import argparse
import hashlib
import json
import math
import os
import shlex
import shutil
import subprocess
import sys
import time

ROOT = os.path.dirname(os.path.dirname(os.path.abspath(__file__)))
CAMELS = ["camel-gallop-%02d" % i for i in range(1, 11)]
FIXED = {
    "cat-lion": ("tosca-cat-00", "tosca-lion-00", True),
    "airplane-bird": ("shrec07-61", "shrec07-248", True),
}
# Pairs of the volume bench without landmarks (scored as the camels are, and the glasses' arms).
NO_TRUTH = {
    "glasses": ("shrec07-41", "shrec07-44", False),
    "busts": ("shrec07-302", "shrec07-314", False),
    "busts-landmarks": ("shrec07-302", "shrec07-314", False),
}
# Pairs whose BIM (and elastic) runs are guided by landmarks the bench places itself
# (bench/landmarks/README.md); scored without them, as the pair without landmarks is.
GUIDES = {"busts-landmarks": os.path.join(ROOT, "bench", "landmarks")}


def expand_pairs(spec):
    """Pair names of --pairs, groups expanded, order kept, duplicates dropped."""
    out = []
    for name in spec.split(","):
        name = name.strip()
        if name == "all":
            names = list(FIXED) + list(NO_TRUTH) + expand_pairs("camel-all")
        elif name == "camel-all":
            names = ["camel-%02d-%02d" % (i, j) for i in range(1, 11) for j in range(i + 1, 11)]
        elif name == "camel-01":
            names = ["camel-01-%02d" % j for j in range(2, 11)]
        else:
            names = [name]
        out.extend(n for n in names if n not in out)
    return out


def pair_files(name):
    """(A stem, B stem, has landmarks) of a pair name, or None when unknown."""
    if name in FIXED:
        return FIXED[name]
    if name in NO_TRUTH:
        return NO_TRUTH[name]
    parts = name.split("-")
    if len(parts) == 3 and parts[0] == "camel" and all(p.isdigit() for p in parts[1:]):
        i, j = int(parts[1]), int(parts[2])
        if 1 <= i <= 10 and 1 <= j <= 10 and i != j:
            return CAMELS[i - 1], CAMELS[j - 1], False
    return None


def file_hash(path):
    h = hashlib.sha256()
    with open(path, "rb") as f:
        for chunk in iter(lambda: f.read(1 << 20), b""):
            h.update(chunk)
    return h.hexdigest()[:16]


class Runner:
    def __init__(self, build, work, threads):
        self.bin = os.path.join(build, "shapemap")
        self.pydir = os.path.join(build, "python")  # the shapemap module (the glasses' arms)
        self.log = open(os.path.join(work, "log.txt"), "a")
        self.glob = ["--quiet"] + (["--threads", str(threads)] if threads is not None else [])

    def run(self, args, timeout=3600):
        """Runs the CLI (global options first); returns (exit code, wall seconds)."""
        cmd = [self.bin] + self.glob + args
        self.log.write("== " + " ".join(shlex.quote(a) for a in cmd) + "\n")
        self.log.flush()
        t0 = time.time()
        try:
            code = subprocess.run(cmd, stdout=self.log, stderr=self.log, timeout=timeout,
                                  env=dict(os.environ, OMP_WAIT_POLICY="passive")).returncode
        except subprocess.TimeoutExpired:
            code = -1
        return code, time.time() - t0


def evaluate(r, A, B, out, landmarks):
    """evaluate surface on OUT's maps, A -> B; the metrics a row shows, or None."""
    ev = os.path.join(out, "eval.json")
    args = ["evaluate", "surface", A, B, os.path.join(out, "map_AB.txt"),
            "--map-ba", os.path.join(out, "map_BA.txt"), "-o", ev]
    if landmarks:
        args += ["--landmarks"] + list(landmarks)
    code, _ = r.run(args)
    if code != 0:
        return None
    j = json.load(open(ev))
    m = {}
    for d, key in (("AB", "distortion"), ("BA", "distortion_BA")):
        x = j[key]
        m[d] = {"flipped": x["flipped_triangles"], "collapsed": x["degenerate_triangles"],
                "conformal": x["conformal_distortion"]["mean"],
                "conformal_median": x["conformal_distortion"]["median"],
                "area": x["area_distortion"]["mean_abs"]}
    m["AB"]["reversibility_bbox"] = j["reversibility_bbox"]["mean"]
    m["AB"]["reversibility_bbox_max"] = j["reversibility_bbox"]["max"]
    if "geodesic_error" in j:
        g = j["geodesic_error"]
        per = g["per_landmark"]
        m["AB"].update({"within_0.05": sum(1 for e in per if e <= 0.05) / len(per),
                        "within_0.1": sum(1 for e in per if e <= 0.1) / len(per),
                        "mean_error": g["mean"], "max_error": g["max"]})
    return m


def glasses_arms(pydir, A, B, out):
    """Where the arms land, SHREC'07 glasses 41 -> 44: 41's arms run along +y (y > 0.3), 44's along
    -z (z < -0.4); both face the same way (up is +z on 41, +y on 44: the rotation that takes one
    pair of arms onto the other keeps x), so an arm's side is the sign of x on both. Per arm and
    direction, the fraction of its vertices whose image is on the other glasses' arm of the same
    side; returns the smallest of the four."""
    sys.path.insert(0, pydir)
    import shapemap
    (VA, FA), (VB, FB) = shapemap.read_surface(A), shapemap.read_surface(B)
    P = shapemap.read_map(os.path.join(out, "map_AB.txt"), VB, FB).points()
    Q = shapemap.read_map(os.path.join(out, "map_BA.txt"), VA, FA).points()
    arm_A, arm_B = VA[:, 1] > 0.3, VB[:, 2] < -0.4
    on_B, on_A = lambda X: X[:, 2] < -0.3, lambda X: X[:, 1] > 0.2
    worst = 1.0
    for side in (1, -1):
        for V, arm, X, on in ((VA, arm_A, P, on_B), (VB, arm_B, Q, on_A)):
            m = arm & (side * V[:, 0] > 0)
            worst = min(worst, float(((side * X[m, 0] > 0) & on(X[m])).mean()))
    return worst


def glasses_arm_spread(pydir, A, B, out):
    """How much of the other's arm each arm of SHREC'07 glasses 41 -> 44 covers (arms and sides as in
    glasses_arms). Along an arm, t runs from 0 where it leaves the frame to 1 at its tip (41: y from
    0.3, 44: -z from 0.4); the images' t on the other's arm, clipped to [0, 1], at the arm's t = 0.1
    and t = 0.9 (medians over t +- 0.05); the spread is their difference: 0.8 when arc length is
    kept, about 0 when the arm collapses to a point of the other (BIM's conformal maps do this on
    thin parts: docs/methods.md, "Thin parts"). Returns the smallest of the four (two arms, two
    directions)."""
    sys.path.insert(0, pydir)
    import numpy as np
    import shapemap
    (VA, FA), (VB, FB) = shapemap.read_surface(A), shapemap.read_surface(B)
    P = shapemap.read_map(os.path.join(out, "map_AB.txt"), VB, FB).points()
    Q = shapemap.read_map(os.path.join(out, "map_BA.txt"), VA, FA).points()
    along_A = lambda X: (X[:, 1] - 0.3) / (VA[:, 1].max() - 0.3)
    along_B = lambda X: (-X[:, 2] - 0.4) / (-VB[:, 2].min() - 0.4)
    worst = 1.0
    for side in (1, -1):
        for V, X, t_src, t_dst in ((VA, P, along_A, along_B), (VB, Q, along_B, along_A)):
            t, ti = t_src(V), np.clip(t_dst(X), 0, 1)
            m = (side * V[:, 0] > 0) & (t >= 0)
            near = lambda c: float(np.median(ti[m & (np.abs(t - c) <= 0.05)]))
            worst = min(worst, near(0.9) - near(0.1))
    return worst


def heads_up(VA, VB, P, Q):
    """Whether a map between two upright shapes (+y up) keeps heads up: of the top 15% of each
    shape's height and of its bottom 15%, the fraction of vertices whose image (P: A's vertices on
    B, Q: B's on A) lies in the same half of the other's height; the smallest of the four (two
    regions, two directions). Also read by bench/volume_map_real.py for the busts' tet meshes."""
    def height(V, y):  # 0 at the bottom of V, 1 at its top
        return (y - V[:, 1].min()) / (V[:, 1].max() - V[:, 1].min())

    worst = 1.0
    for V, W, X in ((VA, VB, P), (VB, VA, Q)):
        h, hx = height(V, V[:, 1]), height(W, X[:, 1])
        worst = min(worst, float((hx[h > 0.85] > 0.5).mean()), float((hx[h < 0.15] < 0.5).mean()))
    return worst


def busts_heads_up(pydir, A, B, out):
    """heads_up of OUT's maps between SHREC'07 busts 302 and 314, both upright along +y with the
    head on top. BIM's maps without landmarks put one bust's head on the other's base
    (docs/methods.md, "The busts: upside down")."""
    sys.path.insert(0, pydir)
    import shapemap
    (VA, FA), (VB, FB) = shapemap.read_surface(A), shapemap.read_surface(B)
    P = shapemap.read_map(os.path.join(out, "map_AB.txt"), VB, FB).points()
    Q = shapemap.read_map(os.path.join(out, "map_BA.txt"), VA, FA).points()
    return heads_up(VA, VB, P, Q)


def run_pair(r, data, work, name, binhash, fresh, any_binary, extra):
    """BIM then elastic on one pair (each cached); list of rows."""
    a, b, has_lm = pair_files(name)
    A, B = os.path.join(data, a + ".off"), os.path.join(data, b + ".off")
    lm = (os.path.join(data, a + ".landmarks"), os.path.join(data, b + ".landmarks")) if has_lm else None
    guide = (["--landmarks", os.path.join(GUIDES[name], a + ".landmarks"), os.path.join(GUIDES[name], b + ".landmarks")]
             if name in GUIDES else [])
    rows = []
    for method in ("bim", "elastic"):
        out = os.path.join(work, name, method)
        cache = os.path.join(out, "row.json")
        if not fresh and os.path.exists(cache):
            row = json.load(open(cache))
            if row.get("binary") == binhash or any_binary:
                if name.startswith("busts") and row.get("exit_code") == 0 and "heads_up" not in row:
                    row["heads_up"] = busts_heads_up(r.pydir, A, B, out)  # a row cached before the check
                    json.dump(row, open(cache, "w"), indent=1)
                if name == "glasses" and row.get("exit_code") == 0 and "arm_spread" not in row:
                    row["arm_spread"] = glasses_arm_spread(r.pydir, A, B, out)  # cached before the check
                    json.dump(row, open(cache, "w"), indent=1)
                rows.append(row)
                continue
        if method == "bim":
            args = ["surface-map", A, B, "-o", out, "--method", "bim", "--symmetric"] + guide + extra
        else:
            if not os.path.exists(os.path.join(work, name, "bim", "map_BA.txt")):
                rows.append({"pair": name, "method": method, "exit_code": None, "binary": binhash})
                continue
            args = ["surface-map", A, B, "-o", out, "--method", "elastic", "--init",
                    os.path.join(work, name, "bim")] + guide + extra
        code, wall = r.run(args)
        row = {"pair": name, "method": method, "exit_code": code, "wall": wall, "binary": binhash}
        if code == 0:
            rep = json.load(open(os.path.join(out, "report.json")))
            row["seconds"] = rep["timings"]["elastic"] if method == "elastic" else wall
            if method == "elastic":
                row["outer_iterations"] = rep["elastic"]["outer_iterations"]
            row["metrics"] = evaluate(r, A, B, out, lm)
            if row["metrics"] is None:
                row["exit_code"] = "evaluate failed"  # the maps exist: elastic still runs
            elif name == "glasses":
                row["arms_on_their_own_arm"] = glasses_arms(r.pydir, A, B, out)
                row["arm_spread"] = glasses_arm_spread(r.pydir, A, B, out)
            elif name.startswith("busts"):
                row["heads_up"] = busts_heads_up(r.pydir, A, B, out)
        print("bench: %s %s: exit %s, %.1f s" % (name, method, code, wall), file=sys.stderr)
        os.makedirs(out, exist_ok=True)
        json.dump(row, open(cache, "w"), indent=1)
        rows.append(row)
    return rows


def add_repaired_counts(rows, work):
    """row["repaired_bad"][d]: flipped + collapsed triangles of the map on the repaired surfaces
    (report.json: metrics.final for elastic, metrics for BIM)."""
    for row in rows:
        rep = os.path.join(work, row["pair"], row["method"], "report.json")
        if row["exit_code"] != 0 or not os.path.exists(rep):
            continue
        m = json.load(open(rep)).get("metrics", {})
        m = m.get("final", m)
        if all(d in m for d in ("AB", "BA")):
            row["repaired_bad"] = {d: m[d]["flipped_triangles"] + m[d]["degenerate_triangles"]
                                   for d in ("AB", "BA")}


def fmt(x, scale=1.0, digits=3):
    if x is None or (isinstance(x, float) and math.isnan(x)):
        return "–"
    if isinstance(x, int):
        return str(x)
    return "%.*g" % (digits, x * scale)


def table(rows):
    lines = ["| pair | method | dir | within 0.05 | within 0.1 | mean err | max err | flipped | collapsed | "
             "conformal mean (median) | area | reversibility % | seconds |",
             "|---|---|---|---|---|---|---|---|---|---|---|---|---|"]
    for row in rows:
        if row["exit_code"] != 0:
            lines.append("| %s | %s | | failed (%s) | | | | | | | | | |" % (row["pair"], row["method"],
                                                                       row["exit_code"] or "no BIM"))
            continue
        for d in ("AB", "BA"):
            m = row["metrics"][d]
            lines.append("| %s | %s | %s | %s | %s | %s | %s | %d | %d | %s (%s) | %s | %s | %s |" % (
                row["pair"] if d == "AB" else "", row["method"] if d == "AB" else "", d,
                fmt(m.get("within_0.05")), fmt(m.get("within_0.1")), fmt(m.get("mean_error")),
                fmt(m.get("max_error")), m["flipped"], m["collapsed"], fmt(m["conformal"]),
                fmt(m["conformal_median"]), fmt(m["area"]), fmt(m.get("reversibility_bbox"), 100),
                fmt(row["seconds"]) if d == "AB" else ""))
    return lines


def targets(rows):
    """(name, met, measured) per target of issue 20 that this bench measures."""
    by = {(r["pair"], r["method"]): r for r in rows}
    ok = lambda r: r is not None and r["exit_code"] == 0
    checks = []
    pairs = []
    for r in rows:
        if r["pair"] not in pairs:
            pairs.append(r["pair"])
    camels = [p for p in pairs if p.startswith("camel")]
    for p in pairs:
        bim, el = by.get((p, "bim")), by.get((p, "elastic"))
        if p in FIXED:
            if not (ok(bim) and ok(el)):
                checks.append(("%s runs" % p, False, "failed"))
                continue
            b, e = bim["metrics"], el["metrics"]
            checks.append(("%s: elastic lowers the mean error" % p, e["AB"]["mean_error"] < b["AB"]["mean_error"],
                           "%.4g -> %.4g" % (b["AB"]["mean_error"], e["AB"]["mean_error"])))
            for d in ("AB", "BA"):
                for key in ("flipped", "collapsed"):
                    checks.append(("%s %s: elastic no more %s triangles" % (p, d, key), e[d][key] <= b[d][key],
                                   "%d -> %d" % (b[d][key], e[d][key])))
                for key, what in (("conformal", "conformal"), ("area", "area")):
                    checks.append(("%s %s: elastic lowers %s distortion" % (p, d, what), e[d][key] < b[d][key],
                                   "%.4g -> %.4g" % (b[d][key], e[d][key])))
        if p == "cat-lion" and ok(el):
            m = el["metrics"]["AB"]
            checks.append(("cat-lion after elastic: within 0.1 >= 0.90", m["within_0.1"] >= 0.90,
                           "%.2f" % m["within_0.1"]))
            checks.append(("cat-lion after elastic: max error <= 0.25", m["max_error"] <= 0.25,
                           "%.3f" % m["max_error"]))
    if camels:
        mapped = [p for p in camels if ok(by.get((p, "bim"))) and ok(by.get((p, "elastic")))]
        checks.append(("camel: every pair maps (%d pairs)" % len(camels), len(mapped) == len(camels),
                       "%d of %d" % (len(mapped), len(camels))))
        clean = [p for p in mapped if all(by[(p, "elastic")]["metrics"][d][k] == 0
                                          for d in ("AB", "BA") for k in ("flipped", "collapsed"))]
        worst = max((sum(by[(p, "elastic")]["metrics"][d][k] for d in ("AB", "BA") for k in ("flipped", "collapsed"))
                     for p in mapped), default=0)
        checks.append(("camel after elastic: no flipped or collapsed triangles (on the input meshes)",
                       len(clean) == len(camels),
                       "%d of %d pairs clean; worst pair %d (both directions)" % (len(clean), len(camels), worst)))
        # The same count on the surfaces the method maps (after the input repairs: report.json's
        # metrics). The input meshes count faces that no map can fix: a face repeated with the
        # opposite orientation (one of the two is always turned over) and the faces of a
        # floating piece that the repair set aside (mapped through the nearest point).
        rep = [by[(p, "elastic")].get("repaired_bad") for p in mapped]
        if all(r is not None for r in rep):
            clean_r = sum(1 for r in rep if r["AB"] == 0 and r["BA"] == 0)
            checks.append(("camel after elastic: no flipped or collapsed triangles (after repair)",
                           clean_r == len(camels),
                           "%d of %d pairs clean; worst pair %d (both directions)"
                           % (clean_r, len(camels), max(r["AB"] + r["BA"] for r in rep))))
        rev = [by[(p, "elastic")]["metrics"]["AB"]["reversibility_bbox"] for p in mapped]
        if rev:
            checks.append(("camel after elastic: round trip AB then BA within 0.5% of the bbox diagonal",
                           max(rev) <= 0.005, "mean per pair %.3g%% .. %.3g%%" % (100 * min(rev), 100 * max(rev))))
    for p in pairs:
        if p not in NO_TRUTH or not (ok(by.get((p, "bim"))) and ok(by.get((p, "elastic")))):
            continue
        b, e = by[(p, "bim")], by[(p, "elastic")]
        for d in ("AB", "BA"):  # issue 20's guard: never more folds than the start
            nb = b["metrics"][d]["flipped"] + b["metrics"][d]["collapsed"]
            ne = e["metrics"][d]["flipped"] + e["metrics"][d]["collapsed"]
            checks.append(("%s %s: elastic no more flipped + collapsed triangles than BIM" % (p, d), ne <= nb,
                           "%d -> %d" % (nb, ne)))
        if p == "glasses":
            for m, row in (("BIM", b), ("elastic", e)):
                f = row.get("arms_on_their_own_arm")
                checks.append(("glasses %s: each arm onto its own arm (>= 90%% of its vertices, both directions)" % m,
                               f is not None and f >= 0.9, "worst arm %s" % ("–" if f is None else "%.0f%%" % (100 * f))))
            # BIM collapses the arms (its conformal maps on thin parts): its spread is shown, not judged.
            f, fb = e.get("arm_spread"), b.get("arm_spread")
            checks.append(("glasses elastic: no arm collapsed (arm spread >= 0.2: 0.8 when arc length is kept, "
                           "about 0 when an arm lands on a point; both directions)", f is not None and f >= 0.2,
                           "worst arm %s (BIM %s)" % tuple("–" if x is None else "%.2f" % x for x in (f, fb))))
        if p.startswith("busts"):
            for m, row in (("BIM", b), ("elastic", e)):
                f = row.get("heads_up")
                checks.append(("%s %s: heads up (>= 90%% of each bust's top and bottom 15%% in the same half of the "
                               "other, both directions)" % (p, m), f is not None and f >= 0.9,
                               "worst %s" % ("–" if f is None else "%.0f%%" % (100 * f))))
    if ok(by.get(("airplane-bird", "bim"))) and ok(by.get(("airplane-bird", "elastic"))):
        b, e = by[("airplane-bird", "bim")]["metrics"], by[("airplane-bird", "elastic")]["metrics"]
        for d in ("AB", "BA"):
            checks.append(("airplane-bird %s: no more collapsed triangles than the initial map" % d,
                           e[d]["collapsed"] <= b[d]["collapsed"],
                           "%d -> %d" % (b[d]["collapsed"], e[d]["collapsed"])))
    return checks


def main():
    ap = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    ap.add_argument("--pairs", default="cat-lion,airplane-bird,camel-01")
    ap.add_argument("--build", default=os.environ.get("BUILD", os.path.join(ROOT, "build")))
    ap.add_argument("--work", default=os.path.join(ROOT, "bench", "out", "surface_real"))
    ap.add_argument("--threads", type=int, default=None, help="shapemap --threads (default: the tool's)")
    ap.add_argument("--fresh", action="store_true", help="recompute cached pairs")
    ap.add_argument("--any-binary", action="store_true",
                    help="use cached rows made by another shapemap binary (row.json: binary)")
    ap.add_argument("--extra", default="", help="more surface-map arguments (BIM and elastic); "
                    "use another --work, the cache does not know them")
    ap.add_argument("--caption", default="", help="a line printed above the table")
    args = ap.parse_args()
    data = os.environ.get("SHAPEMAP_DATA", os.path.join(ROOT, "..", "shared", "data"))
    names = expand_pairs(args.pairs)
    unknown = [n for n in names if pair_files(n) is None]
    if unknown:
        sys.exit("bench: unknown pair %s (cat-lion, airplane-bird, glasses, busts, camel-II-JJ, camel-01, "
                 "camel-all, all)"
                 % unknown[0])
    os.makedirs(args.work, exist_ok=True)
    r = Runner(args.build, args.work, args.threads)
    if not os.access(r.bin, os.X_OK):
        sys.exit("bench: %s not found (make build first)" % r.bin)
    if not os.path.isdir(data):
        print("bench: skipped, no %s (set SHAPEMAP_DATA)" % data, file=sys.stderr)
        sys.exit(0)
    # Run a copy, so that a rebuild during a long run does not mix two versions.
    binhash = file_hash(r.bin)
    copy = os.path.join(args.work, "shapemap." + binhash)
    if not os.path.exists(copy):  # under a temporary name first: two benches may start at once
        tmp = "%s.%d" % (copy, os.getpid())
        shutil.copy2(r.bin, tmp)
        os.replace(tmp, copy)
    r.bin = copy
    rows = []
    for name in names:
        rows.extend(run_pair(r, data, args.work, name, binhash, args.fresh, args.any_binary,
                             shlex.split(args.extra)))
    add_repaired_counts(rows, args.work)
    json.dump(rows, open(os.path.join(args.work, "results.json"), "w"), indent=1)
    checks = targets(rows)
    lines = ([args.caption, ""] if args.caption else []) + table(rows)
    lines += ["", "| target | met | measured |", "|---|---|---|"]
    lines += ["| %s | %s | %s |" % (n, "PASS" if ok else "FAIL", v) for n, ok, v in checks]
    missed = sum(1 for c in checks if not c[1])
    lines += ["", "%d of %d targets met" % (len(checks) - missed, len(checks))]
    text = "\n".join(lines) + "\n"
    open(os.path.join(args.work, "surface_real.md"), "w").write(text)
    print(text)
    failed = sum(1 for row in rows if row["exit_code"] != 0)
    sys.exit(1 if failed or missed else 0)


if __name__ == "__main__":
    main()
