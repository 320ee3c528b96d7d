"""An adaptive pass on the compiled kernel: :func:`render_pixels` (the entry
:func:`pyrt.integrators.compiled_kernel.render_pixels`, its threads over blocks of the pass's pixels, in calls of
about :data:`pyrt.integrators.compiled.CALL_SECONDS`) and :func:`load_pixel_kernel`."""
from __future__ import annotations

import time
import warnings

import numba
from numba.core.errors import NumbaIRAssumptionWarning
import numpy as np

from pyrt.integrators import compiled_kernel as K
from pyrt.integrators.compiled import (CALL_SECONDS, CHUNKSIZE, FIRST_CALL_TILES, PARALLEL_LOCK, announce_compile,
                                       camera_record, kernel_options, load_kernel, packet_width)

#: samples per block of an adaptive pass (:func:`render_pixels`; a block is a task of the kernel's threads, with
#: packet buffers of its own)
BLOCK_SAMPLES = 4096


def render_pixels(cs, cam, P, C, base, spp_after, *, seed, max_depth, throughput_cutoff, split_depth, terminator,
                  threads=None, order_seed=0, halted=None, block_samples=BLOCK_SAMPLES, call_seconds=CALL_SECONDS):
    """The pixels of an adaptive pass on the compiled kernel (:func:`pyrt.integrators.compiled_kernel.render_pixels`):
    pixels ``P`` with ``C`` (even) new samples each, half to A and half to B, each half's sequence continued at
    ``base`` (samples per half so far); ``spp_after`` (samples per pixel after the pass) scales the ray
    differentials (:meth:`pyrt.core.camera.Camera.rays_at`).

    The rows go in blocks of about ``block_samples`` samples (whole pixels), the blocks in an order shuffled by
    ``order_seed`` (a pass cut short is not a band of the image), the threads over the blocks of a kernel call, calls
    of about ``call_seconds`` as :func:`render_fixed`'s; ``halted()``, when given, is asked before each call (once it
    is true no further block starts). Returns ``(sums of A + B (k, 3), sums of B (k, 3), counters (4,), rows done
    (k,) bool, (blocks done, blocks))``, a non-finite sample zeroed and counted. A row's sums do not depend on the blocks: the same with
    any ``block_samples``, thread count or order."""
    opts, optf = kernel_options(cs, 0, seed, max_depth, throughput_cutoff, split_depth, terminator)
    P, C, base = (np.ascontiguousarray(a, dtype=np.int64) for a in (P, C, base))
    dscale = np.maximum(0.125, 1.0 / np.sqrt(np.asarray(spp_after, dtype=np.float64)))
    both, half_b = np.zeros((P.size, 3)), np.zeros((P.size, 3))
    ends = np.cumsum(C)
    starts = np.concatenate(([0], np.searchsorted(ends, np.arange(block_samples, int(ends[-1]) if ends.size else 0,
                                                                   block_samples), side="right"), [P.size]))
    starts = np.unique(starts)
    n_blocks = starts.size - 1
    counters = np.zeros((max(n_blocks, 0), 4), dtype=np.int64)
    order = np.random.default_rng(order_seed).permutation(max(n_blocks, 0))
    done = np.zeros(P.size, dtype=bool)
    cam_rec = camera_record(cam)
    width = packet_width()
    if threads is not None:
        numba.set_num_threads(max(1, min(int(threads), numba.config.NUMBA_NUM_THREADS)))
    announce_compile("render_pixels")
    per_call = FIRST_CALL_TILES * numba.get_num_threads()
    lo, timed_s, timed_blocks = 0, 0.0, 0
    while lo < n_blocks:
        if halted is not None and halted():
            break
        hi = min(n_blocks, lo + max(1, per_call))
        t0 = time.perf_counter()
        with warnings.catch_warnings():
            warnings.simplefilter("ignore", NumbaIRAssumptionWarning)     # (as in render_fixed)
            with PARALLEL_LOCK, numba.parallel_chunksize(CHUNKSIZE):
                K.render_pixels(cs.scene, cam_rec, cs.geo_f, cs.geo_i, cs.materials[0], cs.materials[1],
                                cs.textures[0], cs.textures[1], cs.lights[0], cs.lights[1], cs.env_data, opts, optf,
                                P, C, base, dscale, starts, order[lo:hi], both, half_b, counters, width)
        timed_s += time.perf_counter() - t0
        timed_blocks += hi - lo
        per_call = max(numba.get_num_threads(), int(call_seconds * timed_blocks / max(timed_s, 1e-9)))
        for b in order[lo:hi]:
            done[starts[b]:starts[b + 1]] = True
        lo = hi
    return both, half_b, counters.sum(axis=0), done, (lo, n_blocks)


def load_pixel_kernel(cs, cam):
    """:func:`load_kernel` for the adaptive passes' entry (:func:`render_pixels`), before their chunks run."""
    none, nothing = np.zeros(0, dtype=np.int64), np.zeros((0, 3))
    opts, optf = kernel_options(cs, 0, 0, 1, 0.0, None, True)
    with PARALLEL_LOCK:
        load_kernel(cs, K.render_pixels, lambda: K.render_pixels(
            cs.scene, camera_record(cam), cs.geo_f, cs.geo_i, cs.materials[0], cs.materials[1], cs.textures[0],
            cs.textures[1], cs.lights[0], cs.lights[1], cs.env_data, opts, optf, none, none, none, np.ones(0),
            np.zeros(1, dtype=np.int64), none, nothing, nothing, np.zeros((0, 4), dtype=np.int64), packet_width()),
            "render_pixels")
