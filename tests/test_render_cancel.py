"""Cancelling a render: the ``cancel`` event keeps the finished chunks, a KeyboardInterrupt shuts the thread
pool down and propagates, and an uninterrupted render is unchanged."""
import importlib
import pathlib
import threading
import time

import numpy as np
import pytest

import pyrt
from render_helpers import CancelAfter, CtrlC

R = importlib.import_module("pyrt.render.pool")   # where the chunks get their integrator class
ROOT = pathlib.Path(__file__).resolve().parents[1]



@pytest.fixture(scope="module")
def scene():
    sc, _ = pyrt.load_scene(ROOT / "assets/default_scene.toml")
    sc.camera.width, sc.camera.height = 64, 48
    return sc


# the NumPy path's chunk pool (the compiled path's cancel and fill: tests/test_compiled_render.py)
KW = dict(spp=2, chunk_samples=512, seed=3, backend="numpy")   # 256 pixels per chunk: 12 chunks


def test_uncancelled_render_is_complete_and_unchanged(scene):
    full = pyrt.render_full(scene, threads=2, **KW)
    assert full.complete and full.chunks_done == full.chunks_total == 12
    assert full.pixels_done == 64 * 48 and full.fraction_done == 1.0
    again = pyrt.render_full(scene, threads=2, cancel=threading.Event(), **KW)
    assert again.complete and np.array_equal(again.image, full.image)


def test_cancel_keeps_the_finished_chunks_and_leaves_the_rest_black(scene):
    full = pyrt.render_full(scene, threads=1, aovs=True, **KW)
    part = pyrt.render_full(scene, threads=1, aovs=True, cancel=CancelAfter(5), **KW)
    assert not part.complete and (part.chunks_done, part.chunks_total) == (5, 12)
    assert part.pixels_done == 5 * 256 and part.fraction_done == pytest.approx(5 * 256 / (64 * 48))
    a, b = full.image.reshape(-1, 3), part.image.reshape(-1, 3)
    assert np.array_equal(a[:1280], b[:1280])            # the finished chunks, bit for bit
    assert not np.any(b[1280:])                           # unfinished pixels: weight 0, black
    assert not np.any(part.film.weight[1280:]) and np.all(part.film.weight[:1280] == 2)
    assert part.stats.primary_rays == 1280 * 2


def test_fill_gives_the_unfinished_pixels_one_sample_each(scene):
    """``fill=True`` (what the CLI does on Ctrl-C): the finished chunks stay bit-identical at full spp, every other
    pixel gets exactly one sample (no black hole), and the result says how many pixels were filled."""
    full = pyrt.render_full(scene, threads=1, **KW)
    part = pyrt.render_full(scene, threads=1, cancel=CancelAfter(5), fill=True, fill_budget=60.0, **KW)
    assert not part.complete and part.pixels_done == 1280 and part.pixels_filled == 64 * 48 - 1280
    a, b = full.image.reshape(-1, 3), part.image.reshape(-1, 3)
    assert np.array_equal(a[:1280], b[:1280])
    assert np.all(part.film.weight[1280:] == 1) and np.all(part.film.weight[:1280] == 2)
    # the filled pixels are an unbiased 1-spp estimate of the same image: same mean over the region (5 %)
    np.testing.assert_allclose(b[1280:].mean(axis=0), a[1280:].mean(axis=0), rtol=0.05)
    assert np.isfinite(b).all()
    none = pyrt.render_full(scene, threads=1, cancel=CancelAfter(5), fill=True, fill_budget=0.0, **KW)
    assert none.pixels_filled == 0 and not np.any(none.image.reshape(-1, 3)[1280:])   # over budget: black


def test_cancel_before_the_start_renders_nothing(scene):
    ev = threading.Event()
    ev.set()
    res = pyrt.render_full(scene, threads=2, cancel=ev, **KW)
    assert not res.complete and res.chunks_done == 0 and not np.any(res.image)
    img = pyrt.render(scene, threads=2, cancel=ev, **KW)   # render() takes it too
    assert not np.any(img)


def _pool_threads():
    return [t for t in threading.enumerate() if t.name.startswith("ThreadPoolExecutor")]


def test_keyboard_interrupt_cancels_pending_chunks_and_shuts_the_pool_down(scene):
    before = len(_pool_threads())
    sc, _ = pyrt.load_scene(ROOT / "assets/default_scene.toml")   # 640x480: ~100 chunks at 8 spp
    t0 = time.perf_counter()
    with pytest.raises(KeyboardInterrupt), CtrlC(0.3):
        pyrt.render_full(sc, spp=8, threads=2, progress=False, backend="numpy")
    elapsed = time.perf_counter() - t0
    assert elapsed < 3.0                                  # not the whole render
    assert len(_pool_threads()) == before                 # no worker left running


def test_an_error_in_a_chunk_stops_the_other_chunks(scene, monkeypatch):
    calls = []

    class Failing(R.Integrator):
        def render_samples(self, rays, **kw):
            calls.append(1)
            if len(calls) == 3:
                raise RuntimeError("boom")
            return super().render_samples(rays, **kw)

    monkeypatch.setattr(R, "Integrator", Failing)
    with pytest.raises(RuntimeError, match="boom"):
        pyrt.render_full(scene, threads=2, **KW)
    assert len(calls) < 12 and not _pool_threads()
