"""The compiled render path: which scenes it renders, their flat tables, and the tile loop around the kernel.

:func:`unsupported` says why a render cannot take the compiled path (an empty list: it can); :class:`CompiledScene`
packs a prepared scene into the kernel's flat tables (geometry as float64 / int64 arrays, one row per material,
texture and light: a type tag and a parameter record, packed by each object's ``compiled_record``);
:func:`render_fixed` renders a fixed number of samples per pixel with the kernel of
:mod:`pyrt.integrators.compiled_kernel` and returns per-pixel sums.

What the compiled path covers (everything else renders through the NumPy path, automatically with
``backend="auto"``): the Whitted integrator with max depth, throughput cutoff (rays below it dropped or continued by
Russian roulette) and split depth, and the glossy
integrator (glossy rays with MIS against the area lights whose meshes they reach, the glossy clamp:
:mod:`pyrt.integrators.compiled_hit`), both with the light choice
(``light_select_depth``); Lambert (constant,
unfiltered-checker or nearest / bilinear / trilinear image albedo, constant emission), normalised Blinn-Phong,
Mirror, Glass, smooth Conductor, the library models with constant parameters and
the glTF metallic-roughness family (textured MetallicRoughness, isotropic GltfPBR opaque or smooth-transmitting, glTF
emission and occlusion: :mod:`pyrt.materials.gltf_record`), nested dielectrics and Beer-Lambert absorption
(:mod:`pyrt.integrators.compiled_media`; not beside alpha masks or blending), vertex colours in a colour slot 0 (:mod:`pyrt.integrators.
compiled_vertex`); tangent-space normal maps (in the frame of the mesh's vertex tangents where it has them); point
and spot lights (every spot and distance falloff), directional lights; rectangle, disk and sphere lights (light
samples stratified per hit and padded over a pixel's samples, BSDF samples beside them with MIS) with their visible
meshes; constant and lat-long environments (and subclasses that declare it, the previewer's studio), seen by missed
rays and lighting by ``strategy="mis"`` or ``"preview"`` (:mod:`pyrt.integrators.compiled_preview`); the emissive-mesh
light over constant emission (:mod:`pyrt.integrators.compiled_mesh_stage`); a constant
background and ambient term; smooth and flat shading with or without the back-facing-normal fallback; the ``robust``
and ``robust_no_terminator`` offsets; back-face culling (single-sided materials), alpha masks and blending (a
constant or nearest / bilinear / trilinear opacity, under any light:
:mod:`pyrt.integrators.compiled_coverage`); fixed spp and adaptive passes
(:func:`pyrt.integrators.compiled_passes.render_pixels`). Not yet: other environments and strategies, emissive-mesh
lights over textured emission, the other materials (and per-face colours), anisotropic and bicubic texture filters,
ray recording (transparent shadows through dielectrics:
:mod:`pyrt.integrators.compiled_shadows`; AOVs: fixed spp, not on Dask workers; the
glossy integrator and the light choice not on Dask workers).
"""
from __future__ import annotations

import functools
import math
import sys
import threading
import time
import warnings

import numba
from numba.core.errors import NumbaIRAssumptionWarning
import numpy as np

from pyrt.geometry import embree_jit
from pyrt.integrators import compiled_coverage as CC
from pyrt.integrators import compiled_kernel as K
from pyrt.integrators import compiled_layout as KL
from pyrt.integrators import compiled_media
from pyrt.integrators import compiled_vertex as CV
from pyrt.integrators import kernel_cache
from pyrt.integrators import light_choice
from pyrt.integrators.coverage import MAX_LAYERS, CoverageTable
from pyrt.integrators.glossy import ENV_LIGHT_SAMPLED, emitter_lights
from pyrt.integrators.media import NestedMedia
from pyrt.integrators.shadows import MAX_INTERFACES
from pyrt.lights import compiled as LC
from pyrt.lights import compiled_env, compiled_env_preview
from pyrt.lights import compiled_mesh as CM
from pyrt.materials import compiled as MC
from pyrt.materials.gltf_record import scalar_slot
from pyrt.textures import compiled as TC
from pyrt.textures import ImageTexture

#: ``backend=`` values of :func:`pyrt.render_full`
BACKENDS = ("auto", "compiled", "numpy")
#: offset strategies the kernel implements (None: the default, "robust")
OFFSETS = (None, "robust", "robust_no_terminator")

