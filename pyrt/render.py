"""Render a scene: prepare it once, trace camera rays in chunks on a thread pool, accumulate a Film.

:func:`render` returns the image, :func:`render_full` also the AOVs and the ray statistics. Every chunk
has its own random stream ``default_rng([seed, chunk_index])`` and covers a disjoint range of pixels, so
the image is bit-identical for a seed whatever the number of threads or the order in which chunks finish.
"""
from __future__ import annotations

from concurrent.futures import ThreadPoolExecutor
from copy import copy
from dataclasses import dataclass
import time
import warnings

import numpy as np
from tqdm.auto import tqdm

from pyrt.core import checks
from pyrt.core.errors import RenderError
from pyrt.core.film import Film
from pyrt.integrators.prepared import PreparedScene, RenderStats
from pyrt.integrators.whitted import Integrator


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
    """

    image: np.ndarray
    aovs: dict | None
    stats: RenderStats
    film: Film | None = None


def render_full(scene, *, spp=None, seed=0, max_depth=8, throughput_cutoff=1e-4, offset=None, aovs=False,
                progress=None, chunk_samples=1 << 15, threads=None, record_rays=False, prepared=None,
                nonfinite="zero"):
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

    Chunks of pixels are shaded on a pool of ``threads`` workers (NumPy releases the GIL in its array
    loops, Embree in its traversal). Every chunk has its own random stream
    ``default_rng([seed, chunk_index])`` and writes a disjoint range of the film, so the image does not
    depend on the number of threads or the order in which chunks finish.
    """
    t_start = time.perf_counter()
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
        integ = Integrator(ps, max_depth=max_depth, throughput_cutoff=throughput_cutoff, offset=offset,
                           record_rays=record_rays)
        rng = np.random.default_rng([seed, ci])
        rays = cam.generate_rays(lo, hi, rng, differentials=ps.needs_differentials)
        L, a = integ.render_samples(rays, want_aovs=aovs, rng=rng)
        integ.stats.nonfinite_samples += film.add_block(lo, hi, L, a)
        return integ.stats

    stats = RenderStats()
    workers = max(1, min(ps.accel.threads if threads is None else int(threads), len(starts)))
    bar = tqdm(total=len(starts), desc="render", unit="chunk", leave=False,
               disable=(not progress) if progress is not None else None)
    try:
        if workers == 1:
            results = []
            for ci in range(len(starts)):
                results.append(run_chunk(ci))
                bar.update()
        else:
            with ThreadPoolExecutor(max_workers=workers) as pool:
                futs = [pool.submit(run_chunk, ci) for ci in range(len(starts))]
                results = []
                for f in futs:
                    results.append(f.result())
                    bar.update()
    finally:
        bar.close()
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
    return RenderResult(image=film.image(), aovs=film.aovs(), stats=stats, film=film)


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
    progress : bool, optional
        Show a progress bar (default: only on a terminal).
    chunk_samples : int
        Camera samples per chunk (bounds memory; default 32768: measured fastest on the benchmark scene).
    threads : int, optional
        Worker threads for chunks and for Embree batches (default: all cores).

    Returns
    -------
    (H, W, 3) float32 ndarray
        Linear scene radiance (W m^-2 sr^-1 per RGB channel).
    """
    return render_full(scene, **kwargs).image
