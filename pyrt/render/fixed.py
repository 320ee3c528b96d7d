"""Render a scene: prepare it once, trace camera rays in chunks on a thread pool, accumulate a Film.

:func:`render` returns the image, :func:`render_full` also the AOVs and the ray statistics. Every chunk
has its own random stream ``default_rng([seed, chunk_index])`` and covers a disjoint range of pixels, so
the image is bit-identical for a seed whatever the number of threads or the order in which chunks finish.

Chunks are cut by samples, not pixels: a chunk holds at most ``chunk_samples`` camera samples, so memory
does not grow with ``spp``. Up to ``chunk_samples`` spp a chunk is ``chunk_samples // spp`` whole pixels;
above it a chunk is one pixel and one of its ``pieces = ceil(spp / chunk_samples)`` pieces (chunk index
``pixel * pieces + piece``): piece ``p`` draws the samples ``p, p + pieces, p + 2 pieces, ...`` of the
pixel's stratified set (:func:`pyrt.core.sampler.pixel_strata`: ``spp`` equal-area jittered cells that tile
the pixel once), so the pieces together are one stratified set and each piece alone is spread over the
whole pixel. A piece goes into a one-pixel film of its own and the pieces are added to the image's film
in chunk order, by the calling thread (the same float64 sums whatever the thread count).
"""
from __future__ import annotations

from copy import copy
import time
import warnings

import numpy as np

from pyrt.core import checks
from pyrt.core.errors import RenderError
from pyrt.core.film import Film
from pyrt.integrators.prepared import PreparedScene, RenderStats
from pyrt.integrators.whitted import DEFAULT_SPLIT_DEPTH
from pyrt.integrators import compiled
from pyrt.render.adaptive import render_adaptive
from pyrt.render.compiled import check_backend, render_compiled, render_compiled_dask
from pyrt.render.chunks import ChunkLayout, shade_fixed_chunk
from pyrt.render.distributed import DaskRunner, fixed_group
from pyrt.render.pool import INTEGRATORS, ChunkPool, integrator_factory, merge_stats, progress_bar, use_processes
from pyrt.render.options import check_image_memory, check_options, warn_smooth_lobes
from pyrt.render.result import RenderResult
from pyrt.render import settings



def render_full(scene, *, spp=None, seed=0, integrator="whitted", sampling=None, output=None, execution=None,
                **keywords):
    """Render ``scene`` and return a :class:`RenderResult`: the image, AOVs, statistics and the film.

    Parameters
    ----------
    scene : pyrt.Scene
    spp : int, optional
        Samples per pixel (default: the camera's); short for ``sampling=pyrt.Sampling(spp=...)``.
    seed : int
        Random seed; the same seed gives a bit-identical image.
    integrator : pyrt.Whitted, pyrt.Glossy, str or dict
        The estimator and its own parameters (:class:`pyrt.render.settings.Whitted`, ``Glossy``), a type name
        (``"whitted"``, the default, or ``"glossy"``) or a ``{"type": ..., option: value}`` dict.
    sampling, output, execution : pyrt.Sampling, pyrt.Output, pyrt.Execution or dict, optional
        Adaptive sampling and the sampler; AOVs, the non-finite policy, the fill after a cancellation; threads,
        backend, workers, Dask, cancellation, progress (:mod:`pyrt.render.settings`). An option that the other
        settings leave unused is an error naming it.
    **keywords
        The flat keywords of earlier releases (``max_depth=``, ``aovs=``, ``threads=`` ...:
        :data:`pyrt.render.settings.LEGACY`) still work, with a ``DeprecationWarning`` naming the new spelling.

    A ``KeyboardInterrupt`` while rendering cancels the chunks not yet started, waits for the running ones, shuts
    the worker pool down and propagates (no thread or process is left running). The image does not depend on the
    number or kind of workers (:func:`_render_flat`).
    """
    return _render_options(scene, spp, seed, integrator, sampling, output, execution, keywords, stacklevel=3)


