"""The allocator tuning of pyrt.core.memory: renders reuse freed chunk memory instead of faulting in fresh pages."""
import json
import os
import subprocess
import sys

import numpy as np
import pytest

from pyrt.core import memory

# A render in a fresh process: the minor page faults of its second render (the first one grows the heap).
_CHILD = r"""
import json, resource
import pyrt
cam = pyrt.Camera(position=(0, 1.5, 4.5), target=(0, 0.5, 0), fov=40, width=128, height=96, spp=16)
s = pyrt.Scene(cam)
s.add_plane((0, 0, 0), 10.0, pyrt.Lambert(albedo=0.6))
s.add_sphere((0, 0.6, 0), 0.6, pyrt.Lambert(albedo=(0.8, 0.4, 0.3)))
s.add_light(pyrt.PointLight((2, 4, 3), intensity=25))
with pyrt.PreparedScene(s, threads=1) as ps:
    pyrt.render(s, prepared=ps, threads=1, progress=False, backend="numpy")
    r0 = resource.getrusage(resource.RUSAGE_SELF).ru_minflt
    pyrt.render(s, prepared=ps, threads=1, progress=False, backend="numpy")
    print(json.dumps({"faults": resource.getrusage(resource.RUSAGE_SELF).ru_minflt - r0}))
"""


def _faults(env_value):
    env = dict(os.environ)
    env.pop(memory.ENV_SWITCH, None)
    if env_value is not None:
        env[memory.ENV_SWITCH] = env_value
    out = subprocess.run([sys.executable, "-c", _CHILD], capture_output=True, text=True, env=env, check=True)
    return json.loads(out.stdout.strip().splitlines()[-1])["faults"]


def _glibc():
    try:
        return os.confstr("CS_GNU_LIBC_VERSION").startswith("glibc")
    except (AttributeError, ValueError, OSError):
        return False


def test_switch_off_leaves_the_allocator_alone(monkeypatch):
    monkeypatch.setenv(memory.ENV_SWITCH, "default")
    assert memory.tune_allocator() is False


@pytest.mark.skipif(not _glibc(), reason="the tuning applies to glibc's malloc only")
def test_tuned_render_faults_far_fewer_pages():
    # 128x96 at 16 spp is 6 chunks of 32768 samples: untuned, glibc returns most of each chunk's memory to the
    # kernel and the next chunk faults it in again (measured ~28 000 faults); tuned, the heap is reused (~0).
    untuned = _faults("default")
    tuned = _faults(None)
    assert untuned > 2000, f"expected the untuned render to fault in pages (got {untuned}): the test shows nothing"
    assert tuned < 0.1 * untuned, f"tuned render faulted {tuned} pages, untuned {untuned}"


def test_release_free_memory_returns_freed_heap_pages():
    """malloc_trim(0) after freeing many small blocks: the process's RSS falls (glibc only)."""
    code = r"""
import json, os, numpy as np
from pyrt.core import memory
memory.tune_allocator()                      # the render's setting: up to 256 MiB of free heap kept
def rss():
    with open("/proc/self/statm") as fh:
        return int(fh.read().split()[1]) * os.sysconf("SC_PAGE_SIZE") / 2**20
blocks = [np.ones(100_000) for _ in range(2000)]      # 1.6 GB of 800 kB heap blocks
del blocks[:-1]                                       # the last one keeps the heap's top in use
before = rss()
ok = memory.release_free_memory()
print(json.dumps({"ok": ok, "before": before, "after": rss()}))
"""
    out = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, check=True).stdout
    r = json.loads(out)
    if not r["ok"]:
        pytest.skip("not glibc")
    assert r["before"] - r["after"] > 500, r


def test_zeroed_pages_are_a_writable_zero_array_that_owns_its_mapping():
    """memory.zeroed: ``n`` float64 zeros (one word for ``n`` 0), writable through a float32 view as the texture
    table is written, kept mapped by the array alone (the mapping object is not referenced elsewhere)."""
    import gc
    a = memory.zeroed(3_000_000)
    assert a.dtype == np.float64 and a.shape == (3_000_000,) and a.flags.writeable and a.flags.c_contiguous
    assert not a.any()
    f = a.view(np.float32)
    f[1::1000] = 2.5
    gc.collect()
    assert np.count_nonzero(a) == 6000 and f[1] == 2.5      # one float64 word per float32 written
    assert memory.zeroed(0).shape == (1,)
