# shapemap batch on a local Dask cluster of 2 workers: 3 generated shapes, a rerun that
# skips every pair, then a batch with a broken file whose pairs fail alone.
import csv
import json
import subprocess

import pytest


def batch(cli, *args):
    return subprocess.run([cli.exe, "--quiet", "batch", *map(str, args)], capture_output=True, text=True)


def rows(out):
    with open(out / "summary.csv", newline="") as f:
        return {r["pair"]: r for r in csv.DictReader(f)}


@pytest.fixture(scope="module")
def shapes(cli, tmp_path_factory):
    d = tmp_path_factory.mktemp("shapes")
    for k, s in enumerate(("sphere", "ellipsoid", "creature", "cube-sphere")):
        cli("generate", "--shape", s, "--vertices", 500, "--seed", k + 1, "-o", d / f"s{k}.obj")
    (d / "broken.obj").write_text("v 0 0 0\nv 1 0 0\nf 1 2 7\n")
    return d


def test_batch_rerun_and_failures(cli, shapes, tmp_path):
    out = tmp_path / "out"
    three = [shapes / f"s{k}.obj" for k in range(3)]
    r = batch(cli, *three, "-o", out, "--method", "bim", "--workers", 2)
    assert r.returncode == 0, r.stderr
    got = rows(out)
    assert sorted(got) == ["s0__s1", "s0__s2", "s1__s2"]
    assert all(v["status"] == "ok" for v in got.values())
    for p in got:
        for f in ("map_AB.txt", "A_on_B.obj", "report.json"):
            assert (out / p / f).exists(), (p, f)
    assert float(got["s0__s1"]["conformal_distortion_mean"]) >= 0
    summary = json.loads((out / "summary.json").read_text())
    assert summary["preparations"] == 3  # once per shape, not once per pair
    assert summary["bim_preparations"] == 3  # BIM's stage: once per shape, shared by the workers
    assert all(s["bim_preparations"] == 1 for s in summary["shapes"].values())
    assert (out / "summary.html").exists()

    # A rerun skips the finished pairs (no cluster, no preparation).
    r = batch(cli, *three, "-o", out, "--method", "bim", "--workers", 2)
    assert r.returncode == 0, r.stderr
    assert all(v["status"] == "skipped" for v in rows(out).values())

    # A broken file: its pairs fail with its error, the new good pairs go on; exit 1.
    r = batch(cli, *three, shapes / "s3.obj", shapes / "broken.obj", "-o", out, "--method", "bim",
              "--workers", 2)
    assert r.returncode == 1, r.stderr
    got = rows(out)
    assert len(got) == 10
    for p, v in got.items():
        if "broken" in p:
            assert v["status"] == "failed" and "broken.obj" in v["error"], v
            assert not (out / p).exists()
        elif "s3" in p:
            assert v["status"] == "ok", v
        else:
            assert v["status"] == "skipped", v
    summary = json.loads((out / "summary.json").read_text())
    assert summary["preparations"] == 2 and summary["preparations_reused"] == 3


def test_shared_preparations_give_the_direct_maps(cli, shapes, tmp_path):
    # Pairs from BIM preparations shared between worker threads, sent to worker processes
    # (pickled), and read from the cache of an earlier batch: the maps of `shapemap surface-map`.
    three = [shapes / f"s{k}.obj" for k in range(3)]
    direct = tmp_path / "direct"
    cli("--threads", 1, "surface-map", three[0], three[2], "-o", direct)
    want = (direct / "map_AB.txt").read_text()
    for name, extra in (("threads", []), ("processes", ["--worker-processes"])):
        out = tmp_path / name
        r = batch(cli, *three, "-o", out, "--method", "bim", "--workers", 2, *extra)
        assert r.returncode == 0, r.stderr
        assert (out / "s0__s2" / "map_AB.txt").read_text() == want, name
        assert json.loads((out / "summary.json").read_text())["bim_preparations"] == 3, name
    out = tmp_path / "threads"
    (out / "summary.csv").unlink()
    for p in ("s0__s1", "s0__s2", "s1__s2"):
        for f in (out / p).iterdir():
            f.unlink()
        (out / p).rmdir()
    r = batch(cli, *three, "-o", out, "--method", "bim", "--workers", 1)
    assert r.returncode == 0, r.stderr
    summary = json.loads((out / "summary.json").read_text())
    assert summary["bim_preparations"] == 0 and summary["bim_preparations_reused"] == 3
    assert (out / "s0__s2" / "map_AB.txt").read_text() == want


