"""Compile the render kernels ahead of time (``python -m pyrt compile``, :func:`compile_kernels`)."""
from __future__ import annotations

import os
import subprocess
import sys
import time

from pyrt.core.camera import Camera
from pyrt.integrators import kernel_cache
from pyrt.lights.punctual import DirectionalLight, PointLight, SpotLight
from pyrt.materials.basic import BlinnPhong, Glass, Lambert, Mirror
from pyrt.render.fixed import render_full
from pyrt.render.settings import Execution, Sampling
from pyrt.scene import Scene
from pyrt.textures.procedural import CheckerTexture


def warmup_scene():
    """A 16 x 12 scene of every family the compiled kernel covers (it compiles once for all of them)."""
    s = Scene(Camera(position=(0, 1.2, 4.0), target=(0, 0.5, 0), fov=40, width=16, height=12, spp=4),
              background=(0.05, 0.06, 0.1))
    s.add_plane((0, 0, 0), 6.0, Lambert(albedo=CheckerTexture(0.15, 0.8, scale=6, filtered=False)))
    s.add_sphere((-0.6, 0.5, 0), 0.5, Mirror(0.9), subdivisions=1)
    s.add_sphere((0.6, 0.5, 0), 0.5, Glass(ior=1.5), subdivisions=1)
    s.add_sphere((0.0, 0.3, -0.8), 0.3, BlinnPhong(kd=0.4, ks=0.2, exponent=30), subdivisions=1)
    s.add_light(PointLight((2, 3, 2), intensity=20.0))
    s.add_light(SpotLight((-2, 3, 1), target=(0, 0, 0), intensity=30.0))
    s.add_light(DirectionalLight((0.3, -1, -0.4), irradiance=0.5))
    return s


def compile_kernels(parallel=None):
    """Compile the render kernels now, or load them from the cache; returns ``(seconds, was_cached,
    cache_dir)``. The fixed-spp and the adaptive entry are two kernels: with ``parallel`` (default: on a cold cache
    with two or more CPUs) the adaptive one compiles in a child process beside the fixed one (each compile is
    single-threaded: ~half the wall time on 2 cores)."""
    cached = kernel_cache.is_warm()
    if parallel is None:
        parallel = not cached and (os.cpu_count() or 1) >= 2
    t0 = time.perf_counter()
    child = subprocess.Popen([sys.executable, "-c", "from pyrt.render.warmup import compile_adaptive; "
                              "compile_adaptive()"]) if parallel else None
    compile_fixed()
    if child is None:
        compile_adaptive()
    elif child.wait() != 0:
        compile_adaptive()          # (the child's error is on stderr; compiled here instead)
    return time.perf_counter() - t0, cached, kernel_cache.cache_dir()


def compile_fixed():
    """Compile (or load) the fixed-spp entry (:func:`pyrt.integrators.compiled_kernel.render_tiles`)."""
    render_full(warmup_scene(), execution=Execution(backend="compiled", progress=False))


def compile_adaptive():
    """Compile (or load) the adaptive passes' entry (:func:`pyrt.integrators.compiled_kernel.render_pixels`) and the
    compiled arithmetic between passes (:mod:`pyrt.render.pass_plan`: a target out of reach, so that every step of
    the pass loop runs)."""
    render_full(warmup_scene(), execution=Execution(backend="compiled", progress=False),
                sampling=Sampling(target_error=1e-12, max_spp=64))
