"""What an integrator runs on and what it counts: the prepared scene and the ray statistics."""
from __future__ import annotations

from concurrent.futures import ThreadPoolExecutor
from dataclasses import dataclass, field
import os
import time

import numpy as np

from pyrt.core.memory import tune_allocator
from pyrt.geometry import precision
from pyrt.geometry.accel import Accel
from pyrt.integrators import gouraud
from pyrt.integrators.coverage import CoverageTable
from pyrt.integrators.media import NestedMedia
from pyrt.lights.base import Light
from pyrt.lights.irradiance import irradiance_table
from pyrt.materials.base import Material
from pyrt.textures.base import Texture
from pyrt.textures.image import ImageTexture


@dataclass
class RenderStats:
    """Counters of one render (rays by kind, time), and optionally the traced rays themselves."""

    primary_rays: int = 0
    secondary_rays: int = 0
    shadow_rays: int = 0
    time_total: float = 0.0
    time_intersect: float = 0.0
    time_occluded: float = 0.0
    nonfinite_samples: int = 0
    recorded: list = field(default_factory=list)
    #: the path that rendered: ``"numpy"`` (the wavefront NumPy integrators) or ``"compiled"`` (the Numba tile
    #: kernel, :mod:`pyrt.integrators.compiled`)
    backend: str = "numpy"
    #: why ``backend="auto"`` took the NumPy path (what the compiled one does not cover yet); empty otherwise
    fallback_reasons: list = field(default_factory=list)

    @property
    def rays(self):
        """All rays traced: primary + secondary + shadow."""
        return self.primary_rays + self.secondary_rays + self.shadow_rays


