# Ctrl-C during a long call: SIGINT to the own process from a timer thread; the call stops
# with KeyboardInterrupt, soon, and the module stays usable.
import os
import signal
import threading
import time

import pytest

import shapemap


def test_ctrl_c_raises_keyboard_interrupt(pair):
    VA, FA = shapemap.read_surface(pair / "A.obj")
    VB, FB = shapemap.read_surface(pair / "B.obj")
    timer = threading.Timer(1.0, lambda: os.kill(os.getpid(), signal.SIGINT))
    t0 = time.perf_counter()
    timer.start()
    with pytest.raises(KeyboardInterrupt):
        # Elastic refinement with many iterations: far longer than the timer.
        shapemap.surface_map(VA, FA, VB, FB, method="elastic", elastic_iterations=100000)
    timer.cancel()
    assert time.perf_counter() - t0 < 30
    # Still usable after the interrupt.
    m = shapemap.surface_map(VA, FA, VB, FB, samples=64, candidates=200)
    assert len(m) == len(VA)
