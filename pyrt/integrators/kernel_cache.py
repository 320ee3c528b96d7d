"""Where the compiled render kernels are cached, and Numba's runtime settings for them.

Numba caches a compiled function next to its source (or in ``NUMBA_CACHE_DIR``) keyed on that one file: a kernel
that inlines functions of *other* files keeps its stale machine code when only those change (two different
images from one source tree were seen). So the kernels are cached in a directory of their own whose name is a hash
of every kernel source file, Numba's and llvmlite's versions and Python's (:func:`cache_dir`): any edit, upgrade or
other interpreter starts a fresh cache, and a stale one is never read. Each directory holds ~40-120 MB, so the ones
left by other sources are removed when a compile starts in a new one and they have not been used for
:data:`STALE_DAYS` days (:func:`prune`; a load or compile touches its directory's :data:`STAMP`, so another
installation in use keeps its own); ``pyrt compile --prune`` removes every other one at once.

The base directory is ``NUMBA_CACHE_DIR`` when set (Numba's own rule), else ``$XDG_CACHE_HOME/pyrt`` (default
``~/.cache/pyrt``), else a temporary directory when neither is writable. :func:`use_cache_dir` points Numba there
while the kernel module is imported (its decorators read the setting) and :func:`restore` puts it back, so other
Numba users in the process keep their own.

Threads: Numba's ``workqueue`` layer unless ``NUMBA_THREADING_LAYER`` says otherwise (GNU OpenMP's spin-waits
made a render 5.6x slower on a loaded 2-core machine; the workqueue did not).
"""
from __future__ import annotations

import functools
import getpass
import hashlib
import importlib.util
import os
import re
import shutil
import sys
import tempfile
import time

import llvmlite
import numba

#: the modules whose source the compiled kernels are built from (their hash names the cache directory)
KERNEL_SOURCES = ("pyrt.shaders.jit", "pyrt.shaders.jit_math", "pyrt.shaders.jit_brdfs", "pyrt.shaders.jit_sampling", "pyrt.shaders.jit_preview",
                  "pyrt.core.unmanaged",
                  "pyrt.geometry.embree_jit", "pyrt.textures.compiled_mip", "pyrt.textures.compiled",
                  "pyrt.textures.compiled_normal_map", "pyrt.materials.compiled", "pyrt.integrators.compiled_coverage",
                  "pyrt.integrators.compiled_media", "pyrt.integrators.compiled_shadows",
                  "pyrt.materials.compiled_sampling", "pyrt.lights.compiled", "pyrt.lights.compiled_tables",
                  "pyrt.lights.compiled_env", "pyrt.lights.compiled_env_preview", "pyrt.lights.compiled_mesh",
                  "pyrt.integrators.compiled_preview",
                  "pyrt.integrators.compiled_layout", "pyrt.integrators.compiled_diffs",
                  "pyrt.integrators.compiled_env_stage", "pyrt.integrators.compiled_lighting",
                  "pyrt.integrators.compiled_mesh_stage", "pyrt.integrators.compiled_hit",
                  "pyrt.integrators.compiled_surface",
                  "pyrt.integrators.compiled_kernel", "pyrt.render.image_maps", "pyrt.render.pass_plan")

_saved = []

#: days after its last use that another sources' kernel directory is removed by a compile (:func:`prune`)
STALE_DAYS = 30
#: the file whose modification time says when a kernel directory was last loaded from or compiled into
STAMP = ".last-used"
_KERNEL_DIR = re.compile(r"kernels-[0-9a-f]{16}")


@functools.lru_cache(maxsize=1)
def source_hash():
    """SHA-256 (hex) of the kernel sources, Numba's, llvmlite's and Python's versions."""
    h = hashlib.sha256()
    for name in KERNEL_SOURCES:
        origin = importlib.util.find_spec(name).origin
        with open(origin, "rb") as fh:
            h.update(name.encode() + b"\0" + fh.read() + b"\0")
    h.update(f"{numba.__version__} {llvmlite.__version__} {sys.version}".encode())
    return h.hexdigest()


