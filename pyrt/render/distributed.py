"""Renders on Dask (``render(..., execution=pyrt.Execution(dask=client_or_address))``):
a pass's chunks run as tasks on the workers, the
client merges them in chunk order.

- The scene is pickled once and broadcast to the workers (``client.scatter``); each worker process prepares
  it (BVH) once per render and keeps it until the render ends (:func:`worker_prepared`, released on every
  worker at the end).
- A task is a run of consecutive chunks (:func:`fixed_group`, :func:`adaptive_group`), shaded by exactly
  the functions a local thread runs (:mod:`pyrt.render.chunks`): the same pixels, sample positions and
  random streams. The client adds the returned sums in chunk order, so the image equals the local render
  with the same seed (bit for bit: the same float64 additions in the same order).
- Adaptive renders decide every pass's sample map on the client, from the merged film.
- Renders the compiled kernel covers (:func:`pyrt.integrators.compiled.unsupported`, decided on the client from the
  scene) run as groups of tiles (:func:`compiled_tiles`), each worker compiling the kernel once or loading it from
  its kernel cache; the image equals the local compiled render bit for bit.

``dask``: a ``distributed.Client``, a scheduler address (``"tcp://host:8786"``), or True for a
``LocalCluster`` of ``n_workers`` single-threaded worker processes. Needs the ``preview`` extra
(dask[distributed]). Cancellation and the time budget stop at task granularity (tasks not started are
cancelled); the pixels of a cancelled fixed-spp render that no task finished are black (no fill on Dask).
"""
from __future__ import annotations

import os
import uuid

import numpy as np

from pyrt.core.errors import RenderError
from pyrt.core.film import Film
from pyrt.integrators import compiled
from pyrt.integrators.prepared import PreparedScene
from pyrt.render.chunks import shade_adaptive_chunk, shade_fixed_chunk
from pyrt.render.pool import integrator_factory

#: per worker process: render token -> PreparedScene
_PREPARED = {}
#: tasks per worker and pass (more: finer cancellation and balance; fewer: less per-task overhead)
TASKS_PER_WORKER = 4


def worker_prepared(token, scene, threads):
    """The worker's prepared scene for the render ``token`` (built on first use)."""
    ps = _PREPARED.get(token)
    if ps is None:
        ps = _PREPARED[token] = PreparedScene(scene, threads=threads)
    return ps


def release(token):
    """Close and forget the worker's prepared scene of the render ``token`` (run on every worker)."""
    ps = _PREPARED.pop(token, None)
    if ps is not None:
        ps.close()
    return os.getpid()


def fixed_group(scene, cam, token, spec, cis):
    """Worker task: the fixed-spp chunks ``cis`` (consecutive). Returns ``(lo, film, results)``: whole-pixel
    chunks in ``film`` (pixels ``lo ..``), and per chunk ``(stats, part)`` as :func:`shade_fixed_chunk`."""
    ps = worker_prepared(token, scene, spec["threads"])
    make = integrator_factory(ps, **spec["integrator"])
    layout = spec["layout"]
    lo, hi = layout.pixels(cis[0])[0], layout.pixels(cis[-1])[1]
    film = Film(hi - lo, 1, aovs=spec["aovs"], nonfinite=spec["nonfinite"])
    out = [shade_fixed_chunk(ps, cam, make, spec["seed"], ci, layout, film, lo, spec["aovs"], spec["nonfinite"])
           for ci in cis]
    return lo, film, out


def compiled_tiles(scene, cam, token, spec, tiles):
    """Worker task of a compiled render: the tiles ``tiles`` (:func:`pyrt.integrators.compiled.render_fixed` on one
    Numba thread: the worker processes are the parallelism). Returns ``(pixels, sums (k, 3), counters (4,))`` for the
    pixels of those tiles: per pixel the same float64 sum as a local compiled render (its samples are keyed on the
    pixel), so the merged image equals the local one bit for bit."""
    ps = worker_prepared(token, scene, spec["threads"])
    sums, _sq, counters, done = compiled.render_fixed(compiled.CompiledScene(ps), cam, tiles=tiles, threads=1,
                                                      **spec["compiled"])
    pix = np.flatnonzero(compiled.pixel_mask(done, cam.width, cam.height))
    return pix, sums[pix], counters


def adaptive_group(scene, cam, token, spec, index, items):
    """Worker task: chunks of adaptive pass ``index``; ``items`` = ``(key, P, C, base, spp_after)`` each.
    Returns the list of :func:`shade_adaptive_chunk` results."""
    ps = worker_prepared(token, scene, spec["threads"])
    make = integrator_factory(ps, **spec["integrator"])
    return [shade_adaptive_chunk(ps, cam, make, spec["seed"], index, key, P, C, base, spp_after, spec["aovs"],
                                 spec["nonfinite"]) for key, P, C, base, spp_after in items]


class DaskRunner:
    """The client side: connection, the broadcast scene, task submission and cleanup."""

    def __init__(self, dask, scene, n_workers=2):
        try:
            import distributed
        except ImportError as exc:
            raise RenderError(f"render: dask= needs the packages dask and distributed ({exc}): "
                              "pip install 'pyrt-embree[preview]'") from None
        self._cluster = None
        self._own = True
        if isinstance(dask, distributed.Client):
            self.client, self._own = dask, False
        elif dask is True:
            self._cluster = distributed.LocalCluster(n_workers=n_workers, threads_per_worker=1, processes=True,
                                                     dashboard_address=None)
            self.client = distributed.Client(self._cluster)
        elif isinstance(dask, str):
            self.client = distributed.Client(dask)
        else:
            raise RenderError(f"render: dask must be a distributed.Client, a scheduler address or True, "
                              f"got {dask!r}")
        self.token = uuid.uuid4().hex
        self.n_workers = max(1, len(self.client.scheduler_info().get("workers", {})))
        self.scene = self.client.scatter(scene, broadcast=True, hash=False)

    def groups(self, n):
        """Split ``range(n)`` into consecutive runs, about :data:`TASKS_PER_WORKER` per worker."""
        g = max(1, min(n, TASKS_PER_WORKER * self.n_workers))
        bounds = [round(i * n / g) for i in range(g + 1)]
        return [list(range(bounds[i], bounds[i + 1])) for i in range(g) if bounds[i + 1] > bounds[i]]

    def submit(self, fn, *args):
        """Submit a task (not pure: every call renders)."""
        return self.client.submit(fn, self.scene, *args, pure=False)

    def close(self):
        """Release the workers' prepared scenes; close what this runner opened."""
        try:
            self.client.run(release, self.token)
        finally:
            if self._own:
                self.client.close()
                if self._cluster is not None:
                    self._cluster.close()