def test_summary_has_a_timeline(cli, shapes, tmp_path):
    # Per task: its worker, start, end and CPU seconds; a worker runs one task at a time;
    # a pair starts after its two shapes are ready.
    out = tmp_path / "out"
    three = [shapes / f"s{k}.obj" for k in range(3)]
    r = batch(cli, *three, "-o", out, "--method", "bim", "--workers", 2)
    assert r.returncode == 0, r.stderr
    s = json.loads((out / "summary.json").read_text())
    tasks = s["tasks"]
    assert sorted(t["name"] for t in tasks if t["kind"] == "shape") == ["s0", "s1", "s2"]
    assert sorted(t["name"] for t in tasks if t["kind"] == "pair") == ["s0__s1", "s0__s2", "s1__s2"]
    assert len({t["worker"] for t in tasks}) <= 2
    for t in tasks:
        assert t["start"] <= t["end"] and t["cpu"] >= 0, t
    for w in {t["worker"] for t in tasks}:
        mine = sorted((t for t in tasks if t["worker"] == w), key=lambda t: t["start"])
        assert all(x["end"] <= y["start"] for x, y in zip(mine, mine[1:])), mine
    ready = {t["name"]: t["end"] for t in tasks if t["kind"] == "shape"}
    for t in tasks:
        if t["kind"] == "pair":
            a, b = t["name"].split("__")
            assert t["start"] >= max(ready[a], ready[b]), t
    d = s["driver"]
    assert d["start"] <= d["imported"] <= d["cluster"] <= d["tasks_done"] <= d["closed"] <= d["end"]
    assert all(v["features"] >= 3 and v["vertices"] > 0 for v in s["shapes"].values())
    from shapemap.batch import task_timeline
    tl = task_timeline(s)
    assert 0 < tl["utilization"] <= 1 and tl["head"] >= 0 and tl["tail"] >= 0
    assert tl["busy"] == pytest.approx(sum(t["end"] - t["start"] for t in tasks))


def test_schedule_order():
    # Shapes first, largest input first; then pairs once both shapes are ready, costliest first.
    from shapemap.batch import Schedule, pair_cost
    jobs = [{"pair": f"{a}__{b}", "A": a, "B": b} for a, b in (("a", "b"), ("a", "c"), ("b", "c"))]
    s = Schedule("bim", ["a", "b", "c"], jobs, sizes={"a": 10, "b": 30, "c": 20})
    assert [s.next(), s.next()] == [("shape", "b"), ("shape", "c")]
    assert s.next() == ("shape", "a") and s.next() is None and s
    s.shape_done("b", {"features": 4, "vertices": 100})
    assert s.next() is None  # no pair has both shapes yet
    s.shape_done("c", {"features": 10, "vertices": 100})
    s.shape_done("a", {"features": 3, "vertices": 5000})
    # candidates 6 C(nA,3) C(nB,3), at most 10000: b-c 2880, a-c 720, a-b 24 (despite a's size)
    assert [s.next()[1]["pair"] for _ in range(3)] == ["b__c", "a__c", "a__b"]
    assert s.next() is None and not s
    assert pair_cost("bim", {"features": 10, "vertices": 1}, {"features": 10, "vertices": 1})[0] == 10000
    # other methods: the meshes' size first
    assert pair_cost("volume", {"features": 0, "vertices": 9}, {"features": 0, "vertices": 1}) > \
        pair_cost("volume", {"features": 0, "vertices": 2}, {"features": 0, "vertices": 2})


def test_schedule_many_shapes():
    # Every pair comes out exactly once, after both its shapes, costliest first among those
    # ready together; fast enough for a few hundred shapes.
    import random
    import time
    from shapemap.batch import Schedule
    names = [f"s{k}" for k in range(300)]
    jobs = [{"pair": f"{a}__{b}", "A": a, "B": b} for i, a in enumerate(names) for b in names[i + 1:]]
    rng = random.Random(1)
    t0 = time.perf_counter()
    s = Schedule("bim", names, jobs)
    shapes = [s.next()[1] for _ in names]
    assert shapes == names  # no sizes: the given order
    rng.shuffle(shapes)
    done, out = set(), []
    for n in shapes:
        s.shape_done(n, {"features": rng.randint(3, 8), "vertices": rng.randint(500, 5000)})
        done.add(n)
        drained = []
        while (t := s.next()) is not None:
            assert t[1]["A"] in done and t[1]["B"] in done
            drained.append(t[1])
        assert all(x["cost"] >= y["cost"] for x, y in zip(drained, drained[1:]))
        out += drained
    assert not s and len(out) == len(jobs) == len({j["pair"] for j in out})
    assert time.perf_counter() - t0 < 10


