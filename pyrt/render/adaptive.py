"""Adaptive, progressive rendering: passes of camera samples, spent where the estimated error is high.

How it works (:func:`render_adaptive`;
``pyrt.render(scene, sampling=pyrt.Sampling(target_error=..., time_budget=..., max_spp=...))``):

1. **Two interleaved half-buffers.** Every pass gives a pixel an even number ``c`` of new samples, ``c / 2``
   to half A and ``c / 2`` to half B. Each half of each pixel draws its positions from its own
   Owen-scrambled Sobol' sequence (:func:`pyrt.core.sampler.sobol_owen_2d`), continued where the last pass
   stopped, so a half's samples stay one stratified set however the passes split them. The film holds A + B; a second film holds B alone. The two half means are independent
   unbiased estimates with equal sample counts, so ``(mean_A - mean_B)^2 / 4`` estimates the variance of
   the pixel's mean *including* what stratification buys (a sample variance would ignore it and overstate
   the error of a stratified pixel several-fold).
2. **The error estimate** is the relMSE of :mod:`pyrt.core.metrics` with that variance:
   ``mean over pixels of mean over channels of var / (mean^2 + 1e-2)``, with each pixel's per-sample error
   ``a_p = var_p n_p / (mean^2 + 1e-2)`` raised to ``NEIGHBOURHOOD`` (0.6) of its 5 x 5 neighbourhood's mean where
   that is higher (:func:`~pyrt.render.pass_plan.estimated_error`). It is what ``target_error`` is compared with. Why the neighbourhood:
   a pixel's two halves of 1-2 samples agree by chance more often than not on an edge (all its samples on one
   side), its estimate is then 0, the allocation gives it no more samples, and it stays 0 while its error is real.
   Measured (the scenes of ``tools/bench_mitsuba.py`` at 160 x 120, targets at Mitsuba llvm's 64- and 256-spp
   errors, 3 seeds each, against 1024- (diffuse, shadowed) or 512-spp pyrt references), true / estimated relMSE:
   pixel estimates alone 1.35-2.9 (diffuse, shadowed) and up to 4.5 (default scene); with the floor (0.6, and
   ``MIN_GROWTH`` 0.25): diffuse 0.79-2.17, shadowed 0.88-1.28, mirror/glass 0.82-1.69, sky 0.80-0.90, default
   0.94-1.99 and one seed of its tighter target 3.88 (a rare pixel, also the worst without the floor). The two
   tests' scenes at 0.5 / 0.6 / 0.7: test scene 0.63-1.52 / 0.51-1.15 / 0.48-1.09, edge scene 0.98-2.32 /
   0.61-1.67 / 0.57-1.58 (8 renders each). With uniform allocation (``min_spp = max_spp``) the pixel estimates are
   unbiased: true / estimated 0.94-1.07 at 16 and 64 spp.
3. **Allocation.** For a total of ``M`` samples, the relMSE ``(1/n) sum_p a_p / n_p`` (``a_p`` the
   per-sample relative variance of pixel ``p``) is smallest with ``n_p`` proportional to ``sqrt(a_p)``. After
   the base pass (``min_spp`` everywhere) each pass computes ``a_p`` from the half-buffers, smooths it over
   5 x 5 pixels (one pixel's estimate has 3 degrees of freedom: too noisy alone; Dammertz et al. 2010 and
   pbrt's adaptive samplers likewise decide over blocks), dilates it (every pixel counts at least the largest
   ``sqrt(a)`` of the 3 x 3 pixels around it, :data:`~pyrt.render.pass_plan.DILATE_RADIUS`), and gives every pixel what brings it towards its
   share of the new total (90 % of it by ``sqrt(a_p)``, 10 % uniform: ``DEFENSIVE``, so no pixel is starved
   by an estimate that is 0 by chance), at most 3 x the samples it has (a pixel's estimate may be low by chance) and
   never past ``max_spp``. A pass at most doubles the samples. With a target, the first pass after the base asks
   for the samples the estimate predicts are needed (``M = (sum_p sqrt(a_p))^2 / (n target)``, the floored ``a_p``
   of step 2) and 10 % more, at least ``MIN_GROWTH`` (25 %) of the samples so far: with the raw ``a_p`` and 5 % the
   renders of ``tools/adaptive_chart.py`` ended in 9-13 passes of a few percent each, each pass a few ms of its own.
   The later passes are sized by a prediction (:func:`~pyrt.render.pass_plan.plan_samples`): after an allocation ``new_p`` the estimate
   would be ``mean_p a_p / (n_p + new_p)`` if each pixel's per-sample error stayed ``a_p``; it falls faster than
   that (stratified samples converge faster than ``1 / n``, and the floor's neighbourhoods converge with their
   pixels): as ``before (predicted / before)^k``, ``k`` 1.27-1.59 over the benchmark scenes' passes. Each pass
   measures its ``k`` against its own prediction, and the next takes the fewest samples whose prediction so
   corrected (``k`` at most :data:`~pyrt.render.pass_plan.MAX_FALL_POWER`, 1.3) brings the estimate to :data:`~pyrt.render.pass_plan.PLAN_MARGIN` (0.85) of the
   target, at least :data:`~pyrt.render.pass_plan.PLAN_MIN` (5 %) of the samples so far (where doubling would not reach it: the first
   pass's rule). With ``MIN_GROWTH`` alone the last pass often overshot (the diffuse bench scene: an estimate of
   3.5e-6 for a target of 1.27e-5 after a pass of 96 k samples where ~20 k did). Measured on the five scenes of
   ``tools/bench_mitsuba.py`` at 320 x 240, Mitsuba llvm's 64- and 256-spp errors as targets, seeds 1-3, one thread,
   against 512- / 1024-spp pyrt references: 8-16 % fewer samples on 7 of the 10 (scene, target) pairs, the same on
   the 2 that stop after one pass and 5 % more on one (diffuse at its 256-spp error), CPU seconds 0.78-0.97x of the
   rule before (medians of 3 interleaved rounds; 3.18 -> 2.70 s over the 30 renders), true / target 0.58-1.00 on
   average per pair (0.26-1.00 before) and true / estimated 0.74-1.14.

   Why the dilation: on an edge about half the base pass's pixels have halves that agree (estimate 0); box
   smoothing gives them only what their 5 x 5 box holds (the middle of a run of them: nothing), so they kept their
   base samples while their detected neighbours converged, and at tight targets held most of the error the estimate no longer saw (the
   shadowed scene at 320 x 240, target 2.31e-5: true / estimated 2.5-3.7; one n = 4 pixel held 43 % of the diffuse
   scene's error). With the dilation they get their neighbours' samples and are found at the next pass. Measured on
   the five scenes of ``tools/bench_mitsuba.py`` at 320 x 240, its three targets each, seeds 1-3, against 1024-
   (diffuse, shadowed) or 512-spp pyrt references (``tools/adaptive_calibration.py``): true / estimated 0.59-1.80 over the 45 renders (0.65-3.72
   without the dilation and the water filling below), and at the tightest target of the shadowed scene a true
   relMSE of 1.3-1.5e-5 in 0.34-0.41 s against 3.5-5.9e-5 in 0.27-0.29 s.

   How a pass's total is shared: every pixel is brought towards ``lam`` times its share, capped by its room, with
   one ``lam`` for the whole pass found by regula falsi (water filling, :func:`pyrt.render.image_maps.water_fill`).
   Rescaling only the uncapped pixels gave them nothing once the capped ones had taken the total, which after the
   base pass they usually had: the pixels of middling error waited for a later pass.
4. **Stopping**: the estimate at or below ``target_error``, the time budget spent (the pass in progress
   stops starting chunks; its chunks run in a seeded random order so a cut pass is not a band of the image),
   or no pixel can take more samples (``max_spp``), whichever comes first. The base pass always completes.

Deterministic for a seed (chunk streams ``default_rng([seed, 0xADA, pass, chunk])``, chunks added in index
order) whatever the thread count, unless the time budget cuts a pass (then it depends on the machine's speed).

Bias. Deciding where to sample from the samples themselves, and stopping on an estimate, makes the image a
slightly biased estimator (a pixel whose first samples happen to agree gets fewer more): measured in
``tests/test_adaptive.py`` (the mean of many adaptive renders against a converged reference) and in the
README, it is far below the noise of one render.
"""
from __future__ import annotations

