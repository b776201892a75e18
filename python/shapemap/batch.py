"""shapemap batch: maps over whole shape collections on Dask distributed.

    python3 -m shapemap.batch SHAPE... -o DIR --method bim|elastic|volume|register
        [--pairs all|FILE.csv] [--landmarks-dir D] [--truth-dir D] [--workers N]
        [--threads-per-worker T] [--worker-processes] [--scheduler tcp://HOST:PORT] [--tets N]
        [--seed S] [--symmetric] [--quiet]

(`shapemap batch ...` runs this.) Without --scheduler a local cluster of N workers is
started (threads of this process for bim and elastic, worker processes for volume and
register or with --worker-processes); with it, the tasks go to a running cluster
(dask-scheduler and dask-worker on any machines that see DIR and the shapes at the same paths).

Per-shape work is done once per shape, as one task, and cached in DIR/shapes/<name>/
(reading and checks; for volume and register the tetrahedralization of surface inputs), so
a rerun reuses it. The task's result holds the shape's arrays for the pairs (read once per
batch) and, for bim and elastic without landmarks, BIM's per-surface stage (prepare_surface:
geodesics, features, flattening), done once per shape and batch and shared by every pair
that uses the shape (pickled to the workers that need it; saved in DIR/shapes/<name>/ too).
The driver hands out the tasks itself, one per worker thread at a time (class Schedule):
shapes first, then each pair once its two shapes are ready, the costliest first.
Each pair is a task writing DIR/<A>__<B>/ (map_AB.txt [map_BA.txt], A_on_B.<obj|vtk>
[B_on_A], report.json; volume/register: A.vtk, B.vtk, the meshes the maps index) under a
temporary name, renamed when complete. A rerun skips pairs whose folder is complete. A
failing pair is recorded with its error and the others go on. DIR/summary.csv and
DIR/summary.html list per pair the status (ok, failed, skipped), the time and the metrics;
DIR/summary.json has the totals, the preparation counts and the timeline: per task its
worker, start, end and CPU seconds, and the driver's moments (task_timeline() sums it up).
Exit code:
0 when no pair failed, 1 otherwise, 2 for bad arguments.
"""
import argparse
import csv
import heapq
import html
import json
import os
import shutil
import sys
import threading
import time

SURFACE_EXT = (".obj", ".off", ".ply", ".stl")
VOLUME_EXT = (".vtk", ".mesh", ".msh", ".node", ".ele")
METHODS = ("bim", "elastic", "volume", "register")
SURFACE_METRICS = ("conformal_distortion_mean", "area_distortion_mean_abs", "flipped_triangles",
                   "degenerate_triangles", "reversibility", "geodesic_error_mean", "geodesic_within_0_1")
VOLUME_METRICS = ("n_inv", "d_avg_hat", "d_max_hat", "det_J_mean", "det_J_sd", "E_ARAP", "truth_error_mean")


def shape_name(path):
    return os.path.splitext(os.path.basename(path))[0]


def _worker_id():
    """The Dask worker running the current task (its address), or this process and thread.
    Never imports distributed: a shape task that runs while the driver imports it would wait
    for the whole import."""
    get_worker = getattr(sys.modules.get("distributed"), "get_worker", None)
    try:
        return get_worker().address
    except (TypeError, ValueError):  # no distributed (yet), or not in a worker
        return f"pid{os.getpid()}-{threading.get_ident()}"


def _timing(kind, name, start, cpu):
    """A task's record for summary.json: kind (shape, pair), shape or pair name, the worker,
    its start and end (wall clock, time.time(): one clock for all local workers) and the CPU
    seconds of its thread (`start`, `cpu`: time.time() and time.thread_time() at its start).
    cpu well below end - start: the task waited (a lock, or other programs on the cores)."""
    end, cpu = time.time(), time.thread_time() - cpu
    return {"kind": kind, "name": name, "worker": _worker_id(), "start": start, "end": end, "cpu": cpu}


# ---- tasks (run on the workers) ---------------------------------------------------------