_announced = []
#: what :func:`unsupported` adds to the reason of a material it cannot pack that is a dielectric with a non-delta lobe
_DIELECTRIC_LOBES = (" (a dielectric with a BSDF lobe, e.g. glTF KHR_materials_transmission or rough glass: the "
                     "kernel's dielectrics are Glass and smooth glTF transmission)")
#: ... and to the reason of an emissive-mesh light it cannot pack (:meth:`pyrt.EmissiveMeshLight.compiled_record`)
_MESH_EMISSION = (" (an emitter whose emission is not a constant the kernel reads: textured, vertex colours, alpha "
                  "masks or blending)")
#: ... and to the reason of a smooth transmitting material it cannot pack
_SMOOTH_TEXTURED = (" (smooth glTF transmission: the kernel reads it with constant metallic, transmission, specular "
                    "and specular colour, isotropic)")


def glossy_reasons(scene):
    """Why the kernel cannot render ``scene`` with the glossy integrator (:mod:`pyrt.integrators.compiled_hit`)
    beyond the reasons of the Whitted one; an empty list when it can."""
    reasons = []
    if any(len(lts) > 1 for lts in emitter_lights(scene).values()):
        reasons.append("the glossy integrator with a visible emitter mesh shared by several area lights")
    rough = [m.label for m in scene.materials if m.has_diffuse and m.transmits and not m.smooth_transmission]
    if rough:
        reasons.append(f"the glossy integrator with rough transmission ({', '.join(rough)})")
    return reasons


def kernel_integrator(scene, integ=None):
    """The kernel's integer and float options of the integrator settings ``integ`` (the keywords of
    :func:`pyrt.render.pool.integrator_factory`; None: Whitted): ``((glossy samples, glossy depth, light-select depth,
    the map samples of the environment light sampled at glossy hits), (glossy threshold, glossy clamp))``
    (:data:`pyrt.integrators.compiled_layout.O_GLOSSY_N`, ...; 0, 0, -1, 0 and 0, inf: Whitted, no light choice). The
    light choice needs two delta lights to choose from
    (:meth:`pyrt.integrators.whitted.Integrator._selects_lights`)."""
    if integ is None:
        return (0, 0, -1, 0), (0.0, math.inf)
    sel = integ["light_select_depth"]
    if sel is None or sum(light_choice.selectable(lt) for lt in scene.lights) < 2:
        sel = -1
    if integ["integrator"] != "glossy":
        return (0, 0, int(sel), 0), (0.0, math.inf)
    clamp = integ["glossy_clamp"]
    env = [lt for lt in scene.lights if lt.environment is not None and lt.strategy in ENV_LIGHT_SAMPLED]
    return ((int(integ["glossy_samples"]), int(integ["glossy_depth"]), int(sel), env[0].n_samples if env else 0),
            (float(integ["glossy_threshold"]), math.inf if clamp is None else float(clamp)))


def unsupported(ps, *, integrator="whitted", offset=None, transparent_shadows=False, light_select_depth=None,
                record_rays=False, scene=None, roulette=False, sampler="padded"):
    """The reasons (strings) the compiled kernel cannot render the prepared scene ``ps`` with these options; an
    empty list when it can. The options are those of :func:`pyrt.render_full`. ``ps`` None and ``scene`` given: the
    same decision from the scene alone (what a Dask client decides before its workers prepare the scene; the
    workers' accelerators are assumed to have a scene handle, as they do wherever the binding's layout is the one
    :mod:`pyrt.geometry.accel` verifies)."""
    reasons = []
    facts = ps if ps is not None else _SceneFacts(scene)
    scene = facts.scene
    if integrator not in ("whitted", "glossy"):
        reasons.append(f"integrator {integrator!r}")
    if integrator == "glossy":
        reasons += glossy_reasons(scene)
    if sampler != "padded":
        reasons.append(f"sampler {sampler!r} (the kernel's light samples are padded)")
    if not (offset is None or isinstance(offset, str) and offset in OFFSETS):
        reasons.append(f"offset strategy {offset!r}")
    if record_rays:
        reasons.append("ray recording")
    if scene.environment is not None and not compiled_env.packable(scene.environment):
        reasons.append(f"environment {type(scene.environment).__name__}")
    cover = facts.coverage
    if facts.media is not None and cover is not None and cover.shadows:
        reasons.append(facts.media.describe(scene.materials) + " with alpha masks or blend materials")
    if (ps.face_gouraud is not None) if ps is not None else facts.gouraud:
        reasons.append("Gouraud shading")
    if ps is not None and ps.accel.buffers != "shared":
        reasons.append("no Embree scene handle (the binding's copied buffers)")
    textures = _TexturePacker()
    records = []
    for m in scene.materials:
        seen = len(textures.refused)
        records.append(m.compiled_record(textures.add))
        if records[-1] is None:
            reasons.append(f"material {m.label}" + textures.why(seen) + (
                _SMOOTH_TEXTURED if m.smooth_transmission else _DIELECTRIC_LOBES
                if m.is_dielectric and m.has_diffuse else ""))
        elif m.normal_map is not None and textures.add(m.normal_map) is None:
            reasons.append(f"normal map of material {m.label}" + textures.why(seen))
        elif m.alpha_mode != "opaque" and coverage_fields(m, textures.add) is None:
            reasons.append(f"alpha {m.alpha_mode} of material {m.label} (its opacity is not a constant or a factor "
                           "times a channel of an image texture the kernel reads)" + textures.why(seen))
    for lt in scene.lights:
        if lt.compiled_record() is None or (lt.delta and lt.n_samples != 1):
            reasons.append(f"light {lt.label}" + (_MESH_EMISSION if lt.scene_emitter else ""))
        elif lt.environment is not None and lt.environment is not scene.environment:
            reasons.append(f"light {lt.label} (lights with an environment other than the scene's)")
    reasons += CV.vertex_colors(scene.meshes, CV.vertex_color_textures(records, textures.objects))[1]

    return reasons


