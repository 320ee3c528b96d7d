"""The allocator tuning of pyrt.core.memory: renders reuse freed chunk memory instead of faulting in fresh pages."""
import json
import os
import subprocess
import sys

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
    pyrt.render(s, prepared=ps, threads=1, progress=False)
    r0 = resource.getrusage(resource.RUSAGE_SELF).ru_minflt
    pyrt.render(s, prepared=ps, threads=1, progress=False)
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