def prepare_shape(path, cache, method, tets, seed):
    """Reads and checks one shape (tetrahedralizes surfaces for volume methods), once: the
    result is cached in `cache` (a folder); a second call only reads prep.json."""
    import numpy as np
    import shapemap
    info_path = os.path.join(cache, "prep.json")
    if os.path.exists(info_path):
        with open(info_path) as f:
            info = json.load(f)
        info["prepared"] = False
        return info
    os.makedirs(cache, exist_ok=True)
    t0 = time.perf_counter()
    info = {"shape": path, "status": "ok", "error": ""}
    try:
        if path.lower().endswith(VOLUME_EXT):
            if method in ("bim", "elastic"):
                raise shapemap.InputError(f"{path}: a tet mesh; --method {method} maps surfaces")
            V, T = shapemap.read_volume(path)
            np.savez(os.path.join(cache, "volume.npz"), V=V, T=T)
        elif path.lower().endswith(SURFACE_EXT):
            V, F = shapemap.read_surface(path)
            np.savez(os.path.join(cache, "surface.npz"), V=V, F=F)
            if method in ("volume", "register"):
                VT, T = shapemap.tetrahedralize(V, F, tets=tets, seed=seed)
                np.savez(os.path.join(cache, "volume.npz"), V=VT, T=T)
        else:
            raise shapemap.InputError(f"{path}: unknown extension (surface: .obj .off .ply .stl; "
                                      "tet mesh: .vtk .mesh .msh .node .ele)")
    except (ValueError, RuntimeError, OSError) as e:
        info.update(status="failed", error=str(e))
    info["seconds"] = time.perf_counter() - t0
    with open(info_path + ".tmp", "w") as f:
        json.dump(info, f)
    os.replace(info_path + ".tmp", info_path)
    info["prepared"] = True
    return info


def _load(prep, cache, kind):
    import numpy as np
    if prep["status"] != "ok":
        raise ValueError(prep["error"])
    d = np.load(os.path.join(cache, kind + ".npz"))
    return (d["V"], d["F"]) if kind == "surface" else (d["V"], d["T"])


def _landmarks(d, a, b):
    import numpy as np
    if not d:
        return None
    fa, fb = os.path.join(d, a + ".txt"), os.path.join(d, b + ".txt")
    for f in (fa, fb):
        if not os.path.exists(f):
            raise ValueError(f"{f}: no landmark file (--landmarks-dir needs <shape>.txt per shape)")
    return (np.loadtxt(fa, dtype=int, ndmin=1).tolist(), np.loadtxt(fb, dtype=int, ndmin=1).tolist())


def _bim_prepared(path, mesh, cache, seed, threads):
    """BIM's per-surface stage of one shape: from the cache file of an earlier batch, else
    computed (and saved). Returns (prepared surface, computed now)."""
    import pickle
    import shapemap
    f = os.path.join(cache, f"bim-seed{seed}.pickle")
    if os.path.exists(f):
        try:
            with open(f, "rb") as fh:
                return pickle.load(fh), False
        except (OSError, RuntimeError, pickle.UnpicklingError, EOFError):
            pass  # another format version or a torn file: prepare again
    p = shapemap.prepare_surface(*mesh, seed=seed, name=path, threads=threads)
    with open(f + ".tmp", "wb") as fh:
        pickle.dump(p, fh, protocol=pickle.HIGHEST_PROTOCOL)
    os.replace(f + ".tmp", f)
    return p, True


def load_shape(prep, cache, method, seed, bim, threads=1):
    """One shape for its pairs, once per batch: its arrays (not read again per pair) and,
    with `bim`, its prepared surface for BIM. Never raises: a failure is returned and
    reported by the shape's pairs."""
    t0 = time.perf_counter()
    data = {"status": prep["status"], "error": prep["error"], "mesh": None, "prepared": None, "bim": None}
    if prep["status"] != "ok":
        data["seconds"] = time.perf_counter() - t0
        return data
    try:
        data["mesh"] = _load(prep, cache, "surface" if method in ("bim", "elastic") else "volume")
        if bim:
            data["prepared"], fresh = _bim_prepared(prep["shape"], data["mesh"], cache, seed, threads)
            # An id per preparation: the summary counts distinct ids (once per shape and batch).
            data["bim"] = {"id": f"{os.getpid()}-{time.time_ns()}", "computed": fresh}
    except (ValueError, RuntimeError, OSError, MemoryError) as e:
        data.update(status="failed", error=" ".join(str(e).split()))
    data["seconds"] = time.perf_counter() - t0
    return data


def shape_task(path, cache, method, tets, seed, bim, threads):
    """All the per-shape work of one shape, one task: prepare_shape then load_shape. Returns
    load_shape's result with the preparation info ("prep") and the task's record ("task");
    shape_info() gives the driver the small part of it."""
    start, cpu = time.time(), time.thread_time()
    prep = prepare_shape(path, cache, method, tets, seed)
    data = load_shape(prep, cache, method, seed, bim, threads)
    data["prep"] = prep
    p = data["prepared"]
    data["features"] = p.num_features if p is not None else 0
    data["vertices"] = len(data["mesh"][0]) if data["mesh"] is not None else 0
    data["task"] = _timing("shape", shape_name(path), start, cpu)
    return data


def shape_info(data):
    """The small part of a shape_task result, for the driver (the arrays and the prepared
    surface stay on the workers)."""
    return {k: data.get(k) for k in ("prep", "status", "error", "seconds", "bim", "features", "vertices", "task")}


