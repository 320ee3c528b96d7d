"""Compile the render kernels ahead of time (``python -m pyrt compile``, :func:`compile_kernels`)."""
from __future__ import annotations

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


def compile_kernels():
    """Compile the render kernels now, or load them from the cache; returns ``(seconds, was_cached,
    cache_dir)``."""
    cached = kernel_cache.is_warm()
    t0 = time.perf_counter()
    compiled = Execution(backend="compiled", progress=False)
    render_full(warmup_scene(), execution=compiled)
    # the adaptive passes' entry (render_pixels) is a kernel of its own
    render_full(warmup_scene(), execution=compiled, sampling=Sampling(target_error=1.0, max_spp=4))
    return time.perf_counter() - t0, cached, kernel_cache.cache_dir()