class _SceneFacts:
    """What :func:`unsupported` reads of a :class:`pyrt.PreparedScene`, from the scene alone (no BVH)."""

    def __init__(self, scene):
        mats = scene.materials
        self.scene = scene
        self.dielectric = np.array([m.is_dielectric for m in mats], dtype=bool)
        self.coverage = CoverageTable.for_scene(mats)
        self.media = NestedMedia.for_scene(mats)
        self.gouraud = bool(scene.gouraud_meshes)


class _TexturePacker:
    """Collects texture records (each texture once) for the texture table, and the textures it was refused."""

    def __init__(self):
        self.tags, self.records, self.texels, self._index = [], [], [], {}
        #: the textures by row
        self.objects = []
        #: why each texture the kernel cannot read was refused, in the order asked (:meth:`why`)
        self.refused = []

    def add(self, texture):
        """The texture's row in the table (added on first sight), or None when the kernel cannot read it (the
        reason kept in :attr:`refused`)."""
        key = id(texture)
        if key not in self._index:
            rec = texture.compiled_record()
            if rec is None:
                self.refused.append(_refusal(texture))
                return None
            self._index[key] = len(self.tags)
            self.objects.append(texture)
            self.tags.append(rec[0])
            self.records.append(np.asarray(rec[1], dtype=np.float64))
            self.texels.append(rec[2] if len(rec) > 2 else None)
        return self._index[key]

    def why(self, since):
        """`` (texture ...: why)`` naming the textures refused since :attr:`refused` had ``since`` entries, or
        ``""`` when none was."""
        names = list(dict.fromkeys(self.refused[since:]))
        return f" ({'; '.join(names)})" if names else ""

    def uv_sets(self, geo):
        """``{k: (V, 2)}``: the UV sets ``k >= 1`` the collected textures read, per vertex of the geometry table
        ``geo`` (:meth:`pyrt.geometry.GeometryTable.uv_table`; zeros where no mesh has set ``k``, as the NumPy path
        reads it: :func:`pyrt.geometry.uvsets.uv_set_at_hits`)."""
        sets = sorted({int(r[TC.UV_SET]) for r in self.records if r[TC.UV_SET] >= 1})
        tables = {k: geo.uv_table(k) for k in sets}
        return {k: np.zeros((geo.vertices.shape[0], 2)) if t is None else t for k, t in tables.items()}


def _refusal(texture):
    """Why the kernel cannot read ``texture`` (a phrase naming it): :func:`pyrt.textures.compiled.image_refusal` for
    an image texture, else its type."""
    why = TC.image_refusal(texture) if isinstance(texture, ImageTexture) else None
    return why or f"texture {type(texture).__name__}"