def _compute(job, shapeA, shapeB):
    """The map of one pair; returns (map, meshes A and B, element kind)."""
    import shapemap
    a, b, o = job["A"], job["B"], job["options"]
    lm = _landmarks(o["landmarks_dir"], a, b)
    if o["method"] in ("bim", "elastic"):
        (VA, FA), (VB, FB) = shapeA["mesh"], shapeB["mesh"]
        truth = None
        tf = os.path.join(o["truth_dir"], f"{a}__{b}.txt") if o["truth_dir"] else None
        if tf and os.path.exists(tf):
            truth = shapemap.read_map(tf)
        prepared = None
        if not lm:  # BIM, or elastic's BIM initial maps
            prepared = (shapeA["prepared"], shapeB["prepared"])
        m = shapemap.surface_map(VA, FA, VB, FB, method=o["method"], landmarks=lm, truth=truth, prepared=prepared,
                                 symmetric=o["symmetric"], seed=o["seed"], threads=o["threads"],
                                 names=(job["pathA"], job["pathB"]))
        return m, (VA, FA), (VB, FB), "surface"
    (VA, TA), (VB, TB) = shapeA["mesh"], shapeB["mesh"]
    if o["method"] == "volume":
        # volume-map's default initialization (landmarks, or auto guided by fewer than 20 pairs).
        m = shapemap.volume_map(VA, TA, VB, TB, landmarks=lm,
                                seed=o["seed"], threads=o["threads"], names=(job["pathA"], job["pathB"]))
    else:
        m = shapemap.register(VA, TA, VB, TB, threads=o["threads"])
    return m, (VA, TA), (VB, TB), "volume"


def _write_pair(tmp, m, A, B, kind, report):
    import shapemap
    shapemap.write_map(os.path.join(tmp, "map_AB.txt"), m)
    write, ext = (shapemap.write_surface, ".obj") if kind == "surface" else (shapemap.write_volume, ".vtk")
    write(os.path.join(tmp, "A_on_B" + ext), m.points(), A[1])
    if m.reverse is not None:
        shapemap.write_map(os.path.join(tmp, "map_BA.txt"), m.reverse)
        write(os.path.join(tmp, "B_on_A" + ext), m.reverse.points(), B[1])
    if kind == "volume":  # the tet meshes the maps index
        shapemap.write_volume(os.path.join(tmp, "A.vtk"), *A)
        shapemap.write_volume(os.path.join(tmp, "B.vtk"), *B)
    with open(os.path.join(tmp, "report.json"), "w") as f:
        json.dump(report, f, indent=1)


def run_pair(job, shapeA, shapeB):
    """One pair from its shapes (load_shape): computes the map and writes DIR/A__B/
    (temporary name, then renamed). Never raises for a failing pair: returns its status and
    error."""
    t0, start, cpu = time.perf_counter(), time.time(), time.thread_time()
    out = job["out"]
    tmp = f"{out}.tmp-{os.getpid()}-{threading.get_ident()}"  # workers may be threads
    # The shape tasks this pair used, for the summary (BIM preparation ids, task seconds).
    used = {n: {"bim": d["bim"]} for n, d in ((job["A"], shapeA), (job["B"], shapeB))}
    try:
        for d, name in ((shapeA, job["A"]), (shapeB, job["B"])):
            if d["status"] != "ok":
                raise ValueError(d["error"] or f"{name}: preparation failed")
        m, A, B, kind = _compute(job, shapeA, shapeB)
        report = dict(m.report)
        report["batch"] = {"A": job["pathA"], "B": job["pathB"], "method": job["options"]["method"],
                           "seconds": time.perf_counter() - t0}
        shutil.rmtree(tmp, ignore_errors=True)
        os.makedirs(tmp)
        _write_pair(tmp, m, A, B, kind, report)
        os.replace(tmp, out)
        return {"pair": job["pair"], "status": "ok", "seconds": time.perf_counter() - t0, "error": "",
                "metrics": summary_metrics(report), "shapes": used, "task": _timing("pair", job["pair"], start, cpu)}
    except (ValueError, RuntimeError, OSError, MemoryError) as e:
        shutil.rmtree(tmp, ignore_errors=True)
        msg = " ".join(str(e).split())
        return {"pair": job["pair"], "status": "failed", "seconds": time.perf_counter() - t0, "error": msg,
                "metrics": {}, "shapes": used, "task": _timing("pair", job["pair"], start, cpu)}


def summary_metrics(report):
    """The metrics of the A -> B direction that summary.csv lists."""
    met = report.get("metrics", {})
    if "final" in met:  # elastic
        met = met["final"]
    ab = met.get("AB", met)
    keys = SURFACE_METRICS if "conformal_distortion_mean" in ab else VOLUME_METRICS
    return {k: ab[k] for k in keys if k in ab}