def _render_options(scene, spp, seed, integrator, sampling, output, execution, keywords, *, stacklevel):
    """:func:`render_full`'s arguments resolved to the option objects, then :func:`_render_flat`."""
    integ, samp, out, exe = settings.from_keywords(integrator, sampling, output, execution, keywords,
                                                   stacklevel=stacklevel)
    if spp is not None and samp.spp is not None:
        raise RenderError("render: spp given twice (spp= and sampling=pyrt.Sampling(spp=...)): give it once")
    if spp is not None and samp.adaptive:
        raise RenderError("render: spp (fixed samples per pixel) and target_error / time_budget / max_spp "
                          "(adaptive) exclude each other; min_spp sets the adaptive base pass")
    return _render_flat(scene, spp=samp.spp if spp is None else spp, seed=seed, **integ.keywords(),
                        **samp.keywords(), **out.keywords(), **exe.keywords())


def _render_flat(scene, *, spp=None, seed=0, max_depth=8, throughput_cutoff=1e-4, roulette=False, offset=None,
                 aovs=False, progress=None, chunk_samples=1 << 15, threads=None, record_rays=False, prepared=None,
                nonfinite="zero", cancel=None, fill=False, fill_budget=2.0, transparent_shadows=False,
                integrator="whitted", glossy_samples=4, glossy_depth=2, glossy_threshold=0.4, glossy_clamp=None,
                target_error=None, time_budget=None, max_spp=None, min_spp=4, on_pass=None, dask=None,
                dask_workers=2, split_depth=DEFAULT_SPLIT_DEPTH, light_select_depth=None, parallel="auto", batch_rays=None,
                sampler="padded", backend="auto"):
    """The render itself, every option a keyword (what :func:`render_full`'s option objects resolve to).

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
        After a cancellation, give every pixel with no sample one sample (random stream
        ``default_rng([seed, first_pixel, 1])`` per run of at most ``chunk_samples`` such pixels) when that is
        estimated, from the speed of the chunks done, to take at most ``fill_budget`` seconds: the image is then
        complete, at 1 spp in those pixels (``result.pixels_filled``); partly rendered pixels keep the samples
        they have. No fill job starts after ``fill_budget`` seconds (the pixels of those not run stay black), so
        the fill ends within the budget plus the jobs in progress. What the command line does on Ctrl-C.
    fill_budget : float
        Seconds the fill may take; above the estimate no pixel is filled, at the deadline the fill stops.
    integrator : {"whitted", "glossy"}
        ``"whitted"`` (default): only delta lobes (mirrors, glass) spawn rays. ``"glossy"``
        (:mod:`pyrt.integrators.glossy`): glossy lobes also spawn BSDF-sampled rays, MIS-combined with
        light sampling.
    split_depth : int or None
        From this bounce on, a dielectric hit continues along one of its delta lobes (reflection or
        refraction, chosen by weight and weighted by 1 / probability: unbiased, noisier) instead of both
        (:class:`pyrt.integrators.whitted.Integrator`); default 3 (``DEFAULT_SPLIT_DEPTH``: the same error at
        0.62-0.78 of the time on the benchmark's glass scenes); None: both at every bounce (Whitted's full tree).
    light_select_depth : int, optional
        From this bounce on, the delta lights light each hit by one of them, chosen by irradiance and weighted
        by 1 / probability (:mod:`pyrt.integrators.light_choice`: unbiased, noisier); default None: all of them.
    glossy_samples, glossy_depth, glossy_threshold : int, int, float
        The glossy integrator's rays per hit on the first bounce (1 deeper), the bounces that spawn them
        and the ``glossy_alpha`` above which a lobe counts as diffuse (:class:`GlossyIntegrator`).
    glossy_clamp : float, optional
        The glossy integrator's clamp of the direct light at hits of glossy rays (biased, against fireflies;
        :class:`GlossyIntegrator`); default None: no clamp. The previewer sets one.

    batch_rays : int, optional
        Shade every bounce of a chunk in slices of at most this many rays, the rays they spawn gathered into one
        batch for the next bounce (:meth:`pyrt.integrators.whitted.Integrator.render_samples`): it bounds the
        working set of a bounce that holds more rays than the chunk's camera samples (the glossy integrator's
        first bounce: ``glossy_samples`` rays per hit), at the cost of more per-batch work where it cuts (the
        previewer: docs/preview.md). Default None: a bounce at once. The estimate is the same; the noise differs
        (other random draws).
    sampler : {"padded", "independent"}
        The random numbers of the light and BSDF samples at the camera rays' hits: ``"padded"`` (default) makes
        a pixel's samples one stratified set in every dimension pair, shuffled per pair
        (:class:`pyrt.core.sampler.PaddedStream`); ``"independent"`` draws them independently. Both are unbiased; padding lowers the noise of area, environment and glossy samples (the
        pixel positions are stratified either way).
    backend : {"auto", "compiled", "numpy"}
        The path that renders (``result.stats.backend`` says which did). ``"compiled"``: the Numba tile kernel
        (:mod:`pyrt.integrators.compiled`: Embree's packets, compiled shading, all cores by threads), for the
        scenes and options it covers, else a :class:`RenderError` listing what it does not; ``"numpy"``: the
        wavefront NumPy integrators (the reference; every feature); ``"auto"`` (default): compiled where covered,
        NumPy otherwise (``result.stats.fallback_reasons`` says why). The two paths compute the same estimate from
        different random numbers: images agree to the noise (tests/test_compiled_render.py). The first compiled
        render of a new pyrt compiles the kernel (seconds; one line on stderr), later ones load it from the cache.
    parallel : {"auto", "threads", "processes"}
        What the ``threads`` workers are (:mod:`pyrt.render.pool`): worker processes forked once the scene is
        prepared (no shared GIL: the shading's small-array NumPy calls run in parallel), or threads of this
        process. "auto" (default): processes on Linux for renders of at least
        :data:`pyrt.render.pool.PROCESS_MIN_CHUNKS` chunks (forking costs ~50 ms), threads otherwise and
        elsewhere; one worker renders on the calling thread. The image is the same bit for bit either way.

    A ``KeyboardInterrupt`` while rendering cancels the chunks not yet started, waits for the running
    ones, shuts the worker pool down and propagates (no thread or process is left running).

    Chunks of at most ``chunk_samples`` samples (whole pixels, or pieces of one pixel above
    ``chunk_samples`` spp: see the module docstring) are shaded on a pool of ``threads`` workers,
    threads or forked processes (``parallel``), a bounded number in flight. Every chunk has its own random
    stream ``default_rng([seed, chunk_index])`` and its pixel sums are added to the film in chunk order, so
    the image does not depend on the number or kind of workers or the order in which chunks finish.
    """
    if target_error is not None or time_budget is not None or max_spp is not None:
        if spp is not None:
            raise RenderError("render: spp (fixed samples per pixel) and target_error / time_budget / max_spp "
                              "(adaptive) exclude each other; min_spp sets the adaptive base pass")
        return render_adaptive(scene, target_error=target_error, time_budget=time_budget, max_spp=max_spp,
                               min_spp=min_spp, seed=seed, aovs=aovs, progress=progress,
                               chunk_samples=chunk_samples, threads=threads, prepared=prepared,
                               nonfinite=nonfinite, cancel=cancel, fill=fill, fill_budget=fill_budget,
                               on_pass=on_pass, integrator=integrator, max_depth=max_depth,
                               throughput_cutoff=throughput_cutoff, roulette=roulette, offset=offset,
                               record_rays=record_rays,
                               transparent_shadows=transparent_shadows, glossy_samples=glossy_samples,
                               glossy_depth=glossy_depth, glossy_threshold=glossy_threshold,
                               glossy_clamp=glossy_clamp, dask=dask,
                               dask_workers=dask_workers, split_depth=split_depth,
                               light_select_depth=light_select_depth, parallel=parallel, batch_rays=batch_rays,
                               sampler=sampler, backend=backend)
    t_start = time.perf_counter()
    if integrator not in INTEGRATORS:
        raise RenderError(f"render: integrator must be one of {sorted(INTEGRATORS)}, got {integrator!r}")
    seed = check_options(seed=seed, glossy_samples=glossy_samples, glossy_depth=glossy_depth,
                         glossy_threshold=glossy_threshold, glossy_clamp=glossy_clamp)
    warn_smooth_lobes(scene, integrator)
    integ = dict(integrator=integrator, max_depth=max_depth, throughput_cutoff=throughput_cutoff, roulette=roulette,
                 offset=offset,
                 transparent_shadows=transparent_shadows, glossy_samples=glossy_samples, glossy_depth=glossy_depth,
                 glossy_threshold=glossy_threshold, glossy_clamp=glossy_clamp, split_depth=split_depth,
                 light_select_depth=light_select_depth, batch_rays=batch_rays, sampler=sampler)
    cam = scene.camera
    if spp is not None:
        cam = copy(cam)
        cam.spp = checks.integer("render", "spp", spp, RenderError)
    chunk_samples = checks.integer("render", "chunk_samples", chunk_samples, RenderError)
    threads = None if threads is None else checks.integer("render", "threads", threads, RenderError)
    cam.validate()
    check_image_memory(cam.width, cam.height, aovs=aovs)
    runner = None if dask is None else DaskRunner(dask, scene, dask_workers)
    own = prepared is None and runner is None
    ps = prepared if prepared is not None or runner is not None else PreparedScene(scene, threads=threads)
    W, H, S = cam.width, cam.height, cam.spp
    n_pix = W * H
    film = Film(W, H, aovs=aovs, nonfinite=nonfinite)
    layout = ChunkLayout(S, n_pix, chunk_samples)
    split, pieces, n_chunks, chunk_pixels = layout.split, layout.pieces, layout.n_chunks, layout.pixels

    reasons = []
    if check_backend(backend) != "numpy":
        reasons = compiled.unsupported(
            ps, integrator=integrator, offset=offset, transparent_shadows=transparent_shadows,
            light_select_depth=light_select_depth, record_rays=record_rays, scene=scene, roulette=roulette,
            sampler=sampler)
        if aovs and runner is not None:
            reasons.append("AOVs on Dask workers")
        if runner is not None and (compiled.kernel_integrator(scene, integ) != compiled.kernel_integrator(scene)
                                   or roulette or transparent_shadows):
            reasons.append("the glossy integrator, light selection, Russian roulette or transparent shadows on Dask "
                           "workers")
        if reasons and backend == "compiled":
            if own:
                ps.close()
            if runner is not None:
                runner.close()
            raise RenderError("render: backend='compiled' does not cover " + "; ".join(reasons)
                              + " (backend='auto' renders them on the NumPy path)")
        if not reasons and runner is not None:       # the tiles on the Dask workers
            use_processes(parallel, 1, 1)
            try:
                return render_compiled_dask(runner, cam, seed=seed, max_depth=max_depth,
                                            throughput_cutoff=throughput_cutoff, offset=offset,
                                            split_depth=split_depth, cancel=cancel, nonfinite=nonfinite,
                                            progress=progress, t_start=t_start)
            finally:
                runner.close()
        if not reasons:
            integrator_factory(ps, **integ)()     # the same option checks as the NumPy path
            use_processes(parallel, 1, 1)         # ... and of ``parallel``
            try:
                return render_compiled(ps, cam, seed=seed, max_depth=max_depth, throughput_cutoff=throughput_cutoff,
                                       offset=offset, split_depth=split_depth, threads=threads, cancel=cancel,
                                       fill=fill, nonfinite=nonfinite, progress=progress, t_start=t_start,
                                       aovs=aovs, integ=integ)
            finally:
                if runner is not None:
                    runner.close()
                if own:
                    ps.close()
    make_integrator = None if ps is None else integrator_factory(ps, record_rays=record_rays, **integ)
    workers = 1 if ps is None else max(1, min(ps.accel.threads if threads is None else int(threads), n_chunks))
    processes = use_processes(parallel, workers, n_chunks) and runner is None

    def run_chunk(ci):
        if processes:   # the worker's writes stay in the worker: the chunk's pixels come back as a film
            lo, hi = chunk_pixels(ci)
            part = None if split else Film(hi - lo, 1, aovs=aovs, nonfinite=nonfinite)
            st, piece = shade_fixed_chunk(ps, cam, make_integrator, seed, ci, layout, part, lo, aovs, nonfinite)
            return st, piece if split else part
        return shade_fixed_chunk(ps, cam, make_integrator, seed, ci, layout, film, 0, aovs, nonfinite)

    def halted():
        return cancel is not None and cancel.is_set()

    pieces_done = np.zeros(n_pix, dtype=np.int64)     # per pixel: its chunks finished (all: ``pieces``)
    done = {"chunks": 0, "samples": 0}
    stats = RenderStats()

    def collect(ci, res):
        st, part = res
        lo, hi = chunk_pixels(ci)
        if part is not None:
            film.add_film(part, lo)
        pieces_done[lo:hi] += 1
        done["chunks"] += 1
        done["samples"] += int(part.weight[0]) if split else (hi - lo) * S
        merge_stats(stats, st)

    bar = progress_bar(progress, total=n_chunks, desc="render", unit="chunk", leave=False)
    t_chunks = time.perf_counter()
    try:
        if runner is not None:
            spec = dict(threads=1, layout=layout, seed=seed, aovs=aovs, nonfinite=nonfinite,
                        integrator=dict(integ, record_rays=record_rays))
            _run_dask(runner, cam, spec, n_chunks, cancel, bar, film, collect)
        else:
            with ChunkPool(run_chunk, workers, processes=processes, prepared=ps) as pool:
                pool.map([(ci,) for ci in range(n_chunks)], bar, collect, halted)
    except BaseException:
        if own:
            ps.close()
        raise
    finally:
        bar.close()
        if runner is not None:
            runner.close()
    pixels_done = int(np.count_nonzero(pieces_done == pieces))
    unstarted = pieces_done == 0
    n_unstarted = int(np.count_nonzero(unstarted))
    pixels_filled = 0
    if fill and ps is not None and n_unstarted and done["samples"]:
        # wall seconds per sample of the chunks so far (the fill gives the pixels with no sample one sample each);
        # the fill stops at its deadline whatever the estimate said, its unfinished pixels left black
        rate = (time.perf_counter() - t_chunks) / done["samples"]
        if n_unstarted * rate <= fill_budget:
            deadline = time.perf_counter() + fill_budget
            cam1 = copy(cam)
            cam1.spp = 1
            fps = ps
            fill_make = integrator_factory(ps, **integ)
            jobs = _fill_jobs(unstarted, chunk_samples)
            filled = []

            def fill_chunk(k):
                lo, hi, key = jobs[k]
                integ = fill_make()
                rng = np.random.default_rng([seed, key, 1])
                rays = cam1.generate_rays(lo, hi, rng, differentials=fps.needs_differentials)
                L, a = integ.render_samples(rays, want_aovs=aovs, rng=rng)
                integ.stats.nonfinite_samples += film.add_block(lo, hi, L, a)
                return integ.stats

            def fill_done(k, st):
                merge_stats(stats, st)
                filled.append(jobs[k][1] - jobs[k][0])

            fill_bar = progress_bar(progress, total=len(jobs), desc="fill", unit="chunk", leave=False)
            try:
                with ChunkPool(fill_chunk, workers) as pool:     # threads: the chunks write into ``film``
                    pool.map([(k,) for k in range(len(jobs))], fill_bar, fill_done,
                             lambda: time.perf_counter() > deadline)
            finally:
                fill_bar.close()
                if own:
                    ps.close()
            pixels_filled = sum(filled)
    if own:
        ps.close()
    if stats.nonfinite_samples:
        warnings.warn(f"render: {stats.nonfinite_samples} samples had non-finite radiance and were "
                      "set to 0 (this is a bug; please report the scene)", RuntimeWarning, stacklevel=4)
    stats.time_total = time.perf_counter() - t_start
    stats.fallback_reasons = reasons
    return RenderResult(image=film.image(), aovs=film.aovs(), stats=stats, film=film,
                        complete=done["chunks"] == n_chunks, chunks_done=done["chunks"], chunks_total=n_chunks,
                        pixels_done=pixels_done, pixels_filled=pixels_filled, samples_done=done["samples"])


