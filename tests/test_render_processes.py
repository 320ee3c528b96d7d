"""Renders on forked worker processes (``parallel="processes"``, the default on Linux) give the images of
threads bit for bit, propagate a worker's error, and leave no process behind (:mod:`pyrt.render.pool`)."""
import copy
import multiprocessing
import os
import pathlib
import signal
import threading
import time

import numpy as np
import pytest

import pyrt
from pyrt.core.errors import RenderError
from pyrt.render import pool as P
from render_helpers import CtrlC

ROOT = pathlib.Path(__file__).resolve().parents[1]
pytestmark = pytest.mark.skipif("fork" not in multiprocessing.get_all_start_methods(), reason="needs fork")


@pytest.fixture(scope="module")
def scene():
    sc, _ = pyrt.load_scene(ROOT / "assets/default_scene.toml")
    sc.camera.width, sc.camera.height = 48, 36
    return sc


def _no_children():
    return multiprocessing.active_children() == []


def test_auto_is_processes_on_linux_for_long_renders_and_one_worker_is_the_calling_thread():
    linux = os.uname().sysname.startswith("Linux")
    assert P.use_processes("auto", 2) == linux and P.use_processes("auto", 2, P.PROCESS_MIN_CHUNKS) == linux
    assert not P.use_processes("auto", 2, P.PROCESS_MIN_CHUNKS - 1)      # too short to repay the fork
    assert P.use_processes("processes", 2, 2)
    assert not P.use_processes("auto", 1) and not P.use_processes("processes", 1)
    assert not P.use_processes("threads", 2) and P.use_processes("processes", 2)
    with pytest.raises(RenderError, match="parallel must be one of"):
        P.use_processes("fibers", 2)


def test_bad_parallel_is_a_render_error(scene):
    with pytest.raises(RenderError, match="parallel must be one of"):
        pyrt.render(scene, backend="numpy", spp=1, parallel="gpu")


@pytest.mark.parametrize("kw", [dict(spp=4, chunk_samples=512),                 # whole-pixel chunks: 14
                                dict(spp=40, chunk_samples=16, crop=True),      # pieces of pixels: 3 per pixel
                                dict(spp=4, chunk_samples=512, integrator="glossy")])
def test_fixed_spp_processes_equal_threads_bit_for_bit(scene, kw):
    kw = dict(kw)
    if kw.pop("crop", False):
        scene = copy.copy(scene)
        scene.camera = copy.copy(scene.camera)
        scene.camera.width, scene.camera.height = 8, 6
    a = pyrt.render_full(scene, backend="numpy", threads=2, parallel="threads", aovs=True, seed=5, **kw)
    b = pyrt.render_full(scene, backend="numpy", threads=2, parallel="processes", aovs=True, seed=5, **kw)
    np.testing.assert_array_equal(a.image, b.image)
    for k in a.aovs:
        np.testing.assert_array_equal(a.aovs[k], b.aovs[k])
    np.testing.assert_array_equal(a.film.weight, b.film.weight)
    assert (a.samples_done, a.chunks_done, a.stats.rays) == (b.samples_done, b.chunks_done, b.stats.rays)
    assert b.complete and b.chunks_done > 2 and _no_children()


def test_adaptive_processes_equal_threads_bit_for_bit(scene):
    kw = dict(target_error=2e-3, max_spp=32, min_spp=2, seed=2, threads=2, chunk_samples=1024)
    a = pyrt.render_full(scene, backend="numpy", parallel="threads", **kw)
    b = pyrt.render_full(scene, backend="numpy", parallel="processes", **kw)
    assert a.passes >= 3                                   # several passes on the same pool
    assert (a.passes, a.stop_reason, a.samples_done) == (b.passes, b.stop_reason, b.samples_done)
    np.testing.assert_array_equal(a.image, b.image)
    np.testing.assert_array_equal(a.film.weight, b.film.weight)
    assert _no_children()


def test_a_worker_error_reaches_the_caller_with_its_type_and_message(scene, monkeypatch):
    class Failing(P.Integrator):
        def render_samples(self, rays, **kw):
            raise ValueError("boom in a worker")

    monkeypatch.setattr(P, "Integrator", Failing)      # the factory captures it; the workers inherit it
    with pytest.raises(ValueError, match="boom in a worker"):
        pyrt.render_full(scene, backend="numpy", spp=4, chunk_samples=512, threads=2, parallel="processes")
    assert _no_children()


def _die(i):
    if i == 3:
        os.kill(os.getpid(), signal.SIGKILL)
    return i


def test_a_worker_that_dies_is_a_render_error_naming_it():
    got = []
    with pytest.raises(RenderError, match="a worker process died"):
        with P.ChunkPool(_die, 2, processes=True) as pool:
            pool.map([(i,) for i in range(20)], _Bar(), lambda i, r: got.append(r))
    assert got == list(range(len(got))) and len(got) <= 3 and _no_children()


class _Bar:
    def update(self, n=1):
        pass


def _square(i):
    return i * i


def test_pool_collects_in_index_order_and_halted_stops_submitting():
    with P.ChunkPool(_square, 2, processes=True) as pool:
        got = []
        assert pool.map([(i,) for i in range(50)], _Bar(), lambda i, r: got.append((i, r)))
        assert got == [(i, i * i) for i in range(50)]
        got.clear()
        assert not pool.map([(i,) for i in range(50)], _Bar(), lambda i, r: got.append(i), lambda: len(got) >= 5)
        assert got == list(range(len(got))) and 5 <= len(got) < 50     # a few in flight still land, in order
    assert _no_children()


def test_cancel_before_the_start_renders_nothing_on_processes(scene):
    ev = threading.Event()
    ev.set()
    res = pyrt.render_full(scene, backend="numpy", spp=2, chunk_samples=256, threads=2, parallel="processes", cancel=ev)
    assert not res.complete and res.chunks_done == 0 and not np.any(res.image) and _no_children()


def test_keyboard_interrupt_leaves_no_worker_process():
    sc, _ = pyrt.load_scene(ROOT / "assets/default_scene.toml")   # 640x480: ~100 chunks at 8 spp
    t0 = time.perf_counter()
    with pytest.raises(KeyboardInterrupt), CtrlC(0.5):
        pyrt.render_full(sc, backend="numpy", spp=8, threads=2, parallel="processes", progress=False)
    assert time.perf_counter() - t0 < 4.0 and _no_children()


def _auto_in_child(q):
    q.put(P.use_processes("auto", 2))


def test_auto_is_threads_in_a_daemonic_process():
    ctx = multiprocessing.get_context("fork")
    q = ctx.Queue()
    p = ctx.Process(target=_auto_in_child, args=(q,), daemon=True)
    p.start()
    got = q.get(timeout=30)
    p.join()
    assert got is False


def test_command_lines_take_parallel(tmp_path):
    from pyrt.apps.cli import main
    out = tmp_path / "a.exr"
    assert main(["render", str(ROOT / "assets/default_scene.toml"), "-o", str(out), "--width", "32",
                 "--height", "24", "--spp", "2", "--parallel", "threads", "--threads", "2"]) == 0
    assert out.exists()