def texture_table(ps, textures):
    """:func:`pyrt.textures.compiled.pack_table` of the textures ``textures`` collected (a :class:`_TexturePacker`),
    reused from the prepared scene ``ps``'s last packing when the records are equal and every texture with texels is
    the same lookup (:attr:`pyrt.ImageTexture.sampling_key`: its texels, pyramid, UV set, filter and transform; the
    UV sets ``k >= 1`` the textures read are packed with them, from the prepared scene's geometry): the
    views of a turntable and the renders of one prepared scene pack their textures once (Avocado's three 2048² maps,
    two whole pyramids and one level 0: 185 MB of float32 texels, ~0.17 s in ``pyrt-preview`` each time)."""
    key = _texture_key(textures)
    hit = ps.compiled_textures
    if key is not None and hit is not None and hit[0] == key:
        return hit[1]
    table = TC.pack_table(textures.tags, textures.records, textures.texels, textures.uv_sets(ps.geo))
    ps.compiled_textures = None if key is None else (key, table)
    return table


def _texture_key(textures):
    """What decides the packed table of ``textures``: per row its tag, record and (for an image texture) its
    :attr:`~pyrt.ImageTexture.sampling_key`; None when a texture other than an image texture has texels (not
    cached)."""
    parts = []
    for tex, tag, rec, tx in zip(textures.objects, textures.tags, textures.records, textures.texels):
        if tx is not None and not isinstance(tex, ImageTexture):
            return None
        parts.append((tag, rec.tobytes(), tex.sampling_key if tx is not None else None))
    return tuple(parts)


def _table(tags, records, width):
    """``(tags (n,) int64, records (n, width) float64)``, one zero row when empty (Numba needs a shape)."""
    if not tags:
        return np.zeros(1, dtype=np.int64), np.zeros((1, width))
    return np.asarray(tags, dtype=np.int64), np.ascontiguousarray(np.stack(records), dtype=np.float64)


def _preview_geometries(mats):
    """The Smith terms (indices into :data:`pyrt.shaders.jit_brdfs.GEOMETRY_TERMS`) of the packed materials whose
    split-sum tables the environment preview reads (METALLIC_ROUGHNESS: field 9, GLTF: field 19; a clear coat's lobe:
    ``smith_correlated``, index 0)."""
    terms = {int(rec[9]) if tag == MC.METALLIC_ROUGHNESS else int(rec[19]) for tag, rec in mats
             if tag in (MC.METALLIC_ROUGHNESS, MC.GLTF)}
    return terms | {0 for tag, rec in mats if tag == MC.GLTF and rec[MC.COAT] != 0.0}