def _writable(path):
    try:
        os.makedirs(path, exist_ok=True)
        probe = tempfile.NamedTemporaryFile(dir=path, prefix=".probe")
        probe.close()
        return True
    except OSError:
        return False


def cache_dir():
    """The directory the compiled kernels of these sources are cached in (created)."""
    base = os.environ.get("NUMBA_CACHE_DIR") or os.path.join(
        os.environ.get("XDG_CACHE_HOME") or os.path.join(os.path.expanduser("~"), ".cache"), "pyrt")
    path = os.path.join(base, "kernels-" + source_hash()[:16])
    if not _writable(path):
        path = os.path.join(tempfile.gettempdir(), f"pyrt-{getpass.getuser()}", "kernels-" + source_hash()[:16])
        os.makedirs(path, exist_ok=True)
    return path


def mark_used(path=None):
    """Touch the :data:`STAMP` of the kernel directory ``path`` (default :func:`cache_dir`): it is in use."""
    path = cache_dir() if path is None else path
    try:
        with open(os.path.join(path, STAMP), "a"):
            pass
        os.utime(os.path.join(path, STAMP))
    except OSError:
        pass


def last_used(path):
    """When the kernel directory ``path`` was last used (seconds since the epoch): its :data:`STAMP`'s time, else
    the directory's own."""
    try:
        return os.path.getmtime(os.path.join(path, STAMP))
    except OSError:
        return os.path.getmtime(path)


def _size(path):
    total = 0
    for root, _dirs, files in os.walk(path):
        for f in files:
            try:
                total += os.path.getsize(os.path.join(root, f))
            except OSError:
                pass
    return total


def prune(days=STALE_DAYS, path=None, now=None):
    """Remove the kernel directories beside ``path`` (default :func:`cache_dir`; only names ``kernels-`` + 16 hex
    digits, never ``path`` itself) last used more than ``days`` days ago (0: all of them). Returns ``[(directory,
    bytes)]`` of those removed."""
    path = os.path.abspath(cache_dir() if path is None else path)
    base = os.path.dirname(path)
    now = time.time() if now is None else now
    removed = []
    try:
        names = sorted(os.listdir(base))
    except OSError:
        return removed
    for name in names:
        other = os.path.join(base, name)
        if not _KERNEL_DIR.fullmatch(name) or other == path or not os.path.isdir(other):
            continue
        try:
            if now - last_used(other) < days * 86400.0:
                continue
        except OSError:
            continue
        size = _size(other)
        shutil.rmtree(other, ignore_errors=True)
        if not os.path.exists(other):
            removed.append((other, size))
    return removed


#: the render kernels' entries (:mod:`pyrt.integrators.compiled_kernel`): fixed spp, adaptive passes
ENTRIES = ("render_tiles", "render_pixels")


def is_warm(path=None, entries=ENTRIES):
    """True when the render kernels' ``entries`` (default both: the fixed-spp and the adaptive one) are in the cache
    (no compilation ahead)."""
    path = cache_dir() if path is None else path
    want = {f"compiled_kernel.{e}" for e in entries}
    for _root, _dirs, files in os.walk(path):
        want -= {w for w in want if any(f.startswith(w) and f.endswith(".nbi") for f in files)}
    return not want


def use_cache_dir():
    """Point Numba's cache at :func:`cache_dir` (until :func:`restore`) and choose the threading layer."""
    _saved.append(numba.config.CACHE_DIR)
    numba.config.CACHE_DIR = cache_dir()
    if not os.environ.get("NUMBA_THREADING_LAYER"):
        numba.config.THREADING_LAYER = "workqueue"


def restore():
    """Numba's cache setting as it was before :func:`use_cache_dir`."""
    if _saved:
        numba.config.CACHE_DIR = _saved.pop()