# ---- the driver -------------------------------------------------------------------------

class _Parser(argparse.ArgumentParser):
    def error(self, message):  # one line, like every other input error of shapemap
        print(f"shapemap: error: batch: {message} (see --help)", file=sys.stderr)
        sys.exit(2)


def parse_args(argv):
    p = _Parser(prog="shapemap batch", description="Maps over shape collections on Dask.")
    p.add_argument("shapes", nargs="+", metavar="SHAPE", help="surfaces (.obj .off .ply .stl) or tet meshes")
    p.add_argument("-o", "--output", required=True, metavar="DIR")
    p.add_argument("--method", required=True, choices=METHODS)
    p.add_argument("--pairs", default="all", help="all (every unordered pair once) or a CSV of A,B names")
    p.add_argument("--landmarks-dir", default="", help="landmark files <shape>.txt (vertex indices)")
    p.add_argument("--truth-dir", default="", help="ground-truth maps <A>__<B>.txt (surface methods)")
    p.add_argument("--workers", type=int, default=os.cpu_count() or 1, help="local worker processes")
    p.add_argument("--threads-per-worker", type=int, default=1, help="OpenMP threads per task")
    p.add_argument("--worker-processes", action="store_true",
                   help="local workers as processes for bim and elastic too (isolation; slower start)")
    p.add_argument("--scheduler", default="", help="a running Dask scheduler, tcp://HOST:PORT")
    p.add_argument("--tets", type=int, default=0, help="tets per tetrahedralized surface (0: default)")
    p.add_argument("--seed", type=int, default=1)
    p.add_argument("--symmetric", action="store_true", help="bim: also B -> A")
    p.add_argument("--quiet", action="store_true")
    a = p.parse_args(argv)
    if a.workers < 1 or a.threads_per_worker < 1:
        p.error("--workers and --threads-per-worker must be >= 1")
    return a


def read_pairs(spec, names):
    if spec == "all":
        return [(names[i], names[j]) for i in range(len(names)) for j in range(i + 1, len(names))]
    pairs = []
    with open(spec, newline="") as f:
        for row in csv.reader(f):
            row = [shape_name(c.strip()) for c in row if c.strip()]
            if not row or row[0].startswith("#") or row == ["A", "B"]:
                continue
            if len(row) != 2 or row[0] not in names or row[1] not in names:
                raise ValueError(f"{spec}: {','.join(row)}: expected two of the given shapes' names")
            pairs.append((row[0], row[1]))
    return pairs


class Progress:
    """Pairs done of the total: a bar on a terminal, a line per pair otherwise."""

    def __init__(self, total, quiet):
        self.total, self.done, self.quiet = total, 0, quiet
        self.tty = sys.stderr.isatty()

    def pair(self, r):
        self.done += 1
        if self.quiet:
            return
        line = f"[{self.done}/{self.total}] {r['pair']} {r['status']} {r['seconds']:.1f} s"
        if r["error"]:
            line += f": {r['error']}"
        if self.tty:
            fill = 30 * self.done // max(1, self.total)
            sys.stderr.write(f"\r\033[K{line}\n[{'#' * fill}{' ' * (30 - fill)}] {self.done}/{self.total}")
            if self.done == self.total:
                sys.stderr.write("\n")
        else:
            sys.stderr.write(line + "\n")
        sys.stderr.flush()


def _worker_processes(a):
    """Local workers as processes (else threads of this process)."""
    return a.worker_processes or a.method in ("volume", "register")


class SchedulerUnreachable(Exception):
    """--scheduler names no Dask scheduler that answers."""


def start_client(a):
    from dask.distributed import Client, LocalCluster
    import logging
    if a.scheduler:
        try:
            return Client(a.scheduler), None
        except OSError as e:  # Dask's connect timeout
            raise SchedulerUnreachable(str(e)) from e
    os.environ.setdefault("OMP_WAIT_POLICY", "passive")  # inherited by the worker processes
    os.environ["OMP_NUM_THREADS"] = str(a.threads_per_worker)  # also for calls without threads=
    # Worker threads in this process start in ~0.1 s instead of ~1-3 s for processes, and
    # the shapes' arrays and prepared surfaces are shared without pickling: the surface
    # methods release the GIL and their solvers are thread-safe. Volume methods keep
    # processes: their supernodal factorizations share one BLAS lock within a process.
    processes = _worker_processes(a)
    cluster = LocalCluster(n_workers=a.workers, threads_per_worker=1, processes=processes,
                           dashboard_address=None, silence_logs=logging.ERROR)
    return Client(cluster), cluster