class CompiledScene:
    """A prepared scene as the compiled kernel's flat tables (build it only when :func:`unsupported` is empty).

    Attributes
    ----------
    geo_f, geo_i : tuples of 2-D float64 / int64 arrays
        Vertices, vertex normals, UVs, face normals, per-face absolute-coordinate bounds and extents; faces,
        per-mesh face offsets, per-face material ids and smooth flags (:class:`pyrt.geometry.GeometryTable`).
    materials, textures, lights : (tags, records)
        The family tables (:mod:`pyrt.materials.compiled`, :mod:`pyrt.textures.compiled`,
        :mod:`pyrt.lights.compiled`).
    """

    def __init__(self, ps, integ=None):
        t0 = time.perf_counter()
        #: the integrator's kernel options (:func:`kernel_integrator` of ``integ``, render_full's integrator settings)
        self.integrator = kernel_integrator(ps.scene, integ)
        #: Russian roulette below the throughput cutoff (the integrator setting ``roulette``; False without ``integ``)
        self.roulette = bool(integ is not None and integ["roulette"])
        #: transparent shadows (:data:`pyrt.integrators.compiled_layout.O_TRANSPARENT`): the most surfaces a shadow
        #: ray crosses (as :meth:`pyrt.integrators.whitted.Integrator.visibility`), 0 when off
        self.transparent = 0
        if integ is not None and integ["transparent_shadows"] and np.any(ps.dielectric):
            self.transparent = MAX_LAYERS if any(m.alpha_mode != "opaque" for m in ps.scene.materials) else \
                MAX_INTERFACES
        if ps.compiled_geometry is None:
            geo = ps.geo
            f64 = lambda a: np.ascontiguousarray(a, dtype=np.float64)          # noqa: E731
            i64 = lambda a: np.ascontiguousarray(a, dtype=np.int64)            # noqa: E731
            ps.compiled_geometry = (
                (f64(geo.vertices), f64(geo.normals), f64(geo.uv), f64(geo.face_normals), f64(geo.face_absmax),
                 f64(geo.face_extent[:, None])),
                (i64(geo.faces), i64(geo.face_offset[:, None]), i64(geo.face_material[:, None]),
                 i64(geo.face_smooth[:, None])))
        textures = _TexturePacker()
        mats = [m.compiled_record(textures.add) for m in ps.scene.materials]
        vcol = CV.vertex_colors(ps.geo.meshes, CV.vertex_color_textures(mats, textures.objects))[0]
        #: the geometry tables, then the vertex colours and tangent frames (:mod:`pyrt.integrators.compiled_vertex`)
        self.geo_f = ps.compiled_geometry[0] + (vcol, CV.tangent_frames(ps.geo))
        self.geo_i = ps.compiled_geometry[1]
        self.fallback = ps.geo.shading_normal_fallback
        for m, (tag, rec) in zip(ps.scene.materials, mats):
            if m.normal_map is not None:
                rec[MC.NORMAL_MAP:MC.NORMAL_MAP + 4] = MC.normal_map_fields(m.normal_map, textures.add(m.normal_map))
            rec[MC.CULL] = 1.0 if m.culls_back_faces else 0.0
            if m.alpha_mode != "opaque":
                rec[MC.MASK:MC.MASK + 5] = coverage_fields(m, textures.add)
            rec[MC.GLOSSY] = glossy_field(m, tag)
        traced = emitter_lights(ps.scene)
        for k, lts in traced.items():
            mats[k][1][MC.TRACED] = 1.0 + next(j for j, lt in enumerate(ps.scene.lights) if lt is lts[0])
        #: whether the rays carry interface stacks (:data:`pyrt.integrators.compiled_layout.O_MEDIA`)
        self.media = compiled_media.medium_fields(ps.scene.materials, mats)
        self.materials = _table([t for t, _ in mats], [r for _, r in mats], MC.RECORD)
        self.textures = texture_table(ps, textures)
        #: whether the rays carry differentials (a texture reads footprints); whether a material has a normal map
        #: (:data:`pyrt.integrators.compiled_layout.O_NMAPS`: 2 when besides a mesh has vertex tangents)
        self.diffs = any(t == TC.MIP for t in textures.tags)
        self.normal_maps = any(m.normal_map is not None for m in ps.scene.materials) or any(
            tag == MC.GLTF and rec[MC.COAT + 7] != 0.0 for tag, rec in mats)
        if self.normal_maps and ps.geo.tangent_frames is not None:
            self.normal_maps = 2
        #: coverage (:data:`pyrt.integrators.compiled_layout.O_COVER`): 2 with an alpha mask or a blend material, 1
        #: with culling only, 0
        self.cover = 2 if any(m.alpha_mode != "opaque" for m in ps.scene.materials) else (
            1 if any(m.culls_back_faces for m in ps.scene.materials) else 0)
        lights = [lt.compiled_record() for lt in ps.scene.lights]
        traced_lights = {id(lt) for lts in traced.values() for lt in lts}
        for lt, packed in zip(ps.scene.lights, lights):
            if LC.RECT <= packed[0] <= LC.SPHERE:
                packed[1][LC.TRACED] = 1.0 if id(lt) in traced_lights else 0.0
        self.lights = CM.pack_table(lights)
        self.n_lights = len(lights)
        env = ps.scene.environment
        env_light = next((lt for lt in ps.scene.lights if lt.environment is not None), None)
        packed = compiled_env.pack_environment(env, env_light) if env is not None else None
        packed = compiled_env_preview.pack_preview(env, env_light, packed, _preview_geometries(mats))
        #: the environment (:func:`pyrt.lights.compiled_env.pack_environment`): tag (0: none), record, data
        self.env_tag, self.env_record, self.env_data = packed if packed is not None else (
            0, np.zeros(compiled_env.RECORD), np.zeros(1))
        self.background = np.asarray(ps.scene.background, dtype=np.float64)
        self.ambient = np.asarray(ps.scene.ambient, dtype=np.float64)
        self.scene = embree_jit.scene_handle(ps.accel)
        #: the prepared scene whose Embree scene ``scene`` is (kept alive while these tables are in use)
        self.prepared = ps
        add_time(ps.timings, "tables", time.perf_counter() - t0)


def glossy_field(material, tag):
    """A material record's :data:`pyrt.materials.compiled.GLOSSY` field: its constant
    :meth:`~pyrt.materials.Material.glossy_alpha` (``inf`` where it has none: a diffuse-like lobe), -1 for GLTF (per
    hit: :func:`pyrt.materials.compiled.glossy_alpha`)."""
    if tag == MC.GLTF:
        return -1.0
    a = material.glossy_alpha(MC.ONE_HIT) if material.has_diffuse else None
    return math.inf if a is None else float(np.asarray(a, dtype=np.float64).reshape(-1)[0])


