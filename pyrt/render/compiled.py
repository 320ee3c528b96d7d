"""A fixed-spp render on the compiled path (:mod:`pyrt.integrators.compiled`), with the NumPy path's result.

:func:`render_compiled` is what :func:`pyrt.render_full` runs when the backend is ``"compiled"``, or ``"auto"`` and
the scene and options are all covered: the same :class:`RenderResult` (image, film, statistics, cancellation and
fill) as the chunked NumPy render, ``result.stats.backend == "compiled"``. (:func:`pyrt.render.fixed.warmup` compiles the
kernel ahead of time: ``python -m pyrt compile``.)
"""
from __future__ import annotations

from copy import copy
import time
import warnings

import numpy as np

from pyrt.core.errors import RenderError
from pyrt.core.film import Film, FilmError, PixelSums
from pyrt.integrators import compiled, compiled_passes
from pyrt.integrators.prepared import RenderStats
from pyrt.render.distributed import compiled_tiles
from pyrt.render.pool import progress_bar
from pyrt.render.result import RenderResult


def render_compiled(ps, cam, *, seed, max_depth, throughput_cutoff, offset, split_depth, threads, cancel, fill,
                    nonfinite, progress, t_start, aovs=False, integ=None):
    """Render ``cam.spp`` samples per pixel of the prepared scene ``ps`` with the compiled kernel; a
    :class:`RenderResult` (with ``aovs`` the film's depth, normal and albedo AOVs). After a cancellation with
    ``fill``, the tiles not rendered get one sample per pixel. ``integ``: the integrator settings (the glossy
    integrator's and the light choice's, :func:`pyrt.integrators.compiled.kernel_integrator`; None: Whitted)."""
    cs = compiled.CompiledScene(ps, integ)
    W, H, S = cam.width, cam.height, cam.spp
    kw = dict(seed=seed, max_depth=max_depth, throughput_cutoff=throughput_cutoff, split_depth=split_depth,
              terminator=offset in (None, "robust"), threads=threads)
    bar = progress_bar(progress, total=compiled.n_tiles(cam), desc="render", unit="tile", leave=False)
    try:
        sums, sqs, counters, done, *aov = compiled.render_fixed(cs, cam, spp=S, cancel=cancel, progress=bar,
                                                                aovs=aovs, **kw)
    finally:
        bar.close()
    film = Film(W, H, aovs=aovs, nonfinite=nonfinite)
    px_done = None if done.all() else compiled.pixel_mask(done, W, H)
    film.sum = sums                 # the kernel's own (H*W, 3) float64 sums: no copy
    if aovs:
        _add_aovs(film, aov[0])
    film.weight += float(S) if px_done is None else np.where(px_done, float(S), 0.0)
    stats = RenderStats(primary_rays=int(counters[0]), secondary_rays=int(counters[1]),
                        shadow_rays=int(counters[2]), nonfinite_samples=int(counters[3]), backend="compiled")
    pixels_filled = 0
    if not done.all() and fill:
        rest = np.flatnonzero(~done)
        cam1 = _one_sample(cam)
        s1, _q, c1, d1, *a1 = compiled.render_fixed(cs, cam1, spp=1, tiles=rest, aovs=aovs, **kw)
        filled = compiled.pixel_mask(d1, W, H)
        film.sum += s1
        if aovs:
            _add_aovs(film, a1[0])
        film.weight += filled
        pixels_filled = int(filled.sum())
        stats.nonfinite_samples += int(c1[3])
    _finish(stats, film, nonfinite, t_start)
    n_done = W * H if px_done is None else int(px_done.sum())
    return RenderResult(image=film.image(), aovs=film.aovs(), stats=stats, film=film, complete=bool(done.all()),
                        chunks_done=int(done.sum()), chunks_total=int(done.size), pixels_done=n_done,
                        pixels_filled=pixels_filled, samples_done=n_done * S)


