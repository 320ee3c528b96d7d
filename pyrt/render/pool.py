"""The chunk pool every render runs on: chunks shaded by worker threads or forked worker processes, collected
in index order.

Collecting in index order on the caller's thread is what makes images independent of the number of workers and
of their kind (float64 sums added in a fixed order); at most ``WINDOW`` chunks per worker are in flight, so
memory does not grow with the number of chunks.

**Threads or processes.** Embree's traversal and NumPy's array loops release the GIL, but the shading of a chunk
is many NumPy calls on arrays of a few hundred to a few thousand rays (per material, light and bounce), whose
Python-level work holds it: on the glTF previews two threads used 1.1-1.4 of the 2 cores (ClearCoatTest: render
12.65 s on one thread, 11.19 s on two). Forked worker processes (``parallel="processes"``, and "auto" on Linux
for renders of at least :data:`PROCESS_MIN_CHUNKS` chunks) do not share a GIL. They are forked once per
render, after the scene is prepared (the BVH built), so they inherit the prepared scene, the camera and the
integrator settings copy-on-write, without pickling or rebuilding anything; a task sends only its arguments (a
chunk index, or an adaptive pass's pixels) and gets back the chunk's pixel sums and statistics. The textures' MIP
pyramids are built before the fork (:meth:`PreparedScene.before_fork`: one shared copy instead of one per worker);
whatever else a worker builds lazily during the render (an emitter's Embree scene) it builds for itself.
Workers ignore SIGINT: a Ctrl-C reaches the parent, which stops submitting chunks and waits for the running ones.
"""
from __future__ import annotations

from collections import deque
from concurrent.futures import ThreadPoolExecutor
from concurrent.futures.process import BrokenProcessPool, ProcessPoolExecutor
import itertools
import multiprocessing
import signal
import sys
import warnings

from pyrt.core.errors import RenderError
from pyrt.core.memory import release_free_memory
from pyrt.integrators.glossy import GlossyIntegrator
from pyrt.integrators.whitted import DEFAULT_SPLIT_DEPTH, Integrator

class _NoBar:
    """What :func:`progress_bar` returns when no bar is wanted: the calls the renderers make, doing nothing."""

    def update(self, n=1):
        pass

    def set_description(self, desc=None, refresh=True):
        pass

    def set_postfix_str(self, s="", refresh=True):
        pass

    def close(self):
        pass


def progress_bar(progress, **kwargs):
    """A ``tqdm.auto`` bar (``progress`` True: shown; None: on a terminal only) or, for ``progress=False``, one
    that does nothing without importing tqdm (~0.05 s of start-up the previewer, which shows no bar, need not
    pay)."""
    if progress is False:
        return _NoBar()
    from tqdm.auto import tqdm

    return tqdm(disable=None if progress is None else not progress, **kwargs)


#: ``integrator=`` names: strict Whitted (delta lobes only, the default) and glossy reflection rays
INTEGRATORS = ("whitted", "glossy")
#: ``parallel=`` choices: "auto" (processes on Linux for renders of at least PROCESS_MIN_CHUNKS chunks, see
#: :func:`use_processes`; threads otherwise)
PARALLEL = ("auto", "threads", "processes")


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
#: chunks in flight per worker process: every one is a pending result (the chunk's pixel sums) and a
#: cancellation waits for them, so fewer than threads; 4 keep both workers busy behind a slow head chunk
PROCESS_WINDOW = 4


#: "auto" forks worker processes for renders of at least this many chunks: forking, the workers' cold heaps and
#: the results' transfer cost ~50 ms of wall and ~0.1 s of CPU per render (tools/bench_parallel.py --rounds 3: the
#: 1-spp bench scene, 10 chunks, 0.262 s and 0.48 CPU s on processes against 0.213 s and 0.37 s on threads), which
#: only longer renders repay. The 38-chunk diffuse and shadowed kinds of tools/bench_kinds.py at 16 spp still lose
#: (x1.20-1.22); the previews, 38 chunks of costlier shading, gain (x0.48-0.67)
PROCESS_MIN_CHUNKS = 16


def use_processes(parallel, workers, chunks=None):
    """Whether a render of ``chunks`` chunks (None: unknown) on ``workers`` workers runs on processes, for
    ``parallel`` (:data:`PARALLEL`): "processes" wherever fork is; "auto" on Linux for renders of at least
    :data:`PROCESS_MIN_CHUNKS` chunks, except in a daemonic process (which may not have children)."""
    if parallel not in PARALLEL:
        raise RenderError(f"render: parallel must be one of {list(PARALLEL)}, got {parallel!r}")
    if workers <= 1 or parallel == "threads":
        return False
    fork = "fork" in multiprocessing.get_all_start_methods()
    if parallel == "processes":
        if not fork:
            raise RenderError(f"render: parallel='processes' needs the fork start method, which {sys.platform} "
                              "does not have; use parallel='threads'")
        return True
    if chunks is not None and chunks < PROCESS_MIN_CHUNKS:
        return False
    return fork and sys.platform.startswith("linux") and not multiprocessing.current_process().daemon


#: per render: token -> (task, prepared scene); read by the forked workers, which inherit it
_TASKS = {}
_TOKENS = itertools.count()


def _child_init(token):
    """A worker process's start: SIGINT is the parent's business; the inherited accelerator's thread pool has no
    threads in this process, so its batch queries run on the worker's own thread."""
    signal.signal(signal.SIGINT, signal.SIG_IGN)
    ps = _TASKS[token][1]
    if ps is not None:
        ps.accel.single_threaded()


def _child_run(token, args):
    return _TASKS[token][0](*args)


