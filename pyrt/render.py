"""Render a scene: prepare it once, trace camera rays in chunks on a thread pool, accumulate a Film.

:func:`render` returns the image, :func:`render_full` also the AOVs and the ray statistics. Every chunk
has its own random stream ``default_rng([seed, chunk_index])`` and covers a disjoint range of pixels, so
the image is bit-identical for a seed whatever the number of threads or the order in which chunks finish.
"""
from __future__ import annotations

from concurrent.futures import ThreadPoolExecutor
from copy import copy
from dataclasses import dataclass
import threading
import time
import warnings

import numpy as np
from tqdm.auto import tqdm

from pyrt.core import checks
from pyrt.core.errors import RenderError
from pyrt.core.film import Film
from pyrt.integrators.prepared import PreparedScene, RenderStats
from pyrt.integrators.glossy import GlossyIntegrator
from pyrt.integrators.whitted import Integrator

#: ``integrator=`` names: strict Whitted (delta lobes only, the default) and glossy reflection rays
INTEGRATORS = ("whitted", "glossy")


@dataclass
class RenderResult:
    """Output of :func:`render_full`.

    Attributes
    ----------
    image : (H, W, 3) float32 ndarray
        Linear scene radiance.
    aovs : dict or None
        ``depth`` (H, W), ``normal`` and ``albedo`` (H, W, 3), float32, when asked for.
    stats : RenderStats
        Rays by kind, times, non-finite samples.
    film : Film
        The film the image was read from (per-pixel sample sums and weights).
    complete : bool
        False when the render was cancelled (``cancel`` set): only the chunks that finished are in the film;
        the other pixels have weight 0 and are black in ``image`` (and 0 / infinite depth in the AOVs).
    chunks_done, chunks_total : int
        Chunks of pixels rendered, and in the whole image.
    pixels_done : int
        Pixels with all their samples (the pixels of the finished chunks).
    pixels_filled : int
        Pixels of the unfinished chunks that got one sample each after a cancellation (``fill=True``), so the
        image has no black holes; 0 otherwise.
    """

    image: np.ndarray
    aovs: dict | None
    stats: RenderStats
    film: Film | None = None
    complete: bool = True
    chunks_done: int = 0
    chunks_total: int = 0
    pixels_done: int = 0
    pixels_filled: int = 0

    @property
    def fraction_done(self):
        """Share of the image's pixels rendered, in [0, 1] (1 for a complete render)."""
        n = self.image.shape[0] * self.image.shape[1]
        return self.pixels_done / n if n else 1.0