def make_jobs(a, paths, pairs):
    out = os.path.abspath(a.output)
    options = {"method": a.method, "landmarks_dir": a.landmarks_dir, "truth_dir": a.truth_dir,
               "symmetric": a.symmetric, "seed": a.seed, "threads": a.threads_per_worker}
    jobs, skipped = [], []
    for x, y in pairs:
        job = {"pair": f"{x}__{y}", "A": x, "B": y, "pathA": paths[x], "pathB": paths[y],
               "out": os.path.join(out, f"{x}__{y}"), "cacheA": os.path.join(out, "shapes", x),
               "cacheB": os.path.join(out, "shapes", y), "options": options}
        (skipped if os.path.exists(os.path.join(job["out"], "report.json")) else jobs).append(job)
    return jobs, skipped


def skipped_result(job):
    with open(os.path.join(job["out"], "report.json")) as f:
        rep = json.load(f)
    return {"pair": job["pair"], "status": "skipped", "seconds": rep.get("batch", {}).get("seconds", 0.0),
            "error": "", "metrics": summary_metrics(rep)}


def _choose3(n):
    return n * (n - 1) * (n - 2) // 6 if n >= 3 else 0


def pair_cost(method, infoA, infoB, max_candidates=10000):
    """An estimate of a pair's cost, to run the costliest pairs first (a sort key, not
    seconds). BIM's time grows with its candidate maps (Sec. 4: 6 C(nA,3) C(nB,3) from the
    two surfaces' feature counts, at most max_candidates) and the pairs of them it compares,
    then with the meshes' size; the other methods grow with the meshes' size."""
    k = min(6 * _choose3(infoA.get("features") or 0) * _choose3(infoB.get("features") or 0), max_candidates)
    size = (infoA.get("vertices") or 0) + (infoB.get("vertices") or 0)
    return (k, size) if method == "bim" else (size, k)


class Schedule:
    """The order of a batch's tasks, decided in the driver (list scheduling): whenever a
    worker has a free slot it gets the first of
      1. the shape tasks not yet started, largest input file first (they unlock the pairs, and
         their results tell what each pair will cost);
      2. the pairs whose two shapes are ready, costliest first (pair_cost): long pairs start
         early instead of being left alone at the end while the other workers idle.
    Dask's own placement would queue a pair behind a long task on the worker that holds its
    shapes; here no worker holds more tasks than it has slots, so none waits behind another."""

    def __init__(self, method, shapes, jobs, sizes=None):
        sizes = sizes or {}
        self.method = method
        self.shapes = sorted(shapes, key=lambda n: -sizes.get(n, 0))  # stable: given order on ties
        self.by_shape = {}  # shape -> its pairs still waiting for a shape
        for j in jobs:
            self.by_shape.setdefault(j["A"], []).append(j)
            if j["B"] != j["A"]:
                self.by_shape.setdefault(j["B"], []).append(j)
        self.waiting = len(jobs)  # pairs not ready yet
        self.ready = []  # heap of (negated cost, order of arrival, pair) of the ready pairs
        self.arrived = 0
        self.info = {}

    def shape_done(self, name, info):
        """Shape `name` is ready (info: shape_info's dict); its pairs may become ready."""
        self.info[name] = info
        for j in self.by_shape.pop(name, []):
            other = j["B"] if j["A"] == name else j["A"]
            if other in self.info:
                cost = pair_cost(self.method, self.info[j["A"]], self.info[j["B"]])
                heapq.heappush(self.ready, (tuple(-c for c in cost), self.arrived, dict(j, cost=cost)))
                self.arrived += 1
                self.waiting -= 1

    def next(self):
        """("shape", name), ("pair", job), or None (nothing can start now)."""
        if self.shapes:
            return "shape", self.shapes.pop(0)
        if self.ready:
            return "pair", heapq.heappop(self.ready)[2]
        return None

    def __bool__(self):
        return bool(self.shapes or self.ready or self.waiting)


def _worker_slots(client):
    """{worker address: threads} of the cluster's running workers."""
    return {w: d.get("nthreads", 1) for w, d in client.scheduler_info().get("workers", {}).items()}