from dataclasses import dataclass
import math
import time
import warnings

import numpy as np

from pyrt.core import checks
from pyrt.core.errors import RenderError
from pyrt.core.film import Film
from pyrt.integrators import compiled
from pyrt.integrators.prepared import PreparedScene, RenderStats
from pyrt.integrators.whitted import DEFAULT_SPLIT_DEPTH
from pyrt.render.chunks import shade_adaptive_chunk
from pyrt.render.compiled import adaptive_task, check_backend
from pyrt.render.pass_plan import (MAX_FALL_POWER, MIN_GROWTH, PLAN_MIN, allocation_shares, error_maps, pass_counts,
                                   plan_samples, predicted_error)
from pyrt.render.distributed import DaskRunner, adaptive_group
from pyrt.render.pool import ChunkPool, integrator_factory, merge_stats, progress_bar, use_processes
from pyrt.render.options import check_image_memory, check_options, warn_smooth_lobes
from pyrt.render.result import RenderResult

#: samples per pixel cap when ``max_spp`` is not given
DEFAULT_MAX_SPP = 1 << 16
#: why an adaptive render stopped
STOP_REASONS = ("target_error", "time_budget", "max_spp", "cancelled")


@dataclass
class PassInfo:
    """What ``on_pass`` receives after every pass of an adaptive render.

    Attributes
    ----------
    index : int
        The pass (0: the base pass).
    samples : int
        Camera samples in the film so far.
    mean_spp : float
        ``samples`` per pixel.
    estimated_error : float
        Estimated relMSE of the image now (:mod:`pyrt.render.adaptive`).
    elapsed : float
        Seconds since the render started.
    film : Film
        The film (``film.image()`` is the current image; do not modify it).
    """

    index: int
    samples: int
    mean_spp: float
    estimated_error: float
    elapsed: float
    film: Film