def render_full(scene, *, spp=None, seed=0, max_depth=8, throughput_cutoff=1e-4, offset=None, aovs=False,
                progress=None, chunk_samples=1 << 15, threads=None, record_rays=False, prepared=None,
                nonfinite="zero", cancel=None, fill=False, fill_budget=2.0, transparent_shadows=False,
                integrator="whitted", glossy_samples=4, glossy_depth=2, glossy_threshold=0.4):
    """Render ``scene`` and return a :class:`RenderResult` with the image, AOVs and statistics.

    Parameters are those of :func:`render`, plus:

    aovs : bool
        Also the first hit's depth, shading normal and albedo, averaged per pixel (``result.aovs``).
    record_rays : bool
        Keep every traced ray in ``result.stats.recorded`` (for benchmarks that replay them).
    prepared : PreparedScene, optional
        A scene prepared earlier (BVH built once for several renders); the caller closes it.
    nonfinite : {"zero", "raise"}
        The :class:`pyrt.core.film.Film` policy for samples with non-finite radiance (zeroed, counted and
        warned about; or an error).
    cancel : threading.Event, optional
        Cooperative cancellation: once set, no new chunk starts; the chunks running finish (each takes
        tens of milliseconds) and the result is marked partial (``result.complete`` False, see
        :class:`RenderResult`: unfinished pixels are black).
    fill : bool
        After a cancellation, give every pixel of the unfinished chunks one sample (random stream
        ``default_rng([seed, chunk_index, 1])``) when that is estimated, from the speed of the chunks done, to
        take at most ``fill_budget`` seconds: the image is then complete, at 1 spp in those pixels
        (``result.pixels_filled``). What the command line does on Ctrl-C.
    fill_budget : float
        Seconds the fill may take (estimate); above it the unfinished pixels stay black.
    integrator : {"whitted", "glossy"}
        ``"whitted"`` (default): only delta lobes (mirrors, glass) spawn rays. ``"glossy"``
        (:mod:`pyrt.integrators.glossy`): glossy lobes also spawn BSDF-sampled rays, MIS-combined with
        light sampling.
    glossy_samples, glossy_depth, glossy_threshold : int, int, float
        The glossy integrator's rays per hit on the first bounce (1 deeper), the bounces that spawn them
        and the ``glossy_alpha`` above which a lobe counts as diffuse (:class:`GlossyIntegrator`).

    A ``KeyboardInterrupt`` while rendering cancels the chunks not yet started, waits for the running
    ones, shuts the thread pool down and propagates (no thread is left running).

    Chunks of pixels are shaded on a pool of ``threads`` workers (NumPy releases the GIL in its array
    loops, Embree in its traversal). Every chunk has its own random stream
    ``default_rng([seed, chunk_index])`` and writes a disjoint range of the film, so the image does not
    depend on the number of threads or the order in which chunks finish.
    """
    t_start = time.perf_counter()
    if integrator not in INTEGRATORS:
        raise RenderError(f"render: integrator must be one of {sorted(INTEGRATORS)}, got {integrator!r}")
    extra = {}
    if integrator == "glossy":
        extra = dict(glossy_samples=glossy_samples, glossy_depth=glossy_depth, glossy_threshold=glossy_threshold)
    make = GlossyIntegrator if integrator == "glossy" else Integrator
    cam = scene.camera
    if spp is not None:
        cam = copy(cam)
        cam.spp = checks.integer("render", "spp", spp, RenderError)
    chunk_samples = checks.integer("render", "chunk_samples", chunk_samples, RenderError)
    threads = None if threads is None else checks.integer("render", "threads", threads, RenderError)
    own = prepared is None
    ps = prepared if prepared is not None else PreparedScene(scene, threads=threads)
    W, H, S = cam.width, cam.height, cam.spp
    n_pix = W * H
    px_per_chunk = max(1, int(chunk_samples) // S)
    film = Film(W, H, aovs=aovs, nonfinite=nonfinite)
    starts = list(range(0, n_pix, px_per_chunk))

    def run_chunk(ci):
        lo = starts[ci]
        hi = min(lo + px_per_chunk, n_pix)
        integ = make(ps, max_depth=max_depth, throughput_cutoff=throughput_cutoff, offset=offset,
                     record_rays=record_rays, transparent_shadows=transparent_shadows, **extra)
        rng = np.random.default_rng([seed, ci])
        rays = cam.generate_rays(lo, hi, rng, differentials=ps.needs_differentials)
        L, a = integ.render_samples(rays, want_aovs=aovs, rng=rng)
        integ.stats.nonfinite_samples += film.add_block(lo, hi, L, a)
        return integ.stats

    abort = threading.Event()    # set on an error or a KeyboardInterrupt (the caller's ``cancel`` is not touched)

    def run_or_skip(ci):
        if abort.is_set() or (cancel is not None and cancel.is_set()):
            return None
        return run_chunk(ci)

    stats = RenderStats()
    workers = max(1, min(ps.accel.threads if threads is None else int(threads), len(starts)))
    bar = tqdm(total=len(starts), desc="render", unit="chunk", leave=False,
               disable=(not progress) if progress is not None else None)
    results = []
    try:
        if workers == 1:
            for ci in range(len(starts)):
                results.append(run_or_skip(ci))
                bar.update()
        else:
            results = _run_pool(run_or_skip, len(starts), workers, abort, bar)
    except BaseException:
        if own:
            ps.close()
        raise
    finally:
        bar.close()
    done = [ci for ci, st in enumerate(results) if st is not None]
    results = [results[ci] for ci in done]
    pixels_done = sum(min(starts[ci] + px_per_chunk, n_pix) - starts[ci] for ci in done)
    pixels_filled = 0
    pending = [ci for ci in range(len(starts)) if results and ci not in set(done)]
    if fill and pending and pixels_done:
        # seconds per pixel-sample so far; the fill gives the pending pixels one sample each
        rate = (time.perf_counter() - t_start) / (pixels_done * S)
        if (n_pix - pixels_done) * rate <= fill_budget:
            cam1 = copy(cam)
            cam1.spp = 1
            fps = ps

            def fill_chunk(k):
                ci = pending[k]
                lo, hi = starts[ci], min(starts[ci] + px_per_chunk, n_pix)
                integ = make(fps, max_depth=max_depth, throughput_cutoff=throughput_cutoff, offset=offset,
                             transparent_shadows=transparent_shadows, **extra)
                rng = np.random.default_rng([seed, ci, 1])
                rays = cam1.generate_rays(lo, hi, rng, differentials=fps.needs_differentials)
                L, a = integ.render_samples(rays, want_aovs=aovs, rng=rng)
                integ.stats.nonfinite_samples += film.add_block(lo, hi, L, a)
                return integ.stats

            fill_bar = tqdm(total=len(pending), desc="fill", unit="chunk", leave=False,
                            disable=(not progress) if progress is not None else None)
            try:
                results += _run_pool(fill_chunk, len(pending), workers, threading.Event(), fill_bar)
            finally:
                fill_bar.close()
                if own:
                    ps.close()
            pixels_filled = n_pix - pixels_done
    if own:
        ps.close()
    for st in results:  # merge in chunk order (deterministic)
        for k in ("primary_rays", "secondary_rays", "shadow_rays", "time_intersect", "time_occluded",
                  "nonfinite_samples"):
            setattr(stats, k, getattr(stats, k) + getattr(st, k))
        stats.recorded.extend(st.recorded)
    if stats.nonfinite_samples:
        warnings.warn(f"render: {stats.nonfinite_samples} samples had non-finite radiance and were "
                      "set to 0 (this is a bug; please report the scene)", RuntimeWarning, stacklevel=2)
    stats.time_total = time.perf_counter() - t_start
    return RenderResult(image=film.image(), aovs=film.aovs(), stats=stats, film=film,
                        complete=len(done) == len(starts), chunks_done=len(done), chunks_total=len(starts),
                        pixels_done=pixels_done, pixels_filled=pixels_filled)


def _run_pool(run, n, workers, abort, bar):
    """``[run(0), ..., run(n - 1)]`` on ``workers`` threads, in index order.

    On any exception in the caller's thread (a ``KeyboardInterrupt`` above all) or in a chunk: set
    ``abort``, cancel the chunks not started, wait for the running ones and re-raise; the pool is shut
    down in every case.
    """
    pool = ThreadPoolExecutor(max_workers=workers)
    try:
        futs = [pool.submit(run, ci) for ci in range(n)]
        results = []
        for f in futs:
            results.append(f.result())
            bar.update()
    except BaseException:
        abort.set()
        pool.shutdown(wait=True, cancel_futures=True)
        raise
    pool.shutdown(wait=True)
    return results


def render(scene, **kwargs):
    """Render ``scene`` to linear radiance.

    Parameters
    ----------
    scene : pyrt.Scene
    spp : int, optional
        Samples per pixel (default: the camera's).
    seed : int
        Random seed; the same seed gives a bit-identical image.
    max_depth : int
        Maximum specular recursion depth (default 8).
    throughput_cutoff : float
        Drop specular rays whose throughput falls below this (default 1e-4).
    offset : str or callable
        Ray-offset strategy (:mod:`pyrt.geometry.offsets`): a name, a Strategy or a callable; default "robust"
        (local error bound + robust shadow tmax + shadow-terminator lift).
    transparent_shadows : bool
        Shadow rays pass straight through dielectrics, attenuated by the Fresnel transmittance of each
        interface, the tint and Beer-Lambert absorption (:mod:`pyrt.integrators.shadows`: an approximation,
        no caustics). Default False (strict Whitted: glass casts a shadow of 0, like an opaque object).
    progress : bool, optional
        Show a progress bar (default: only on a terminal).
    chunk_samples : int
        Camera samples per chunk (bounds memory; default 32768: measured fastest on the benchmark scene).
    threads : int, optional
        Worker threads for chunks and for Embree batches (default: all cores).
    cancel : threading.Event, optional
        Stop early when set (no new chunk starts); the chunks not rendered stay black. Use
        :func:`render_full` to learn whether the image is complete.
    integrator : {"whitted", "glossy"}
        Default ``"whitted"``; see :func:`render_full` (also ``glossy_samples``, ``glossy_depth``,
        ``glossy_threshold``).

    Returns
    -------
    (H, W, 3) float32 ndarray
        Linear scene radiance (W m^-2 sr^-1 per RGB channel).
    """
    return render_full(scene, **kwargs).image