def run_batch(a, paths, pairs, progress, driver):
    """Runs the shape tasks and the pairs on Dask in the order of Schedule, at most one task per
    worker thread at a time; returns (results, shape infos). Records its moments
    (time.time()) in `driver`."""
    jobs, skipped = make_jobs(a, paths, pairs)
    results = [skipped_result(j) for j in skipped]
    for r in results:
        progress.pair(r)
    infos = {}
    if not jobs:
        return results, infos
    needed = sorted({j["A"] for j in jobs} | {j["B"] for j in jobs})
    out = os.path.abspath(a.output)
    bim = a.method in ("bim", "elastic") and not a.landmarks_dir  # BIM's stage serves these pairs
    sizes = {}
    for n in needed:
        try:
            sizes[n] = os.path.getsize(paths[n])
        except OSError:
            sizes[n] = 0
    schedule = Schedule(a.method, needed, jobs, sizes)
    # A local cluster of worker threads lives in this process: until it is up (Dask's import
    # and start: ~0.3 s on an idle machine, more under load), threads of its own, one per
    # worker, run the first shape tasks; each counts as a task of the worker it is given to.
    early, lock, up = [], threading.Lock(), threading.Event()

    def early_shapes(k):
        while not up.is_set():
            with lock:
                t = schedule.next() if schedule.shapes else None
            if t is None:
                return
            n = t[1]
            try:
                data = shape_task(paths[n], os.path.join(out, "shapes", n), a.method, a.tets, a.seed, bim,
                                  a.threads_per_worker)
            except BaseException as e:  # raised in the driver below, like a failed Dask task
                data = e
            early.append((k, n, data))
            if isinstance(data, BaseException):
                return

    threads = []
    if not a.scheduler and not _worker_processes(a):
        threads = [threading.Thread(target=early_shapes, args=(k,), daemon=True) for k in range(a.workers)]
        for t in threads:
            t.start()
    futures = []
    shape_futures = {}  # name -> future of shape_task (its data stays on the workers)
    try:
        from dask.distributed import as_completed
        driver["imported"] = time.time()
        client, cluster = start_client(a)
        driver["cluster"] = time.time()
    finally:
        up.set()
        for t in threads:
            t.join()
    try:
        client.wait_for_workers(1)
        meta = {}  # future -> (kind, name, worker it was given to)
        busy = {}  # worker -> tasks given to it and not finished
        done = as_completed()
        workers = sorted(_worker_slots(client))
        for k, n, data in early:  # to the cluster: the data stays in this process
            if isinstance(data, BaseException):
                raise data
            w = workers[k % len(workers)]
            data["task"]["worker"] = w
            shape_futures[n] = client.scatter([data], workers=[w], hash=False)[0]
            infos[n] = shape_info(data)
            schedule.shape_done(n, infos[n])

        def dispatch():
            slots = _worker_slots(client)
            for w in slots:
                busy.setdefault(w, 0)
            for w in sorted(slots, key=lambda w: busy[w] - slots[w]):
                while busy[w] < slots[w]:
                    t = schedule.next()
                    if t is None:
                        return
                    where = dict(workers=[w], allow_other_workers=True)
                    stamp = time.time_ns()
                    if t[0] == "shape":
                        n = t[1]
                        f = client.submit(shape_task, paths[n], os.path.join(out, "shapes", n), a.method,
                                          a.tets, a.seed, bim, a.threads_per_worker, key=f"shape-{n}-{stamp}",
                                          pure=False, **where)
                        shape_futures[n] = f
                        f = client.submit(shape_info, f, key=f"shape-info-{n}-{stamp}", pure=False, **where)
                    else:
                        j = t[1]
                        n = j["pair"]
                        f = client.submit(run_pair, j, shape_futures[j["A"]], shape_futures[j["B"]],
                                          key=f"pair-{n}-{stamp}", pure=False, **where)
                    meta[f] = (t[0], n, w)
                    busy[w] += 1
                    futures.append(f)
                    done.add(f)

        dispatch()
        for fut in done:
            kind, name, w = meta.pop(fut)
            busy[w] -= 1
            r = fut.result()
            if kind == "shape":
                infos[name] = r
                schedule.shape_done(name, r)
            else:
                results.append(r)
                progress.pair(r)
            dispatch()
        if schedule:
            raise RuntimeError("batch: tasks left unscheduled (a bug)")
        driver["tasks_done"] = time.time()
    except KeyboardInterrupt:
        # Drop the queued tasks: closing waits only for the running ones (worker threads
        # do not see Ctrl-C).
        client.cancel(futures + list(shape_futures.values()))
        raise
    finally:
        client.close()
        if cluster is not None:
            cluster.close()
    driver["closed"] = time.time()
    return results, infos