class ChunkPool:
    """``collect(i, task(*args[i]))`` for every ``i`` in index order, on ``workers`` threads or processes.

    Use as a context manager: processes are forked at :meth:`__enter__` (after ``prepared``, the scene the
    tasks read, is built) and end at :meth:`__exit__`; one pool serves every :meth:`map` of a render (the
    passes of an adaptive render).

    Parameters
    ----------
    task : callable
        ``task(*args)`` shades one chunk. In processes its result is pickled back; it must not write into
        the caller's objects (a worker's writes stay in the worker).
    workers : int
    processes : bool
        Forked processes instead of threads (see the module docstring); needs the ``fork`` start method.
    prepared : PreparedScene, optional
        The prepared scene ``task`` reads (its accelerator is made single-threaded in the workers).
    """

    def __init__(self, task, workers, *, processes=False, prepared=None):
        self.task, self.workers, self.processes, self.prepared = task, max(1, int(workers)), processes, prepared
        self._pool = None
        self._token = None

    def __enter__(self):
        if self.workers > 1:
            if self.processes:
                if self.prepared is not None:
                    self.prepared.before_fork()
                release_free_memory()         # free heap pages would be copied by the workers that reuse them
                self._token = next(_TOKENS)
                _TASKS[self._token] = (self.task, self.prepared)
                self._pool = ProcessPoolExecutor(self.workers, mp_context=multiprocessing.get_context("fork"),
                                                 initializer=_child_init, initargs=(self._token,))
                # fork the workers now (the first submit does): Python >= 3.12 warns at a fork of a process
                # with threads (Embree's, BLAS's idle pools are always there) that a lock one of them holds
                # could deadlock the child; the workers run only the chunks' code, which takes none of them
                with warnings.catch_warnings():
                    warnings.filterwarnings("ignore", message=r".*use of fork\(\) may lead to deadlocks",
                                            category=DeprecationWarning)
                    self._pool.submit(int).result()
            else:
                self._pool = ThreadPoolExecutor(max_workers=self.workers)
        return self

    def __exit__(self, *exc):
        self.close()

    def close(self, cancel=False):
        """Shut the workers down (waiting for running chunks; ``cancel``: the queued ones are dropped)."""
        if self._pool is not None:
            self._pool.shutdown(wait=True, cancel_futures=cancel)
            self._pool = None
        _TASKS.pop(self._token, None)

    def _submit(self, args, halted):
        if self.processes:
            return self._pool.submit(_child_run, self._token, args)
        if halted is None:
            return self._pool.submit(self.task, *args)

        def guarded():
            return None if halted() else self.task(*args)
        return self._pool.submit(guarded)

    def map(self, args, bar, collect, halted=None):
        """Run the tasks ``args`` (a sequence of argument tuples); ``collect(i, result)`` in index order.

        ``halted()``, when given, is asked before every task starts (by the worker thread; for processes by
        the caller, at submission): once it is true no further task is submitted, and a task that saw it
        gives ``None``, which is not collected. Returns True when every task ran.

        On any exception in the caller's thread (a ``KeyboardInterrupt`` above all) or in a task: the tasks
        not started are cancelled, the running ones waited for, the pool shut down, and the exception
        re-raised (a worker process that died is a :class:`RenderError`).
        """
        n = len(args)
        if self._pool is None:
            for i in range(n):
                res = None if halted is not None and halted() else self.task(*args[i])
                if res is None:
                    return False
                collect(i, res)
                bar.update()
            return True
        window = deque()
        limit = (PROCESS_WINDOW if self.processes else WINDOW) * self.workers
        nxt, stopped = 0, False
        try:
            while window or nxt < n:
                while nxt < n and len(window) < limit and not stopped:
                    if halted is not None and self.processes and halted():
                        stopped = True
                        break
                    window.append((nxt, self._submit(args[nxt], halted)))
                    nxt += 1
                if not window:
                    break
                i, f = window.popleft()
                res = f.result()
                if res is None:
                    stopped = True
                    continue
                collect(i, res)
                bar.update()
        except BrokenProcessPool as exc:
            self.close(cancel=True)
            raise RenderError(f"render: a worker process died ({exc}); parallel='threads' renders without "
                              "them") from None
        except BaseException:
            self.close(cancel=True)
            raise
        return not stopped and nxt == n


def integrator_factory(ps, integrator, *, max_depth, throughput_cutoff, offset, roulette=False, record_rays=False,
                       transparent_shadows=False, glossy_samples=4, glossy_depth=2, glossy_threshold=0.4,
                       glossy_clamp=None, split_depth=DEFAULT_SPLIT_DEPTH, light_select_depth=None, batch_rays=None,
                       sampler="padded"):
    """A function of no argument returning a fresh integrator for one chunk (``"whitted"`` or ``"glossy"``)
    over the prepared scene ``ps``; :class:`RenderError` for another name."""
    if integrator not in INTEGRATORS:
        raise RenderError(f"render: integrator must be one of {sorted(INTEGRATORS)}, got {integrator!r}")
    extra = {}
    if integrator == "glossy":
        extra = dict(glossy_samples=glossy_samples, glossy_depth=glossy_depth, glossy_threshold=glossy_threshold,
                     glossy_clamp=glossy_clamp)
    cls = GlossyIntegrator if integrator == "glossy" else Integrator

    def make():
        return cls(ps, max_depth=max_depth, throughput_cutoff=throughput_cutoff, roulette=roulette, offset=offset,
                   record_rays=record_rays, transparent_shadows=transparent_shadows, split_depth=split_depth,
                   light_select_depth=light_select_depth, batch_rays=batch_rays, sampler=sampler, **extra)
    return make