def adaptive_task(ps, cam, *, seed, max_depth, throughput_cutoff, offset, split_depth, nonfinite, threads=None,
                  integ=None):
    """The compiled twin of :func:`pyrt.render.chunks.shade_adaptive_chunk` for :func:`pyrt.render.adaptive.
    render_adaptive`: a function ``(P, C, base, spp_after, halted, order_seed) -> (stats, rows done, sums of A + B,
    sums of B, blocks done, blocks)`` (sums as :class:`PixelSums` of the rows done) that renders a whole pass with
    the kernel's threads (:func:`pyrt.integrators.compiled_passes.render_pixels`: the same camera rays as the NumPy
    path's chunks; ``spp_after``, the pixels' samples after the pass, scales their differentials; ``halted()`` asked
    between kernel calls)."""
    cs = compiled.CompiledScene(ps, integ)
    compiled_passes.load_pixel_kernel(cs, cam)
    kw = dict(seed=seed, max_depth=max_depth, throughput_cutoff=throughput_cutoff, split_depth=split_depth,
              terminator=offset in (None, "robust"), threads=threads)

    def run(P, C, base, spp_after, halted, order_seed):
        both, half_b, counters, done, blocks = compiled_passes.render_pixels(
            cs, cam, P, C, base, spp_after, halted=halted, order_seed=order_seed, **kw)
        if counters[3] and nonfinite == "raise":
            raise FilmError("Film: non-finite radiance in an adaptive pass")
        stats = RenderStats(primary_rays=int(counters[0]), secondary_rays=int(counters[1]),
                            shadow_rays=int(counters[2]), nonfinite_samples=int(counters[3]), backend="compiled")
        C = np.asarray(C, dtype=np.int64)
        if not done.all():          # a pass cut short: its rows done
            P, C, both, half_b = np.asarray(P)[done], C[done], both[done], half_b[done]
        return stats, P, PixelSums(C.astype(np.float64), both, nonfinite=int(counters[3])), \
            PixelSums((C // 2).astype(np.float64), half_b), blocks
    return run


def _one_sample(cam):
    c = copy(cam)
    c.spp = 1
    return c


def check_backend(backend):
    """``backend`` if it is one of :data:`pyrt.integrators.compiled.BACKENDS`, else a :class:`RenderError`."""
    if backend not in compiled.BACKENDS:
        raise RenderError(f"render: backend must be one of {compiled.BACKENDS}, got {backend!r}")
    return backend


def render_compiled_dask(runner, cam, *, seed, max_depth, throughput_cutoff, offset, split_depth, cancel, nonfinite,
                         progress, t_start):
    """:func:`render_compiled` with the tiles as Dask tasks (:func:`pyrt.render.distributed.compiled_tiles`), merged
    on the client; a cancellation stops at task granularity (no fill on Dask, as on the NumPy path)."""
    W, H, S = cam.width, cam.height, cam.spp
    order = compiled.tile_order(compiled.n_tiles(cam))
    spec = {"threads": 1, "compiled": dict(spp=S, seed=seed, max_depth=max_depth, throughput_cutoff=throughput_cutoff,
                                           split_depth=split_depth, terminator=offset in (None, "robust"))}
    tasks = [(g, runner.submit(compiled_tiles, cam, runner.token, spec, order[g])) for g in runner.groups(order.size)]
    film = Film(W, H, nonfinite=nonfinite)
    counters = np.zeros(4, dtype=np.int64)
    tiles_done = 0
    bar = progress_bar(progress, total=order.size, desc="render", unit="tile", leave=False)
    try:
        for k, (g, fut) in enumerate(tasks):
            if cancel is not None and cancel.is_set():
                for _g, f in tasks[k:]:
                    f.cancel()
                break
            pix, sums, c = fut.result()
            film.sum[pix] += sums
            film.weight[pix] += S
            counters += c
            tiles_done += len(g)
            bar.update(len(g))
    finally:
        bar.close()
    stats = RenderStats(primary_rays=int(counters[0]), secondary_rays=int(counters[1]),
                        shadow_rays=int(counters[2]), nonfinite_samples=int(counters[3]), backend="compiled")
    _finish(stats, film, nonfinite, t_start)
    n_done = int(np.count_nonzero(film.weight))
    return RenderResult(image=film.image(), aovs=None, stats=stats, film=film, complete=tiles_done == order.size,
                        chunks_done=tiles_done, chunks_total=int(order.size), pixels_done=n_done,
                        samples_done=n_done * S)


def _add_aovs(film, a):
    """The kernel's AOV sums (H*W, 8: depth, depth weight, normal, albedo) into the film's."""
    f = film._aov
    f["depth"] += a[:, 0]
    f["depth_weight"] += a[:, 1]
    f["normal"] += a[:, 2:5]
    f["albedo"] += a[:, 5:8]


def _finish(stats, film, nonfinite, t_start):
    """The film's policy for the non-finite samples the kernel zeroed and counted (an error, or a warning), and the
    render's total time."""
    if stats.nonfinite_samples:
        if nonfinite == "raise":
            raise FilmError(f"Film: {stats.nonfinite_samples} samples with non-finite radiance")
        film.nonfinite_samples = stats.nonfinite_samples
        warnings.warn(f"render: {stats.nonfinite_samples} samples had non-finite radiance and were "
                      "set to 0 (this is a bug; please report the scene)", RuntimeWarning, stacklevel=4)
    stats.time_total = time.perf_counter() - t_start