def task_timeline(summary, start=None, end=None):
    """What the per-task records of a summary.json say about a batch's use of its workers.

    start, end: wall-clock bounds of the run (default: the driver's process start and its
    end as summary.json records them). Returns a dict:
      workers       the workers that ran tasks
      busy          worker-seconds inside tasks
      cpu           CPU seconds of the tasks' threads (busy - cpu: waiting for a core or a lock)
      utilization   busy / ((end - start) x workers)
      head          start -> the first task's start (Python, imports, cluster start)
      tail          the moment the last-but-one worker ran out of tasks -> end (the last
                    tasks alone, then results, summary files, cluster shutdown, exit)
      task_seconds  the sum of task durations per kind (prepare, shape, pair)
    """
    tasks = summary.get("tasks", [])
    d = summary.get("driver", {})
    if start is None:
        start = d.get("process_start") or d.get("start")
    end = d.get("end") if end is None else end
    last = {}
    for t in tasks:
        last[t["worker"]] = max(last.get(t["worker"], t["end"]), t["end"])
    busy = sum(t["end"] - t["start"] for t in tasks)
    kinds = {}
    for t in tasks:
        kinds[t["kind"]] = kinds.get(t["kind"], 0.0) + t["end"] - t["start"]
    ends = sorted(last.values())
    n = max(1, summary.get("workers") or len(last))
    return {"workers": len(last), "busy": busy, "cpu": sum(t.get("cpu", 0.0) for t in tasks),
            "utilization": busy / ((end - start) * n) if tasks and end > start else 0.0,
            "head": min(t["start"] for t in tasks) - start if tasks else 0.0,
            "tail": end - (ends[-2] if len(ends) > 1 and n > 1 else ends[-1]) if tasks else 0.0,
            "task_seconds": kinds}


def _process_start():
    """This process's start (wall clock), from /proc on Linux; None elsewhere."""
    try:
        with open("/proc/self/stat") as f:
            ticks = int(f.read().rsplit(")", 1)[1].split()[19])
        with open("/proc/stat") as f:
            boot = next(int(l.split()[1]) for l in f if l.startswith("btime"))
        return boot + ticks / os.sysconf("SC_CLK_TCK")
    except (OSError, ValueError, IndexError, StopIteration):
        return None


def write_summary(out, a, results, infos, seconds, driver=None):
    """DIR/summary.csv, summary.html and summary.json from the pairs' results and the shape
    tasks' infos (shape_info); returns summary.json's dict."""
    results = sorted(results, key=lambda r: r["pair"])
    preps = {n: i["prep"] for n, i in infos.items()}
    keys = []
    for r in results:
        keys += [k for k in r["metrics"] if k not in keys]
    with open(os.path.join(out, "summary.csv"), "w", newline="") as f:
        w = csv.writer(f)
        w.writerow(["pair", "A", "B", "status", "seconds", "error"] + keys)
        for r in results:
            A, B = r["pair"].split("__", 1)
            w.writerow([r["pair"], A, B, r["status"], f"{r['seconds']:.3f}", r["error"]] +
                       [r["metrics"].get(k, "") for k in keys])
    counts = {s: sum(r["status"] == s for r in results) for s in ("ok", "failed", "skipped")}
    shapes = {n: {k: p[k] for k in ("status", "error", "seconds", "prepared")} for n, p in preps.items()}
    for n, i in infos.items():
        shapes[n].update(load_seconds=i["seconds"] or 0.0, features=i["features"], vertices=i["vertices"])
    bim_ids = {}  # shape -> {preparation id: computed (not read from the cache)}
    for r in results:
        for n, u in r.get("shapes", {}).items():
            if u["bim"]:
                bim_ids.setdefault(n, {})[u["bim"]["id"]] = u["bim"]["computed"]
    for n, ids in bim_ids.items():
        shapes[n]["bim_preparations"] = sum(ids.values())
        shapes[n]["bim_preparations_reused"] = len(ids) - sum(ids.values())
    # Time spent inside this batch's tasks: shape preparations done now, shape tasks, pairs.
    task_seconds = (sum(s["seconds"] for s in shapes.values() if s["prepared"]) +
                    sum(s.get("load_seconds", 0.0) for s in shapes.values()) +
                    sum(r["seconds"] for r in results if r["status"] != "skipped"))
    # Every task of this batch with its worker, start and end (time.time()), shape tasks once.
    tasks = [i["task"] for i in infos.values()] + [r["task"] for r in results if r.get("task")]
    tasks.sort(key=lambda t: t["start"])
    totals = {"method": a.method, "pairs": len(results), **counts, "seconds": seconds,
              "task_seconds": task_seconds, "workers": a.workers if not a.scheduler else None,
              "preparations": sum(1 for p in preps.values() if p.get("prepared")),
              "preparations_reused": sum(1 for p in preps.values() if not p.get("prepared")),
              # BIM's per-surface stage: once per shape and batch, shared by its pairs
              "bim_preparations": sum(s.get("bim_preparations", 0) for s in shapes.values()),
              "bim_preparations_reused": sum(s.get("bim_preparations_reused", 0) for s in shapes.values()),
              "shapes": shapes, "tasks": tasks}
    write_html(out, a, results, keys, totals)
    # The driver's moments (wall clock): process start, main(), Dask imported, cluster up,
    # last result, cluster closed, end (summary files written).
    totals["driver"] = dict(driver or {}, end=time.time())
    with open(os.path.join(out, "summary.json.tmp"), "w") as f:
        json.dump(totals, f, indent=1)
    os.replace(os.path.join(out, "summary.json.tmp"), os.path.join(out, "summary.json"))
    return totals