class PreparedScene:
    """A scene with its Embree acceleration structure and flat geometry table built once.

    Parameters
    ----------
    scene : pyrt.Scene
    threads : int, optional
        Worker threads of the accelerator's batch queries (default: all cores).
    build_quality : {"medium", "low", "high"}
        Embree's BVH build quality (:class:`pyrt.geometry.Accel`; default Embree's "medium").

    Besides ``geo`` (:class:`pyrt.geometry.GeometryTable`) and ``accel`` (:class:`pyrt.geometry.Accel`) it
    holds what the integrators look at before they render, to model no more than the scene needs:
    per-material flags (``has_delta``, ``has_diffuse``, ``dielectric``, ``emits``), the nested-media tables (``media``,
    None without several dielectrics), the coverage table (``coverage``, None without alpha or culling), the
    Gouraud face mask, ``needs_differentials`` and ``has_normal_maps``.
    Close it (or use it as a context manager) to free the Embree scene. Preparing a scene also tunes the C
    allocator for rendering (:func:`pyrt.core.memory.tune_allocator`: freed chunk memory is reused, not
    returned to the OS and faulted in again; ``PYRT_MALLOC=default`` switches that off).
    """

    #: Seconds spent preparing: ``"geometry"`` (flat geometry table, float32 range check, the copies into
    #: Embree) and ``"bvh"`` (Embree's BVH build); added when they happen: ``"mip_levels"`` and ``"irradiance"``
    #: (:meth:`before_fork`), ``"tables"`` (packing the compiled kernel's flat tables, per compiled render:
    #: :class:`pyrt.integrators.compiled.CompiledScene`) and ``"kernel"`` (loading the compiled kernel from its cache,
    #: or compiling it, once per process: :func:`pyrt.integrators.compiled.load_kernel`).
    timings: dict

    def __init__(self, scene, *, threads=None, build_quality="medium"):
        t0 = time.perf_counter()
        scene.validate()      # parameters changed since construction are errors here, not wrong images
        tune_allocator()      # every render goes through here: chunk temporaries reuse heap memory
        self.scene = scene
        self.geo = scene.geometry_table()
        # meshes float32 ray tracing distorts or loses: warned about; nothing left to render: an error
        precision.check_range(scene.meshes, scene.camera.position)
        self.accel = Accel(threads=threads, build_quality=build_quality)
        for m in self.geo.meshes:
            self.accel.add_mesh(m.vertices, m.faces)
        t1 = time.perf_counter()
        self.accel.commit()
        self.timings = {"geometry": t1 - t0, "bvh": time.perf_counter() - t1}
        mats = scene.materials
        self.has_delta = np.array([m.has_delta for m in mats], dtype=bool)
        self.has_diffuse = np.array([m.has_diffuse for m in mats], dtype=bool)
        self.transmits = np.array([m.transmits for m in mats], dtype=bool)
        #: dielectric materials (transparent shadows pass through them, pyrt.integrators.shadows)
        self.dielectric = np.array([m.is_dielectric for m in mats], dtype=bool)
        # nested dielectrics (pyrt.integrators.media): per-ray interface stacks only when the scene needs them
        self.media = NestedMedia.for_scene(mats)
        # faces shaded per vertex (pyrt.integrators.gouraud), None when no mesh asks for it
        self.face_gouraud = gouraud.face_mask(self.geo, scene.gouraud_meshes)
        self.needs_differentials = any(m.uses_footprints for m in mats)
        #: materials whose emission() can be non-zero (the rest skip the emission pass)
        self.emits = np.array([m.emits for m in mats], dtype=bool)
        #: alpha masks, blending and back-face culling (pyrt.integrators.coverage), None when every material is
        #: opaque and double-sided
        self.coverage = CoverageTable.for_scene(mats)
        # materials with a tangent-space normal map (Material.normal_map, see pyrt.textures)
        self.has_normal_maps = any(m.normal_map is not None for m in mats)
        #: the geometry as the compiled kernel's flat tables (:class:`pyrt.integrators.compiled.CompiledScene`), built
        #: by the first compiled render and kept: the geometry cannot change once its BVH is built
        self.compiled_geometry = None
        #: the compiled texture table of the last compiled render and what decided it
        #: (:func:`pyrt.integrators.compiled.texture_table`: reused while the textures' lookups are the same)
        self.compiled_textures = None

    def before_fork(self):
        """Build now what every forked render worker (:class:`pyrt.render.pool.ChunkPool`) would otherwise build
        for itself, the same in each: the MIP pyramids of the scene's image textures, so that the workers share
        one copy of them (copy-on-write) instead of holding one each; and the irradiance grid of an environment
        light with the control variate in a scene with Lambertian materials (:func:`pyrt.lights.irradiance.
        irradiance_table`: 0.22 s for a 512 x 256 map, kept by the environment across renders). Once per prepared
        scene; the seconds it took are ``timings["mip_levels"]`` and ``timings["irradiance"]``."""
        if "mip_levels" in self.timings:
            return
        t0 = time.perf_counter()
        texs = list(image_textures(*self.scene.materials, *self.scene.lights))
        # one texture per thread: the reductions run in NumPy without the GIL (helmet-like model, five 2048^2
        # maps: 0.16 -> 0.10 s on two cores); a pyramid two textures share builds under its own lock, once
        n = min(len(texs), os.cpu_count() or 1)
        if n > 1:
            with ThreadPoolExecutor(n) as ex:
                list(ex.map(lambda tex: tex.build_mip_levels(), texs))
        else:
            for tex in texs:
                tex.build_mip_levels()
        t1 = time.perf_counter()
        self.timings["mip_levels"] = t1 - t0
        if any(m.lambertian for m in self.scene.materials):
            for lt in self.scene.lights:
                env = lt.environment
                if env is not None and lt.control_variate and lt.strategy != "preview" \
                        and env.radiance_resolution is not None:
                    irradiance_table(env)
        self.timings["irradiance"] = time.perf_counter() - t1

    def close(self):
        """Release the Embree scene."""
        self.accel.close()

    def __enter__(self):
        return self

    def __exit__(self, *exc):
        self.close()


def image_textures(*roots):
    """The :class:`ImageTexture` objects reachable from ``roots`` through the attributes of materials, lights and
    textures (and the lists, tuples and dicts they hold), each once, in the order found. A texture held by an
    object of another kind is not found: the render still reads it, only :meth:`PreparedScene.before_fork` does
    not build its pyramid ahead (each worker then builds what it reads)."""
    found, seen, todo = [], set(), list(roots)
    while todo:
        obj = todo.pop()
        if id(obj) in seen:
            continue
        seen.add(id(obj))
        if isinstance(obj, ImageTexture):
            found.append(obj)
        if isinstance(obj, dict):
            todo.extend(obj.values())
        elif isinstance(obj, (list, tuple)):
            todo.extend(obj)
        elif isinstance(obj, (Material, Light, Texture)):
            todo.extend(vars(obj).values())
    return found