def _positive(name, v):
    """``v`` as a positive finite float, or None; RenderError otherwise."""
    if v is None:
        return None
    x = checks.finite_number("render", name, v, RenderError)
    if not x > 0:
        raise RenderError(f"render: {name} must be > 0, got {v!r}")
    return float(x)


def _chunks(counts, chunk_samples):
    """The pass's chunks: lists of (pixels, counts), whole pixels, starting every ``chunk_samples`` samples."""
    sel = np.flatnonzero(counts)
    if sel.size == 0:
        return []
    c = counts[sel]
    start = np.cumsum(c) - c
    cid = start // chunk_samples
    cuts = np.flatnonzero(np.diff(cid)) + 1
    return list(zip(np.split(sel, cuts), np.split(c, cuts)))


def render_adaptive(scene, *, target_error=None, time_budget=None, max_spp=None, min_spp=4, seed=0, aovs=False,
                    progress=None, chunk_samples=1 << 15, threads=None, prepared=None, nonfinite="zero",
                    cancel=None, fill=False, fill_budget=2.0, on_pass=None, integrator="whitted", max_depth=8,
                    throughput_cutoff=1e-4, roulette=False, offset=None, record_rays=False, transparent_shadows=False,
                    glossy_samples=4, glossy_depth=2, glossy_threshold=0.4, glossy_clamp=None, dask=None,
                    dask_workers=2, split_depth=DEFAULT_SPLIT_DEPTH, light_select_depth=None, parallel="auto",
                    batch_rays=None, sampler="padded", backend="auto"):
    """Render ``scene`` in adaptive passes until the estimated relMSE is at most ``target_error``, the
    ``time_budget`` (seconds, counted from the call, less the compiled kernel's load: a first run's minutes of
    compiling do not eat the budget) is spent, or no pixel may take more samples
    (``max_spp``): a :class:`RenderResult` with ``passes``, ``estimated_error``, ``stop_reason`` and the film
    (``film.weight``: the samples each pixel got). See the module docstring for the method.

    ``min_spp`` (even, >= 2): the base pass's samples per pixel. ``on_pass(PassInfo)`` is called after each
    pass (the command line's ``--write-every`` writes the current image from it). ``cancel`` / ``fill`` as
    in :func:`pyrt.render_full` (a cancelled base pass leaves pixels without samples; ``fill`` gives them 2).
    ``dask``: run every pass's chunks on Dask workers (:mod:`pyrt.render.distributed`; the sample map of the
    next pass is decided here, from the merged film). The other parameters are those of
    :func:`pyrt.render_full`; ``backend`` as there: the compiled kernel renders the passes' chunks where it covers
    the scene and options (not on Dask workers yet), the same camera rays as the NumPy path.
    """
    t_start = time.perf_counter()
    target_error = _positive("target_error", target_error)
    time_budget = _positive("time_budget", time_budget)
    if target_error is None and time_budget is None:
        raise RenderError("render: adaptive rendering needs target_error or time_budget (max_spp alone would "
                          "render every pixel to max_spp: use spp= for that)")
    seed = check_options(seed=seed, glossy_samples=glossy_samples, glossy_depth=glossy_depth,
                         glossy_threshold=glossy_threshold, glossy_clamp=glossy_clamp)
    warn_smooth_lobes(scene, integrator)
    min_spp = checks.integer("render", "min_spp", min_spp, RenderError)
    if min_spp < 2 or min_spp % 2:
        raise RenderError(f"render: min_spp must be an even integer >= 2 (two half-buffers), got {min_spp!r}")
    max_spp = DEFAULT_MAX_SPP if max_spp is None else checks.integer("render", "max_spp", max_spp, RenderError)
    if max_spp < min_spp:
        raise RenderError(f"render: max_spp ({max_spp}) is below min_spp ({min_spp})")
    chunk_samples = checks.integer("render", "chunk_samples", chunk_samples, RenderError)
    threads = None if threads is None else checks.integer("render", "threads", threads, RenderError)
    scene.camera.validate()
    check_image_memory(scene.camera.width, scene.camera.height, aovs=aovs, films=2)
    integ = dict(integrator=integrator, max_depth=max_depth, throughput_cutoff=throughput_cutoff, roulette=roulette,
                 offset=offset,
                 record_rays=record_rays, transparent_shadows=transparent_shadows, glossy_samples=glossy_samples,
                 glossy_depth=glossy_depth, glossy_threshold=glossy_threshold,
                 glossy_clamp=glossy_clamp, split_depth=split_depth,
                 light_select_depth=light_select_depth, batch_rays=batch_rays, sampler=sampler)
    runner = None if dask is None else DaskRunner(dask, scene, dask_workers)
    own = prepared is None and runner is None
    ps = prepared if prepared is not None or runner is not None else PreparedScene(scene, threads=threads)
    try:
        make = None if ps is None else integrator_factory(ps, **integ)
        reasons = _compiled_reasons(backend, ps, scene, runner, integ, aovs)
        spec = dict(threads=1, seed=seed, aovs=aovs, nonfinite=nonfinite, integrator=integ)
        cam = scene.camera
        workers = 1 if ps is None else (ps.accel.threads if threads is None else int(threads))
        # the base pass's chunks, times 4: the passes after it add at least as many samples again, usually more
        base_chunks = -(-scene.camera.width * scene.camera.height * min_spp // chunk_samples)
        processes = use_processes(parallel, workers, 4 * base_chunks) and runner is None and bool(reasons)
        t_kernel = time.perf_counter()
        kernel = None if reasons else adaptive_task(ps, cam, seed=seed, max_depth=max_depth,
                                                    throughput_cutoff=throughput_cutoff, offset=offset,
                                                    split_depth=split_depth, nonfinite=nonfinite, threads=workers,
                                                    integ=integ)
        t_start += time.perf_counter() - t_kernel       # the kernel's load (a first run: its compile) is not budgeted
        deadline = t_start + time_budget if time_budget is not None else math.inf

        def task(index, key, P, C, base, spp_after, timed):
            if timed and time.perf_counter() >= deadline:
                return None
            return shade_adaptive_chunk(ps, cam, make, seed, index, key, P, C, base, spp_after, aovs, nonfinite)

        # the compiled kernel renders a whole pass in one go (its own threads); the NumPy path's chunks go to a pool
        with ChunkPool(task, 1 if runner is not None or kernel is not None else workers, processes=processes,
                       prepared=ps) as pool:
            res = _passes(cam, ps, pool, t_start, target_error, time_budget, max_spp, min_spp, seed, aovs,
                          progress, max(2, chunk_samples - chunk_samples % 2), nonfinite, cancel, fill,
                          fill_budget, on_pass, runner, spec, kernel)
        res.stats.backend = "numpy" if reasons else "compiled"
        res.stats.fallback_reasons = [r for r in reasons if r != "backend='numpy'"]
        return res
    finally:
        if own:
            ps.close()
        if runner is not None:
            runner.close()


def _compiled_reasons(backend, ps, scene, runner, integ, aovs):
    """Why the passes cannot run on the compiled kernel (:func:`pyrt.integrators.compiled.unsupported`; empty: they
    can); a :class:`RenderError` when ``backend="compiled"`` and there is a reason."""
    if check_backend(backend) == "numpy":
        return ["backend='numpy'"]
    reasons = compiled.unsupported(ps, integrator=integ["integrator"], offset=integ["offset"],
                                   transparent_shadows=integ["transparent_shadows"],
                                   light_select_depth=integ["light_select_depth"],
                                   record_rays=integ["record_rays"], scene=scene, roulette=integ["roulette"],
                                   sampler=integ["sampler"])
    if runner is not None:
        reasons.append("adaptive passes on Dask workers")
    if aovs:
        reasons.append("AOVs with adaptive passes")
    if reasons and backend == "compiled":
        raise RenderError("render: backend='compiled' does not cover " + "; ".join(reasons)
                          + " (backend='auto' renders them on the NumPy path)")
    return reasons


def _passes(cam, ps, pool, t_start, target_error, time_budget, max_spp, min_spp, seed, aovs, progress,
            chunk_samples, nonfinite, cancel, fill, fill_budget, on_pass, runner=None, spec=None, kernel=None):
    """The pass loop of :func:`render_adaptive` (``ps`` prepared, parameters checked; the chunks run on
    ``pool``, a :class:`ChunkPool` of :func:`shade_adaptive_chunk` tasks, or with a Dask ``runner`` on its
    workers, ``spec`` their settings; with ``kernel`` (:func:`pyrt.render.compiled.adaptive_task`) a pass is one
    call of the compiled kernel)."""
    W, H = cam.width, cam.height
    n_pix = W * H
    film = Film(W, H, aovs=aovs, nonfinite=nonfinite)
    half = Film(W, H, nonfinite=nonfinite)           # half B; half A is film - half
    deadline = t_start + time_budget if time_budget is not None else math.inf
    stats = RenderStats()
    bar = progress_bar(progress, desc="pass 0", unit="sample", unit_scale=True, leave=False)
    totals = {"chunks": 0, "chunks_total": 0, "render_s": 0.0}

    def run_pass(counts, index, timed=True, honour_cancel=True, stop_at=math.inf):
        spp_after = film.weight + counts
        base = half.weight.astype(np.int64)             # samples per half so far (A and B have as many)

        def halted():
            return (honour_cancel and cancel is not None and cancel.is_set()) or \
                (timed and time.perf_counter() >= deadline) or time.perf_counter() >= stop_at

        if kernel is not None:
            t0 = time.perf_counter()
            P = np.flatnonzero(counts)
            if P.size:
                st, P, both, b, (blocks_done, blocks) = kernel(P, counts[P], base[P], spp_after[P], halted,
                                                               [seed, 0xADA, index, 1 << 20])
                film.add_pixel_sums(P, both)
                half.add_pixel_sums(P, b)
                merge_stats(stats, st)
                totals["chunks"] += blocks_done
                totals["chunks_total"] += blocks
                bar.update(int(both.weight.sum()))
            totals["render_s"] += time.perf_counter() - t0
            return
        chunks = _chunks(counts, chunk_samples)
        order = np.random.default_rng([seed, 0xADA, index, 1 << 20]).permutation(len(chunks))

        def collect(k, res):
            if res is None:
                return
            st, P, both, b = res
            film.add_pixel_sums(P, both)
            half.add_pixel_sums(P, b)
            merge_stats(stats, st)
            totals["chunks"] += 1
            bar.update(int(both.weight.sum()))

        t0 = time.perf_counter()
        if runner is not None:
            _run_dask_pass(runner, cam, spec, index, chunks, order, base, spp_after, collect, halted)
        else:
            args = []
            for k in range(len(chunks)):
                key = int(order[k])
                P, C = chunks[key]
                args.append((index, key, P, C, base[P], spp_after[P], timed))
            pool.map(args, _NoBar(), collect, halted)
        totals["render_s"] += time.perf_counter() - t0
        totals["chunks_total"] += len(chunks)

    counts = np.full(n_pix, min_spp, dtype=np.int64)
    index, stop, est = 0, None, math.inf
    plan, est_before, k = None, math.inf, None      # the last pass's (predicted, estimate before it), its fall power
    pixels_filled = 0
    try:
        run_pass(counts, 0, timed=False)
        err = None
        while True:
            # after the base pass only the pixels the last pass rendered have changed
            err, box, floored, est = error_maps(film, half, (H, W), None if err is None else np.flatnonzero(counts),
                                                err)
            samples = int(film.weight.sum())
            bar.set_postfix_str(f"spp {samples / n_pix:.1f}, relMSE~{est:.3g}")
            if on_pass is not None:
                on_pass(PassInfo(index, samples, samples / n_pix, est, time.perf_counter() - t_start, film))
            if cancel is not None and cancel.is_set():
                stop = "cancelled"
                break
            if target_error is not None and est <= target_error:
                stop = "target_error"
                break
            now = time.perf_counter()
            if now >= deadline:
                stop = "time_budget"
                break
            total_new = float(samples)                      # at most double
            if plan is not None and 0.0 < plan < est_before and 0.0 < est < est_before:
                # how the estimate fell in the last pass against how it was predicted to: est = before (p / before)^k
                k = min(max(math.log(est / est_before) / math.log(plan / est_before), 1.0), MAX_FALL_POWER)
            share, room = allocation_shares(film, err, max_spp, chunk_samples, (H, W), box)
            planned = None
            if target_error is not None and np.isfinite(est) and k is not None:
                planned = plan_samples(floored, film.weight, share, room, est, target_error, k, PLAN_MIN * samples,
                                       total_new)
            if planned is not None:
                total_new = planned
            elif target_error is not None and np.isfinite(est):
                # the first pass after the base: the samples the estimate asks for (the same floored errors: a
                # prediction from the raw ones stopped short of what the estimate then wanted), at least MIN_GROWTH
                need = np.sqrt(floored[0]).sum() ** 2 / (n_pix * target_error)
                total_new = min(total_new, max(1.1 * need - samples, MIN_GROWTH * samples))
            if math.isfinite(deadline):
                rate = totals["render_s"] / max(samples, 1)
                total_new = min(total_new, (deadline - now) / max(rate, 1e-12))
            if total_new < 2:
                stop = "time_budget"
                break
            rng = np.random.default_rng([seed, 0xADA, index + 1, 1 << 21])
            counts = pass_counts(share, room, film.weight, total_new, rng)
            plan, est_before = predicted_error(floored, film.weight, counts), est
            if not counts.any():
                stop = "max_spp"
                break
            index += 1
            bar.set_description(f"pass {index}")
            run_pass(counts, index)
        empty = film.weight == 0
        if fill and empty.any() and film.weight.sum() > 0:
            rate = totals["render_s"] / film.weight.sum()
            if 2 * empty.sum() * rate <= fill_budget:
                run_pass(np.where(empty, 2, 0).astype(np.int64), index + 1, timed=False, honour_cancel=False,
                         stop_at=time.perf_counter() + fill_budget)      # no chunk starts after the budget
                pixels_filled = int(np.count_nonzero(empty & (film.weight > 0)))
                est = error_maps(film, half, (H, W))[3]
    finally:
        bar.close()
    if stats.nonfinite_samples:
        warnings.warn(f"render: {stats.nonfinite_samples} samples had non-finite radiance and were "
                      "set to 0 (this is a bug; please report the scene)", RuntimeWarning, stacklevel=3)
    stats.time_total = time.perf_counter() - t_start
    samples = int(film.weight.sum())
    return RenderResult(image=film.image(), aovs=film.aovs(), stats=stats, film=film,
                        complete=stop != "cancelled", chunks_done=totals["chunks"],
                        chunks_total=totals["chunks_total"], pixels_done=int(np.count_nonzero(film.weight)),
                        pixels_filled=pixels_filled, samples_done=samples, passes=index + 1,
                        estimated_error=est, stop_reason=stop)


def _run_dask_pass(runner, cam, spec, index, chunks, order, base, spp_after, collect, halted):
    """One pass's chunks as Dask tasks (runs of consecutive chunk indices ``k``, chunk ``order[k]``), collected
    in order; once ``halted()``, the tasks not finished are cancelled (finished ones are still used)."""
    tasks = []
    for g in runner.groups(len(chunks)):
        items = []
        for k in g:
            key = int(order[k])
            P, C = chunks[key]
            items.append((key, P, C, base[P], spp_after[P]))
        tasks.append((g, runner.submit(adaptive_group, cam, runner.token, spec, index, items)))
    for g, fut in tasks:
        if halted() and not fut.done():
            fut.cancel()
            continue
        for k, res in zip(g, fut.result()):
            collect(k, res)


class _NoBar:
    """The pool's per-chunk bar hook (the adaptive bar counts samples in ``collect`` instead)."""

    def update(self, n=1):
        """Nothing: progress is reported per sample by the pass's ``collect``."""