def write_html(out, a, results, keys, t):
    colour = {"ok": "#dfd", "failed": "#fdd", "skipped": "#eee"}
    rows = []
    for r in results:
        cells = [f'<a href="{html.escape(r["pair"])}/report.json">{html.escape(r["pair"])}</a>'
                 if r["status"] != "failed" else html.escape(r["pair"]),
                 r["status"], f"{r['seconds']:.1f}", html.escape(r["error"])]
        cells += [html.escape(f"{r['metrics'][k]:.4g}" if isinstance(r["metrics"].get(k), float)
                              else str(r["metrics"].get(k, ""))) for k in keys]
        rows.append(f'<tr style="background:{colour[r["status"]]}">' + "".join(f"<td>{c}</td>" for c in cells) + "</tr>")
    head = "".join(f"<th>{html.escape(h)}</th>" for h in ["pair", "status", "seconds", "error"] + keys)
    text = (f"<!DOCTYPE html><html><head><meta charset='utf-8'><title>shapemap batch</title>"
            f"<style>body{{font-family:sans-serif}}td,th{{padding:2px 8px;border-bottom:1px solid #ccc}}</style>"
            f"</head><body><h1>shapemap batch: {html.escape(a.method)}</h1>"
            f"<p>{t['pairs']} pairs: {t['ok']} ok, {t['failed']} failed, {t['skipped']} skipped; "
            f"{t['seconds']:.1f} s; {t['preparations']} shape preparations "
            f"({t['preparations_reused']} reused from an earlier run); "
            f"{t['bim_preparations']} BIM per-surface preparations</p>"
            f"<table><tr>{head}</tr>{''.join(rows)}</table></body></html>\n")
    with open(os.path.join(out, "summary.html"), "w") as f:
        f.write(text)


def _remove_if_made(out, made):
    """A batch that could not start leaves no output folder it created (nothing in it is done)."""
    if made:
        shutil.rmtree(out, ignore_errors=True)


def main(argv=None):
    a = parse_args(sys.argv[1:] if argv is None else argv)
    paths = {}
    for s in a.shapes:
        n = shape_name(s)
        if n in paths:
            print(f"shapemap: error: {s}: two shapes named {n}", file=sys.stderr)
            return 2
        paths[n] = os.path.abspath(s)
    try:
        pairs = read_pairs(a.pairs, list(paths))
    except (OSError, ValueError) as e:
        print(f"shapemap: error: {e}", file=sys.stderr)
        return 2
    out = os.path.abspath(a.output)
    made_out = not os.path.exists(out)
    os.makedirs(os.path.join(out, "shapes"), exist_ok=True)
    t0 = time.perf_counter()
    driver = {"process_start": _process_start(), "start": time.time()}
    progress = Progress(len(pairs), a.quiet)
    try:
        results, infos = run_batch(a, paths, pairs, progress, driver)
    except ImportError as e:
        # Unpickling a task on a worker that cannot import this package (a cluster's workers
        # need shapemap installed, or its build folder on their PYTHONPATH).
        if a.scheduler and "shapemap" in str(e):
            print(f"shapemap: error: {a.scheduler}: a Dask worker cannot import the shapemap package ({e}); "
                  "install it on every worker machine (make install) or start dask-worker with "
                  "PYTHONPATH=<build>/python", file=sys.stderr)
            _remove_if_made(out, made_out)
            return 2
        raise
    except SchedulerUnreachable as e:
        print(f"shapemap: error: {a.scheduler}: cannot reach the Dask scheduler ({e})", file=sys.stderr)
        _remove_if_made(out, made_out)
        return 2
    t = write_summary(out, a, results, infos, time.perf_counter() - t0, driver)
    if not a.quiet:
        print(f"batch: {t['pairs']} pairs, {t['ok']} ok, {t['failed']} failed, {t['skipped']} skipped; "
              f"{t['preparations']} shape preparations, {t['bim_preparations']} BIM preparations; "
              f"{t['seconds']:.1f} s -> {out}/summary.html",
              file=sys.stderr)
    return 1 if t["failed"] else 0


if __name__ == "__main__":
    # The tasks must belong to shapemap.batch (importable on the workers), not to __main__.
    from shapemap.batch import main as batch_main
    code = batch_main()
    # Everything is written and the cluster closed: skip the interpreter's shutdown (Dask's
    # threads and exit hooks, ~0.15 s on an idle machine).
    sys.stdout.flush()
    sys.stderr.flush()
    os._exit(code)