@pytest.mark.parametrize("method,count", [("register", 3), ("volume", 2)])
def test_volume_methods_prepare_each_shape_once(cli, shapes, tmp_path, method, count):
    # The volume-side methods: each surface tetrahedralized (and, for register, its ball map
    # computed) once per shape and shared by its pairs; both directions written per pair.
    out = tmp_path / method
    some = [shapes / f"s{k}.obj" for k in range(count)]
    r = batch(cli, *some, "-o", out, "--method", method, "--workers", 2, "--tets", 1500)
    assert r.returncode == 0, r.stderr
    got = rows(out)
    assert len(got) == count * (count - 1) // 2
    for p, v in got.items():
        assert v["status"] == "ok", v
        assert float(v["d_avg_hat"]) < 0.05 and 0 < float(v["det_J_mean"]) <= 1.0 + 1e-9, v
        for f in ("map_AB.txt", "map_BA.txt", "report.json", "A_on_B.vtk"):
            assert (out / p / f).exists(), (p, f)
    summary = json.loads((out / "summary.json").read_text())
    assert summary["preparations"] == count and summary["preparations_reused"] == 0
    r = batch(cli, *some, "-o", out, "--method", method, "--workers", 2, "--tets", 1500)
    assert r.returncode == 0 and all(v["status"] == "skipped" for v in rows(out).values())


def _free_port():
    import socket
    with socket.socket() as s:
        s.bind(("127.0.0.1", 0))
        return s.getsockname()[1]


def _wait_for_port(port, seconds=30):
    import socket
    import time
    end = time.time() + seconds
    while time.time() < end:
        with socket.socket() as s:
            if s.connect_ex(("127.0.0.1", port)) == 0:
                return
        time.sleep(0.2)
    raise AssertionError(f"dask-scheduler did not listen on port {port}")


@pytest.mark.parametrize("worker_sees_shapemap", [True, False])
def test_batch_on_a_running_cluster(cli, shapes, tmp_path, worker_sees_shapemap):
    # --scheduler: a dask-scheduler and a dask-worker started apart from the batch, as on a
    # cluster. A worker that cannot import shapemap gives one error line (exit 2, no output).
    import os
    import shutil
    sched_bin, worker_bin = shutil.which("dask-scheduler"), shutil.which("dask-worker")
    assert sched_bin and worker_bin, "python3-distributed's dask-scheduler/dask-worker (scripts/install-deps)"
    port = _free_port()
    env = dict(os.environ)
    env.pop("PYTHONPATH", None)
    if worker_sees_shapemap:
        env["PYTHONPATH"] = os.path.join(os.path.dirname(cli.exe), "python")
    quiet = dict(stdout=subprocess.DEVNULL, stderr=subprocess.DEVNULL)
    sched = subprocess.Popen([sched_bin, "--host", "127.0.0.1", "--port", str(port), "--no-dashboard"], **quiet)
    worker = None
    try:
        _wait_for_port(port)
        worker = subprocess.Popen([worker_bin, f"tcp://127.0.0.1:{port}", "--nworkers", "1", "--nthreads", "1",
                                   "--no-dashboard"], env=env, **quiet)
        out = tmp_path / "out"
        three = [shapes / f"s{k}.obj" for k in range(3)]
        r = batch(cli, *three, "-o", out, "--method", "bim", "--scheduler", f"tcp://127.0.0.1:{port}")
        if worker_sees_shapemap:
            assert r.returncode == 0, r.stderr
            assert all(v["status"] == "ok" for v in rows(out).values()) and len(rows(out)) == 3
            assert json.loads((out / "summary.json").read_text())["preparations"] == 3
        else:
            assert r.returncode == 2, r.stderr
            lines = r.stderr.strip().splitlines()
            assert len(lines) == 1 and "cannot import the shapemap package" in lines[0], r.stderr
            assert not out.exists()
    finally:
        for p in (worker, sched):
            if p:
                p.terminate()
                try:
                    p.wait(timeout=20)
                except subprocess.TimeoutExpired:
                    p.kill()