def add_time(timings, phase, seconds):
    """Add ``seconds`` to ``timings[phase]`` (a :attr:`pyrt.PreparedScene.timings` dict; absent counts as 0)."""
    timings[phase] = timings.get(phase, 0.0) + seconds


def load_kernel(cs, kernel, call, entry="render_tiles"):
    """Load ``kernel`` (the render entry ``entry`` of :mod:`pyrt.integrators.compiled_kernel`: ``"render_tiles"`` or
    ``"render_pixels"``) from the cache, or compile it on a cold one, by ``call()``, an empty call (no tiles, no
    pixels), when this process has not loaded it yet (:func:`announce_compile` says so when it compiles); the seconds
    are added to ``cs.prepared.timings["kernel"]`` (what a preview reports as its ``kernel`` phase: a load from the
    cache, the same file for every model, or the cold compile), so that no render's time includes them."""
    if kernel.overloads:
        return
    announce_compile(entry)
    t0 = time.perf_counter()
    with warnings.catch_warnings():
        warnings.simplefilter("ignore", NumbaIRAssumptionWarning)        # (as in render_fixed)
        call()
    add_time(cs.prepared.timings, "kernel", time.perf_counter() - t0)


def coverage_fields(material, add_texture):
    """A material record's :data:`pyrt.materials.compiled.MASK` fields for the alpha mask or blend of ``material``:
    :data:`pyrt.integrators.compiled_coverage.MODE_MASK` or ``MODE_BLEND``, ``alpha_cutoff`` and the opacity's scalar
    slot (:func:`pyrt.materials.gltf_record.scalar_slot`, its texture added by ``add_texture``; a trilinear texture is
    read at the ray's footprint); None when the kernel cannot read the opacity."""
    slot = scalar_slot(material.opacity, add_texture)
    mode = CC.MODE_MASK if material.alpha_mode == "mask" else CC.MODE_BLEND
    return None if slot is None else [mode, float(material.alpha_cutoff), *slot]


def camera_record(cam):
    """The kernel's camera record (float64): position, forward, right, up, tan(fov/2), width, height, jitter."""
    rec = np.zeros(KL.N_CAM)
    rec[KL.C_POS:KL.C_POS + 3] = cam.position
    rec[KL.C_FWD:KL.C_FWD + 3], rec[KL.C_RIGHT:KL.C_RIGHT + 3], rec[KL.C_UP:KL.C_UP + 3] = cam.frame()
    rec[KL.C_TAN] = cam.tan_half
    rec[KL.C_W], rec[KL.C_H] = cam.width, cam.height
    rec[KL.C_JITTER] = 1.0 if cam.jitter else 0.0
    rec[KL.C_K] = 2.0 * cam.tan_half / cam.height
    rec[KL.C_AX] = cam.tan_half * cam.width / cam.height
    return rec


def tile_order(n_tiles):
    """The tiles in a fixed shuffled order: ``prange`` gives each thread one contiguous block of the list, so each
    gets tiles from all over the image (a block of raster-order tiles can be all sky). The image does not depend
    on the order (every pixel's samples are keyed on the pixel). The permutation is made once per tile count
    (a copy of it each call: a writeable array, the kernel's argument type)."""
    return _tile_order(int(n_tiles)).copy()


@functools.lru_cache(maxsize=16)
def _tile_order(n_tiles):
    return np.random.default_rng(0x71E5).permutation(n_tiles).astype(np.int64)


def announce_compile(entry, stream=None):
    """Say once per process and entry (``"render_tiles"``: fixed spp, ``"render_pixels"``: adaptive passes), on
    stderr, that it is being compiled (not in the cache); the cache is looked at once per process and entry (after
    that the entry is loaded or compiled). Marks the cache directory used and, before a compile, removes the ones
    of other sources unused for :data:`pyrt.integrators.kernel_cache.STALE_DAYS` days
    (:func:`pyrt.integrators.kernel_cache.prune`)."""
    if entry not in _announced:
        _announced.append(entry)
        kernel_cache.mark_used()
        if kernel_cache.is_warm(entries=(entry,)):
            return
        kernel_cache.prune()
        kind = "the adaptive passes' entry" if entry == "render_pixels" else "the fixed-spp entry"
        print(f"pyrt: compiling render kernels ({kind}), first run only (cached in {kernel_cache.cache_dir()})",
              file=stream or sys.stderr, flush=True)


