"""Long calls release the GIL (two threads' calls run in parallel), report progress on the
calling thread, and stop on Ctrl-C or an exception of the progress callable through the
library's cancellation."""

from __future__ import annotations

import os
import signal
import threading
from pathlib import Path

import numpy as np
import pytest

import skylod


def grid(synth: Path, n: int) -> np.ndarray:
    """``n`` x ``n`` street-level points across the model's box."""
    b = skylod.stats(synth)["bbox"]
    xs = np.linspace(b[0], b[3], n + 2)[1:-1]
    ys = np.linspace(b[1], b[4], n + 2)[1:-1]
    return np.array([[x, y, b[2] + 1.5] for x in xs for y in ys])


def test_progress_is_called_on_the_calling_thread_per_stage(synth, synth_pois):
    calls = []
    me = threading.get_ident()

    def progress(stage, done, total):
        calls.append((stage, done, total, threading.get_ident()))

    skylod.svf(synth, synth_pois, rays=500, progress=progress)
    assert {c[3] for c in calls} == {me}
    stages = [c[0] for c in calls]
    assert stages.index("read") < stages.index("bvh") < stages.index("trace")
    trace = [c for c in calls if c[0] == "trace"]
    assert trace[0][1:3] == (0, 3) and trace[-1][1:3] == (3, 3)
    assert [c[1] for c in trace] == sorted(c[1] for c in trace)


def test_an_exception_in_progress_cancels_and_is_raised(synth):
    pois = grid(synth, 12)
    seen = []

    class Stop(Exception):
        pass

    def progress(stage, done, total):
        seen.append((stage, done, total))
        if stage == "trace" and done >= 1:
            raise Stop("enough")

    with pytest.raises(Stop, match="enough"):
        skylod.svf(synth, pois, rays=20_000, progress=progress)
    # Called no more after it raised.
    assert seen[-1][0] == "trace" and seen[-1][1] >= 1
    # The library is usable again at once.
    assert skylod.svf(synth, pois[:2], rays=500).shape == (2,)


def test_two_threads_run_svf_in_parallel(synth):
    """Thread A starts a long svf; thread B, woken once A is inside it (A's progress called
    while tracing), runs Python and a short svf of its own. With the GIL held by A's call, B
    could not run any Python until A returned. (Whether B's svf ends before A's depends on the
    shared thread pool's scheduling, so it is not asserted.)"""
    big = grid(synth, 14)
    small = grid(synth, 1)
    inside = threading.Event()
    state = {"a_done": False}
    b_result = {}

    def progress(stage, done, total):
        if stage == "trace":
            inside.set()

    def a():
        skylod.svf(synth, big, rays=30_000, progress=progress)
        state["a_done"] = True

    def b():
        assert inside.wait(300)
        b_result["a_done_when_b_ran"] = state["a_done"]
        b_result["svf"] = skylod.svf(synth, small, rays=500)

    ta = threading.Thread(target=a)
    ta.start()
    tb = threading.Thread(target=b)
    tb.start()
    tb.join(600)
    ta.join(600)
    assert state["a_done"]
    assert b_result["svf"].shape == (1,)
    assert b_result["a_done_when_b_ran"] is False


def test_ctrl_c_cancels_through_the_library(synth):
    pois = grid(synth, 14)
    n = len(pois)
    traced = []
    started = threading.Event()

    def progress(stage, done, total):
        if stage == "trace":
            traced.append(done)
            started.set()

    def interrupt():
        if started.wait(300):
            os.kill(os.getpid(), signal.SIGINT)

    t = threading.Thread(target=interrupt)
    t.start()
    try:
        with pytest.raises(KeyboardInterrupt):
            skylod.svf(synth, pois, rays=30_000, progress=progress)
    finally:
        t.join()
    # Stopped before every POI was traced: cancelled, not run to its end.
    assert traced and max(traced) < n, (max(traced), n)
