"""The C allocator's settings for rendering: reuse freed chunk memory instead of returning it to the OS.

A render allocates and frees thousands of NumPy temporaries of 0.1-3 MB per chunk (an (N, 3) float64
array of 32768 rows is 786 kB). glibc's malloc serves blocks above its mmap threshold with ``mmap`` and
trims the heap back to the OS once more than its trim threshold is free at the top; its thresholds adapt
(the mmap threshold rises to the largest block freed, the trim threshold to twice that) but stay far below
a chunk's working set. So at the end of every chunk most of its memory goes back to the kernel, and the
next chunk touches fresh pages: measured on the 320x240, 16 spp diffuse scene of ``tools/bench_kinds.py``
(one thread), ~150 000 minor page faults per render and 0.35-0.45 s of system time out of 0.8-1.0 s of CPU
time. With the two thresholds below, the faults drop to ~0 and the CPU time to ~0.45-0.5 s; images are
unchanged (only where memory comes from changes).

:func:`tune_allocator` sets (glibc only; elsewhere it does nothing)

- ``M_MMAP_THRESHOLD`` = :data:`MMAP_THRESHOLD` (32 MiB, the largest value glibc accepts on 64-bit):
  blocks below it come from the heap, not from fresh ``mmap`` pages;
- ``M_TRIM_THRESHOLD`` = :data:`TRIM_THRESHOLD` (256 MiB): up to that much free memory stays in the
  process for the next chunk.

The cost: after a render the process keeps up to its peak heap use (bounded by the chunk memory, which
``chunk_samples`` bounds) instead of returning it; peak memory itself is unchanged. Setting an explicit
threshold also switches off glibc's dynamic adjustment for the rest of the process. Every
:class:`pyrt.PreparedScene` calls it (so every render does); set the environment variable
``PYRT_MALLOC=default`` to leave the allocator as it is.
"""
from __future__ import annotations

import ctypes
import mmap
import os

import numpy as np

#: glibc ``mallopt`` parameter numbers (malloc.h)
_M_TRIM_THRESHOLD = -1
_M_MMAP_THRESHOLD = -3
#: bytes: blocks smaller than this are served from the heap (glibc's maximum on 64-bit: 32 MiB)
MMAP_THRESHOLD = 32 << 20
#: bytes of free memory at the top of the heap kept for reuse before it is returned to the OS
TRIM_THRESHOLD = 256 << 20
#: environment variable; ``default`` leaves the allocator's settings alone
ENV_SWITCH = "PYRT_MALLOC"


def tune_allocator():
    """Set glibc's mmap and trim thresholds for rendering (module docstring); True when they were set.

    Does nothing (returns False) when ``PYRT_MALLOC=default`` is set, on a C library other than glibc, or
    when ``mallopt`` refuses the values. Idempotent: calling it again sets the same values.
    """
    if os.environ.get(ENV_SWITCH, "").strip().lower() == "default":
        return False
    libc = _glibc()
    if libc is None:
        return False
    ok = libc.mallopt(_M_MMAP_THRESHOLD, MMAP_THRESHOLD) == 1
    return bool(libc.mallopt(_M_TRIM_THRESHOLD, TRIM_THRESHOLD) == 1 and ok)


def release_free_memory():
    """Return the heap's free pages to the OS now (glibc ``malloc_trim(0)``; elsewhere nothing). True when it ran.

    Called before render workers are forked (:class:`pyrt.render.pool.ChunkPool`): the trim threshold above keeps
    up to 256 MiB of freed memory in the process, and a forked worker that reuses those free blocks writes into
    pages it shares with the parent, which copies every one of them (memory and page faults: measured +300 MB
    for a glass preview after two chunks had run in the parent). Trimmed, the workers' new blocks are fresh
    pages of their own."""
    libc = _glibc()
    if libc is None:
        return False
    libc.malloc_trim(0)
    return True


def zeroed(n):
    """A zero float64 array of ``n`` words on private anonymous pages of its own (``mmap``), faulted in as they are
    first written, in 4 KiB pages.

    For large tables filled once (the kernel's texture table: hundreds of MB of float32 texels for a model with a
    few 2048-pixel maps). NumPy advises the kernel to back blocks of 4 MiB and more with transparent huge pages
    (``madvise(MADV_HUGEPAGE)``); where the kernel then compacts memory to find them (the common ``defrag=madvise``
    setting), the first writes stall unpredictably: writing 480 MB of fresh ``np.zeros`` took 0.08-1.41 s on a 2-core
    VM, against 0.25-0.38 s on these pages; the AlphaBlendModeTest preview's texture table 1.5-1.9 s against
    0.54-0.68 s with NumPy's advice switched off. The array keeps its mapping alive; it is unmapped with the array."""
    n = max(int(n), 1)
    return np.frombuffer(mmap.mmap(-1, n * 8, flags=mmap.MAP_PRIVATE), dtype=np.float64, count=n)


def _glibc():
    """The C library when it is glibc (``ctypes.CDLL``), else None."""
    try:
        glibc = os.confstr("CS_GNU_LIBC_VERSION")    # "glibc 2.36"; missing or an error elsewhere
    except (AttributeError, ValueError, OSError):
        return None
    if not glibc or not glibc.startswith("glibc"):
        return None
    try:
        return ctypes.CDLL("libc.so.6")
    except OSError:
        return None
