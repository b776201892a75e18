# Fixtures of the Python tests: the shapemap binary (SHAPEMAP_BINARY, set by ctest) and small
# generated inputs, made once per session.
import os
import subprocess

import pytest


@pytest.fixture(scope="session")
def cli():
    exe = os.environ.get("SHAPEMAP_BINARY")
    if not exe or not os.path.exists(exe):
        pytest.skip("SHAPEMAP_BINARY not set (run through ctest)")

    def run(*args, check=True):
        r = subprocess.run([exe, "--quiet", *map(str, args)], capture_output=True, text=True)
        if check and r.returncode != 0:
            raise AssertionError(f"shapemap {' '.join(map(str, args))}: exit {r.returncode}: {r.stderr}")
        return r
    run.exe = exe
    return run


@pytest.fixture(scope="session")
def pair(cli, tmp_path_factory):
    """A near-isometric pair of ~1000-vertex surfaces with ground truth, and its tet meshes."""
    d = tmp_path_factory.mktemp("pair")
    cli("generate", "--shape", "pair", "--kind", "near-isometric", "--vertices", 1000, "--seed", 2,
        "--tets", "--tet-count", 1500, "-o", d / "p")
    return d / "p"
