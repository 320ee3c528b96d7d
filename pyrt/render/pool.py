"""The chunk pool every render runs on: chunks shaded on worker threads, collected in index order.

Collecting in index order on the caller's thread is what makes images independent of the thread count
(float64 sums added in a fixed order); at most ``WINDOW`` chunks per worker are in flight, so memory does not
grow with the number of chunks.
"""
from __future__ import annotations

from collections import deque
from concurrent.futures import ThreadPoolExecutor

from pyrt.core.errors import RenderError
from pyrt.integrators.glossy import GlossyIntegrator
from pyrt.integrators.whitted import Integrator

#: ``integrator=`` names: strict Whitted (delta lobes only, the default) and glossy reflection rays
INTEGRATORS = ("whitted", "glossy")


def merge_stats(stats, st):
    """Add a chunk's statistics to ``stats`` (called in chunk order: deterministic; nothing kept per chunk)."""
    for k in ("primary_rays", "secondary_rays", "shadow_rays", "time_intersect", "time_occluded",
              "nonfinite_samples"):
        setattr(stats, k, getattr(stats, k) + getattr(st, k))
    stats.recorded.extend(st.recorded)


#: chunks in flight per worker thread: enough that a slow chunk at the head of the in-order collection does not
#: leave the other workers idle, few enough that memory stays bounded (a chunk's pending result is its
#: statistics and, above chunk_samples spp, a 1-pixel film)
WINDOW = 16


def run_pool(run, n, workers, abort, bar, collect, stopped=None):
    """``collect(ci, run(ci))`` for ``ci`` in ``0 .. n - 1``, in index order, ``run`` on ``workers`` threads.

    At most ``WINDOW * workers`` chunks are queued or waiting to be collected at a time (memory does not grow
    with the number of chunks). Once ``stopped`` is set no further chunk is submitted. On any exception in
    the caller's thread (a ``KeyboardInterrupt`` above all) or in a chunk: set ``abort``, cancel the chunks
    not started, wait for the running ones and re-raise; the pool is shut down in every case.
    """
    if workers == 1:
        for ci in range(n):
            collect(ci, run(ci))
            bar.update()
            if stopped is not None and stopped.is_set():
                return
        return
    pool = ThreadPoolExecutor(max_workers=workers)
    try:
        window = deque()
        nxt = 0
        while window or nxt < n:
            while nxt < n and len(window) < WINDOW * workers and not (stopped is not None and stopped.is_set()):
                window.append((nxt, pool.submit(run, nxt)))
                nxt += 1
            if not window:
                break
            ci, f = window.popleft()
            collect(ci, f.result())
            bar.update()
    except BaseException:
        abort.set()
        pool.shutdown(wait=True, cancel_futures=True)
        raise
    pool.shutdown(wait=True)


def integrator_factory(ps, integrator, *, max_depth, throughput_cutoff, offset, record_rays=False,
                       transparent_shadows=False, glossy_samples=4, glossy_depth=2, glossy_threshold=0.4,
                       split_depth=None, light_select_depth=None):
    """A function of no argument returning a fresh integrator for one chunk (``"whitted"`` or ``"glossy"``)
    over the prepared scene ``ps``; :class:`RenderError` for another name."""
    if integrator not in INTEGRATORS:
        raise RenderError(f"render: integrator must be one of {sorted(INTEGRATORS)}, got {integrator!r}")
    extra = {}
    if integrator == "glossy":
        extra = dict(glossy_samples=glossy_samples, glossy_depth=glossy_depth, glossy_threshold=glossy_threshold)
    cls = GlossyIntegrator if integrator == "glossy" else Integrator

    def make():
        return cls(ps, max_depth=max_depth, throughput_cutoff=throughput_cutoff, offset=offset,
                   record_rays=record_rays, transparent_shadows=transparent_shadows, split_depth=split_depth,
                   light_select_depth=light_select_depth, **extra)
    return make