def _run_dask(runner, cam, spec, n_chunks, cancel, bar, film, collect):
    """The chunks as Dask tasks (runs of consecutive chunks), merged in chunk order; on ``cancel`` the tasks
    not collected yet are cancelled (their chunks stay unrendered)."""
    tasks = [(g, runner.submit(fixed_group, cam, runner.token, spec, g)) for g in runner.groups(n_chunks)]
    for k, (g, fut) in enumerate(tasks):
        if cancel is not None and cancel.is_set():
            for _, f in tasks[k:]:
                f.cancel()
            return
        lo, part, results = fut.result()
        film.add_film(part, lo)           # whole-pixel chunks (zeros where the run holds pieces)
        for ci, res in zip(g, results):
            collect(ci, res)
        bar.update(len(g))


def _fill_jobs(unstarted, chunk_samples):
    """The fill pass's ``(lo, hi, stream key)``: the runs of pixels with no sample (``unstarted``), cut at
    ``chunk_samples`` pixels (one sample each: as many samples as a render chunk; key: the run's first pixel).
    Jobs of whole chunks instead would be thousands of tiny ones at high spp (128 pixels at 256 spp), whose
    per-job cost made a 1280x960, 256-spp fill take ~20 s."""
    idx = np.flatnonzero(unstarted)
    cuts = np.flatnonzero(np.diff(idx) != 1) + 1
    jobs = []
    for run in np.split(idx, cuts):
        for lo in range(int(run[0]), int(run[-1]) + 1, chunk_samples):
            jobs.append((lo, min(lo + chunk_samples, int(run[-1]) + 1), lo))
    return jobs


def render(scene, *, spp=None, seed=0, integrator="whitted", sampling=None, output=None, execution=None,
           **keywords):
    """Render ``scene`` to linear radiance: ``pyrt.render(scene, spp=4)``.

    Parameters
    ----------
    scene : pyrt.Scene
    spp : int, optional
        Samples per pixel (default: the camera's).
    seed : int
        Random seed; the same seed gives a bit-identical image.
    integrator, sampling, output, execution
        The option objects of :func:`render_full` (:mod:`pyrt.render.settings`): e.g.
        ``integrator=pyrt.Glossy(samples=4)``, ``sampling=pyrt.Sampling(target_error=1e-3)``,
        ``execution=pyrt.Execution(threads=1, backend="numpy")``.
    **keywords
        The flat keywords of earlier releases, with a ``DeprecationWarning`` naming the new spelling.

    Returns
    -------
    (H, W, 3) float32 ndarray
        Linear scene radiance (W m^-2 sr^-1 per RGB channel). :func:`render_full` returns the whole
        :class:`RenderResult` (AOVs, statistics, whether a cancelled render is complete).
    """
    return _render_options(scene, spp, seed, integrator, sampling, output, execution, keywords,
                           stacklevel=3).image