def n_tiles(cam):
    """Tiles of :data:`pyrt.integrators.compiled_layout.TILE` pixels in the camera's image."""
    return -(-cam.width // KL.TILE) * -(-cam.height // KL.TILE)


#: the seconds a kernel call should take at most (a progress step and a look at ``cancel`` between calls; each call
#: ends with a barrier): the first call renders :data:`FIRST_CALL_TILES` tiles per thread, later calls as many as
#: the rate measured so far fits in this time, at least :data:`MIN_CALLS` calls per render unless the rest fits in
#: one call. A Ctrl-C (``cancel``) is seen within about one call (a 1920 x 1080 render at 64 spp in 4 calls took
#: 27 s to stop)
CALL_SECONDS = 0.25
#: tiles per thread of the first call of a render (its time sets the later calls' sizes)
FIRST_CALL_TILES = 8
#: the kernel's tasks a thread takes at a time from a call's list (Numba's ``parallel_chunksize``; a task is
#: :data:`pyrt.integrators.compiled_layout.TILES_PER_TASK` tiles): 4 tiles at a time rather than 1, and 4 calls
#: rather than 16, measured within the noise to 5 % faster on the shadowed bench scene (quickbench, 2 threads, load
#: 0.1; 16 / static: 36.7 Ms/s, 4 / static 39.8, 2 / 4 tiles 38.8)
CHUNKSIZE = 1
#: the fewest kernel calls of a render with enough tiles whose rest takes longer than :data:`CALL_SECONDS` after the
#: first call (so that a progress bar moves)
MIN_CALLS = 4
#: held around every call of the threaded kernel (:func:`pyrt.integrators.compiled_kernel.render_tiles`): Numba's
#: workqueue threading layer runs one parallel region at a time and aborts the process when a second thread enters
#: one (two renders on a Dask worker's threads, or any two Python threads), so concurrent renders take turns call
#: by call (each call uses every thread it was given)
PARALLEL_LOCK = threading.Lock()


def render_fixed(cs, cam, *, spp, seed, max_depth, throughput_cutoff, split_depth, terminator, threads=None,
                 cancel=None, progress=None, tiles=None, call_seconds=CALL_SECONDS, aovs=False, second_moment=False):
    """Render ``spp`` samples per pixel of the compiled scene ``cs`` through the camera ``cam``.

    The tiles (``tiles``: a subset, default all in :func:`tile_order`) are rendered in kernel calls of at most
    about ``call_seconds`` each (a progress step each; ``cancel`` is looked at between them). Returns ``(sums
    (H*W, 3), squared sums (H*W, 3) with ``second_moment`` (else None), counters (4,), tiles_done (n_tiles,)
    bool)``, and with ``aovs`` the AOV sums
    (H*W, :data:`pyrt.integrators.compiled_layout.N_AOV`) after them; counters: primary, secondary, shadow rays,
    non-finite samples (zeroed)."""
    W, H = cam.width, cam.height
    order = tile_order(n_tiles(cam)) if tiles is None else np.asarray(tiles, dtype=np.int64)
    opts, optf = kernel_options(cs, spp, seed, max_depth, throughput_cutoff, split_depth, terminator)
    sums = np.zeros((W * H, 3))
    sqs = np.zeros((W * H if second_moment else 1, 3))
    aov = np.zeros((W * H if aovs else 1, KL.N_AOV))
    opts[KL.O_AOV] = 1 if aovs else 0
    opts[KL.O_SQ] = 1 if second_moment else 0
    counters = np.zeros((order.size, 4), dtype=np.int64)
    done = np.zeros(n_tiles(cam), dtype=bool)
    cam_rec = camera_record(cam)
    width = packet_width()
    if threads is not None:
        numba.set_num_threads(max(1, min(int(threads), numba.config.NUMBA_NUM_THREADS)))
    with PARALLEL_LOCK:
        load_kernel(cs, K.render_tiles, lambda: K.render_tiles(
            cs.scene, order[:0], cam_rec, cs.geo_f, cs.geo_i, cs.materials[0], cs.materials[1], cs.textures[0],
            cs.textures[1], cs.lights[0], cs.lights[1], cs.env_data, opts, optf, sums, sqs, aov, counters[:0], width))
    n_threads = numba.get_num_threads()
    per_call = FIRST_CALL_TILES * n_threads
    lo, timed_s, timed_tiles = 0, 0.0, 0
    while lo < order.size:
        if cancel is not None and cancel.is_set():
            break
        cap = -(-order.size // MIN_CALLS)
        if timed_tiles and (order.size - lo) * timed_s <= call_seconds * timed_tiles:
            cap = order.size - lo       # the rest fits in one call (each call ends with a barrier)
        hi = min(order.size, lo + max(1, min(per_call, cap)))
        t0 = time.perf_counter()
        with warnings.catch_warnings():
            # a compile (first call, cold cache) reports "variable ... is not in scope" for inlined helpers with
            # early returns: an internal check of Numba's, not a fault of the kernel (the tests hold its images)
            warnings.simplefilter("ignore", NumbaIRAssumptionWarning)
            with PARALLEL_LOCK, numba.parallel_chunksize(CHUNKSIZE):
                K.render_tiles(cs.scene, order[lo:hi], cam_rec, cs.geo_f, cs.geo_i, cs.materials[0], cs.materials[1],
                               cs.textures[0], cs.textures[1], cs.lights[0], cs.lights[1], cs.env_data, opts,
                               optf, sums, sqs, aov, counters[lo:hi], width)
        timed_s += time.perf_counter() - t0
        timed_tiles += hi - lo
        per_call = max(KL.TILES_PER_TASK * n_threads, int(call_seconds * timed_tiles / max(timed_s, 1e-9)))
        done[order[lo:hi]] = True
        if progress is not None:
            progress.update(hi - lo)
        lo = hi
    sqs = sqs if second_moment else None
    if aovs:
        return sums, sqs, counters.sum(axis=0), done, aov
    return sums, sqs, counters.sum(axis=0), done


def kernel_options(cs, spp, seed, max_depth, throughput_cutoff, split_depth, terminator):
    """The kernel's integer and float option arrays (:data:`pyrt.integrators.compiled_layout.N_OPTS`, ``O_*``,
    ``F_*``)."""
    opts = np.zeros(KL.N_OPTS, dtype=np.int64)
    opts[KL.O_SEED] = int(seed) & 0x7FFFFFFFFFFFFFFF
    opts[KL.O_SPP] = spp
    opts[KL.O_MAX_DEPTH] = max_depth
    opts[KL.O_SPLIT] = -1 if split_depth is None else split_depth
    opts[KL.O_TERMINATOR] = 1 if terminator else 0
    opts[KL.O_NLIGHTS] = cs.n_lights
    opts[KL.O_SPP_LO] = 0
    opts[KL.O_FALLBACK] = 1 if cs.fallback else 0
    grid = int(round(spp ** 0.5))
    opts[KL.O_GRID] = grid if grid * grid == spp else 0
    opts[KL.O_ENV] = cs.env_tag
    opts[KL.O_DIFFS] = 1 if cs.diffs else 0
    opts[KL.O_NMAPS] = int(cs.normal_maps)
    opts[KL.O_COVER] = cs.cover
    opts[KL.O_LAYERS] = MAX_LAYERS
    opts[KL.O_ROULETTE] = 1 if cs.roulette else 0
    opts[KL.O_TRANSPARENT] = cs.transparent
    opts[KL.O_MEDIA] = 1 if cs.media else 0
    (opts[KL.O_GLOSSY_N], opts[KL.O_GLOSSY_DEPTH], opts[KL.O_SELECT], opts[KL.O_GLOSSY_ENV]), (threshold, clamp) = \
        cs.integrator
    optf = np.zeros(KL.F_ENV + compiled_env.RECORD)
    optf[KL.F_GLOSSY_T], optf[KL.F_GLOSSY_CLAMP] = threshold, clamp
    optf[KL.F_ENV:] = cs.env_record
    optf[KL.F_CUTOFF] = throughput_cutoff
    optf[KL.F_BG:KL.F_BG + 3] = cs.background
    optf[KL.F_AMBIENT:KL.F_AMBIENT + 3] = cs.ambient
    return opts, optf


def packet_width():
    """The camera and shadow packets' width: Embree's native width on this CPU (16 with AVX-512, 8 with AVX2, 4 with
    SSE; a wider packet than the native width is slower: 12.5 against 40.2 Mrays/s for 16 against 8 lanes on an
    AVX2 device, tests/test_embree_jit.py's measurement); 16 where Embree reports no native packets."""
    w = embree_jit.native_packet_width()
    return w if w in (4, 8, 16) else 16


def pixel_mask(tiles_done, W, H):
    """(H*W,) bool: the pixels of the finished tiles."""
    grid = np.asarray(tiles_done, dtype=bool).reshape(-(-H // KL.TILE), -(-W // KL.TILE))
    return np.repeat(np.repeat(grid, KL.TILE, axis=0)[:H], KL.TILE, axis=1)[:, :W].ravel()
