"""Load real assets (glTF 2.0 / GLB, OBJ + MTL, PLY, STL) into a :class:`pyrt.Scene`.

``asset = load_asset(path)`` reads a file into an :class:`Asset` (object-space meshes, instances with
their world transforms, materials, cameras, lights, warnings); ``asset.add_to_scene(scene)`` adds it
to a scene. Every failure raises :class:`AssetError` with a message naming the file and the part
that is wrong (a missing texture, an accessor past the end of its buffer, ...).

Conventions
-----------
- **UVs** follow pyrt's convention (:mod:`pyrt.textures`): ``(0, 0)`` is the *bottom-left* of the
  image, ``v`` up, texel row ``(1 - v) H``. glTF puts ``(0, 0)`` at the top-left, so glTF
  ``TEXCOORD_n`` are stored as ``(u, 1 - v)`` (the same flip trimesh applies); OBJ, PLY and trimesh
  UVs are already bottom-left and are used as they are. ``KHR_texture_transform`` is converted to
  the flipped space (:func:`gltf_uv_transform`). glTF normal maps are "green = up in the image",
  i.e. +v in pyrt's flipped UVs, which is :class:`pyrt.textures.NormalMap`'s default.
- **Colour**: base-colour and emissive textures are sRGB and are linearised; metallic-roughness
  (B = metallic, G = roughness), normal and occlusion (R) textures are linear data. glTF
  ``COLOR_0`` is linear (spec); PLY / OBJ vertex colours are 8-bit sRGB by convention and are
  linearised.
- **glTF defaults** where a property is absent: baseColorFactor (1, 1, 1, 1), metallicFactor 1,
  roughnessFactor 1, emissiveFactor (0, 0, 0), normal scale 1, occlusion strength 1,
  doubleSided false, alphaMode OPAQUE; a primitive without a material gets the spec's default
  material (all of the above). Emissive values (times ``KHR_materials_emissive_strength``) are
  used as radiance in W m^-2 sr^-1.
- **Lights** (``KHR_lights_punctual``): point/spot ``intensity`` is luminous intensity in candela,
  directional ``intensity`` is illuminance in lux. They become radiant intensity
  ``I = cd / K * color`` (W/sr) and irradiance ``E = lux / K * color`` (W/m^2) with
  ``K = shaders.color.LUMINOUS_EFFICACY`` = 683 lm/W, through the lights' own ``candela=`` /
  ``lux=`` arguments (:mod:`pyrt.lights`): the photometric value is the luminance (Rec. 709
  weights) of the result exactly when ``luminance(color) = 1`` (e.g. white). Spot cones use glTF's
  falloff (``spot_falloff="gltf"``), a ``range`` glTF's window (``falloff="gltf_range"``). Lights
  point along the node's local -Z.
- **Cameras**: perspective cameras look along local -Z with +Y up; orthographic cameras are not
  supported (warning).
- **Instancing**: a glTF mesh used by several nodes is decoded once; its object-space arrays,
  smooth normals, UVs and materials are shared by the instances. The Embree scene holds one
  world-space copy per instance (:mod:`pyrt.geometry.accel` has no instancing).
- **Normals**: file normals are used as given; meshes without normals get crease-angle smooth
  normals (:func:`crease_normals`, default 30 degrees), welded by position so UV seams and STL
  triangle soups are smoothed too. Meshes without UVs render (UV = 0; textures read one texel).

OBJ + MTL mapping (documented choice; the MTL "illum 2" model *is* Blinn-Phong)
------------------------------------------------------------------------------
- Opaque materials -> :class:`ObjMaterial` = energy-normalised :class:`pyrt.BlinnPhong`:
  ``kd = Kd`` (times ``map_Kd``, sRGB), ``ks = Ks``, ``exponent = Ns``; if ``kd + ks > 1`` in a
  channel, ``ks`` is scaled down uniformly (warning) so the model conserves energy.
  ``Ke`` (and ``map_Ke``) is emitted radiance. ``Ka`` is not used (pyrt's ambient term uses the
  albedo ``kd``).
- Transparent materials (``d < 1``, ``Tr > 0`` or ``illum`` 4, 6, 7, 9) -> :class:`pyrt.Glass` with
  ``ior = Ni`` (1.5 if ``Ni <= 1`` or absent, warning) and ``tint = Tf`` (default white).
- ``map_Kd`` options ``-s`` and ``-o`` become the texture's UV scale and offset; ``norm`` is used as
  a normal map; ``bump``/``map_Bump`` (height maps) and other maps are ignored with a warning.
"""
from __future__ import annotations

import base64
from dataclasses import dataclass, field
import json
import math
import os
import re
import struct
import tempfile
import time
import urllib.parse

import numpy as np
import trimesh

from pyrt.shaders import color as _color

from pyrt.core.camera import Camera
from pyrt.lights.punctual import DirectionalLight, PointLight, SpotLight
from pyrt.materials import BlinnPhong, Glass
from pyrt.textures import ImageTexture, NormalMap, Texture, TextureError, load_image
from pyrt.core.errors import Error

try:  # the glTF metallic-roughness BRDF (material library, issue 3)
    from pyrt.materials import MetallicRoughness
except ImportError:  # pragma: no cover - reported loudly by make_metallic_roughness
    MetallicRoughness = None


class AssetError(Error, ValueError):
    """An asset file cannot be loaded; the message names the file and what is wrong."""


FORMATS = {".gltf": "gltf", ".glb": "gltf", ".obj": "obj", ".ply": "ply", ".stl": "stl"}

#: Default crease angle (degrees) for meshes without normals.
DEFAULT_CREASE_ANGLE = 30.0


# ============================================================================ data model

@dataclass
class AssetMesh:
    """One triangle mesh in object space (a glTF primitive, an OBJ material group, a PLY/STL file).

    ``uv`` uses pyrt's convention (v up); ``colors`` are linear RGB per vertex; ``material`` indexes
    :attr:`Asset.materials` (-1: the format's default material).
    """

    name: str
    vertices: np.ndarray            # (V, 3) float64
    faces: np.ndarray               # (F, 3) int64
    normals: np.ndarray | None = None   # (V, 3) unit, from the file
    uv: np.ndarray | None = None        # (V, 2) float64
    colors: np.ndarray | None = None    # (V, 3) float64 linear
    material: int = -1


@dataclass
class AssetInstance:
    """A mesh placed in the world: ``world_from_object`` (4, 4) float64."""

    mesh: int
    world_from_object: np.ndarray
    node: str = ""


@dataclass
class TextureSlot:
    """A texture as the file describes it: the decoded texture and the parameters that apply to it."""

    texture: ImageTexture
    texcoord: int = 0
    source: str = ""                # file name or "image 3 (embedded)"


@dataclass
class PBRParams:
    """glTF metallic-roughness material parameters with the glTF defaults applied."""

    name: str = ""
    base_color_factor: np.ndarray = field(default_factory=lambda: np.ones(4))
    base_color_texture: TextureSlot | None = None
    metallic_factor: float = 1.0
    roughness_factor: float = 1.0
    metallic_roughness_texture: TextureSlot | None = None   # the raw RGB(A) data texture
    metallic_texture: ImageTexture | None = None            # its B channel
    roughness_texture: ImageTexture | None = None           # its G channel
    normal_texture: NormalMap | None = None
    normal_scale: float = 1.0
    occlusion_texture: ImageTexture | None = None           # its R channel
    occlusion_strength: float = 1.0
    emissive_factor: np.ndarray = field(default_factory=lambda: np.zeros(3))
    emissive_texture: TextureSlot | None = None
    emissive_strength: float = 1.0
    double_sided: bool = False
    alpha_mode: str = "OPAQUE"
    alpha_cutoff: float = 0.5
    texcoord: int = 0


@dataclass
class MTLParams:
    """One ``newmtl`` block of an MTL file (values as written; None = absent)."""

    name: str
    Kd: np.ndarray | None = None
    Ks: np.ndarray | None = None
    Ke: np.ndarray | None = None
    Tf: np.ndarray | None = None
    Ns: float | None = None
    Ni: float | None = None
    d: float | None = None
    illum: int | None = None
    map_Kd: ImageTexture | None = None
    map_Ke: ImageTexture | None = None
    norm: NormalMap | None = None


@dataclass
class DefaultParams:
    """The preview material for files without materials (PLY, STL): a grey dielectric "clay"."""

    name: str = "default"
    base_color: tuple = (0.8, 0.8, 0.8)
    metallic: float = 0.0
    roughness: float = 0.5


@dataclass
class AssetCamera:
    """A perspective camera: world position, unit forward and up, vertical fov (degrees)."""

    name: str
    position: np.ndarray
    forward: np.ndarray
    up: np.ndarray
    yfov_deg: float
    aspect: float | None = None

    def to_pyrt(self, width, height, **kwargs):
        """A :class:`pyrt.Camera` with this pose and field of view."""
        return Camera(self.position, self.position + self.forward, self.up, fov=self.yfov_deg, width=width,
                      height=height, **kwargs)


@dataclass
class AssetLight:
    """A ``KHR_lights_punctual`` light in photometric units, placed in the world.

    ``intensity`` is in candela (point, spot) or lux (directional); ``direction`` is the unit
    direction the light travels (the node's -Z).
    """

    name: str
    kind: str                       # "point" | "spot" | "directional"
    color: np.ndarray
    intensity: float
    position: np.ndarray
    direction: np.ndarray
    range: float | None = None
    inner_cone: float = 0.0         # radians
    outer_cone: float = math.pi / 4

    def to_pyrt(self):
        """The pyrt light in radiometric units (see the module docstring for the conversion)."""
        return light_from_photometric(self)


@dataclass
class Asset:
    """A loaded asset. ``up_axis`` is "+y" when the format defines it (glTF), else None."""

    path: str
    format: str
    meshes: list[AssetMesh] = field(default_factory=list)
    instances: list[AssetInstance] = field(default_factory=list)
    materials: list = field(default_factory=list)
    cameras: list[AssetCamera] = field(default_factory=list)
    lights: list[AssetLight] = field(default_factory=list)
    warnings: list[str] = field(default_factory=list)
    up_axis: str | None = None
    load_time: float = 0.0

    @property
    def n_triangles(self):
        """Triangles rendered (instances counted)."""
        return int(sum(self.meshes[i.mesh].faces.shape[0] for i in self.instances))

    def world_vertices(self):
        """All instances' vertices in world space, (N, 3) float64."""
        out = []
        for inst in self.instances:
            m = inst.world_from_object
            out.append(self.meshes[inst.mesh].vertices @ m[:3, :3].T + m[:3, 3])
        return np.concatenate(out) if out else np.zeros((0, 3))

    def bounds(self):
        v = self.world_vertices()
        if v.shape[0] == 0:
            raise AssetError(f"{self.path}: the asset has no geometry")
        return v.min(axis=0), v.max(axis=0)

    def add_to_scene(self, scene, *, transform=None, crease_angle=DEFAULT_CREASE_ANGLE, lights=True,
                     name_prefix=""):
        """Add the meshes (with materials) and, if ``lights``, the lights to ``scene``.

        ``transform`` (4, 4) is applied on top of every instance's world transform (e.g. an up-axis
        change). Returns the list of scene mesh indices added.
        """
        pre = np.eye(4) if transform is None else np.asarray(transform, dtype=np.float64)
        prepared = {}
        mats = {}
        added = []
        for k, inst in enumerate(self.instances):
            if inst.mesh not in prepared:
                prepared[inst.mesh] = _prepare_mesh(self.meshes[inst.mesh], crease_angle)
            tm, normals, colors = prepared[inst.mesh]
            am = self.meshes[inst.mesh]
            key = am.material if colors is None else ("vc", inst.mesh)
            if key not in mats:
                mats[key] = self._material(am, colors)
            material, vc_tex = mats[key]
            m = pre @ inst.world_from_object
            if abs(np.linalg.det(m[:3, :3])) < 1e-300:
                self.warnings.append(f"instance {inst.node or k} of mesh {am.name!r} has a singular transform "
                                     "(zero scale): skipped")
                continue
            mid = scene.add_mesh(tm, material, transform=m, normals=normals,
                                 name=f"{name_prefix}{inst.node or am.name}#{k}")
            if vc_tex is not None:
                vc_tex.bind(mid, scene.meshes[mid].faces, colors)
            added.append(mid)
        if lights:
            for L in self.lights:
                light = L.to_pyrt()
                if transform is not None:
                    light = _transform_light(light, pre)
                scene.add_light(light)
        return added

    def _material(self, am, colors):
        """(pyrt material, vertex-colour texture or None) for a mesh."""
        params = self.materials[am.material] if am.material >= 0 else (
            PBRParams(name="gltf-default") if self.format == "gltf" else DefaultParams())
        vc = VertexColorTexture() if colors is not None else None
        return to_pyrt_material(params, vertex_colors=vc), vc


# ============================================================================ materials

class ScaledTexture(Texture):
    """``factor * texture`` (factor a scalar or RGB); ``channels`` of the inner texture."""

    def __init__(self, texture, factor):
        self.texture = texture
        self.factor = np.asarray(factor, dtype=np.float64)
        self.channels = texture.channels

    def evaluate(self, ctx):
        v = np.asarray(self.texture.evaluate(ctx), dtype=np.float64).reshape(ctx.n_hits, -1)
        return v * self.factor


class ProductTexture(Texture):
    """Per-hit product of two textures (or a texture and a constant), e.g. vertex colour x base colour."""

    def __init__(self, a, b):
        self.a, self.b = a, b
        self.channels = 3

    def evaluate(self, ctx):
        def val(x):
            if isinstance(x, Texture):
                return np.asarray(x.evaluate(ctx), dtype=np.float64).reshape(ctx.n_hits, -1)
            return np.broadcast_to(np.asarray(x, dtype=np.float64), (ctx.n_hits, 3))
        return val(self.a) * val(self.b)


class VertexColorTexture(Texture):
    """Linear per-vertex colours interpolated with the hit's barycentrics.

    The colours are bound to scene meshes after :meth:`pyrt.Scene.add_mesh` (``bind(mesh_id,
    faces, colors)``, with the mesh's final faces so that ``ctx.prim_id`` indexes them). Hits on
    meshes that were not bound get white (1, 1, 1).
    """

    channels = 3

    def __init__(self):
        self._bound = {}

    def bind(self, mesh_id, faces, colors):
        self._bound[int(mesh_id)] = (np.asarray(faces, dtype=np.int64), np.asarray(colors, dtype=np.float64))

    def evaluate(self, ctx):
        out = np.ones((ctx.n_hits, 3))
        for mid in np.unique(ctx.mesh_id):
            if int(mid) not in self._bound:
                continue
            faces, colors = self._bound[int(mid)]
            sel = np.flatnonzero(ctx.mesh_id == mid)
            tri = faces[ctx.prim_id[sel]]
            b = ctx.bary[sel]
            out[sel] = (b[:, 0:1] * colors[tri[:, 0]] + b[:, 1:2] * colors[tri[:, 1]]
                        + b[:, 2:3] * colors[tri[:, 2]])
        return out


class SurfaceExtras:
    """Mixin adding glTF-style extras to a material: emission, occlusion and a normal map.

    - ``emission_value`` (constant or texture): emitted radiance (W m^-2 sr^-1).
    - ``occlusion`` (1-channel texture or None): ``1 + strength (occ - 1)``; multiplies
      :meth:`albedo`, i.e. the constant ambient term (pyrt's only indirect light, which is what glTF
      occlusion applies to) and the albedo AOV. Direct light is not occluded (glTF spec).
    - ``normal_map`` (:class:`pyrt.textures.NormalMap` or None): applied by the integrator
      (:func:`pyrt.textures.apply_normal_maps` perturbs the shading normal of every material with a
      ``normal_map`` attribute before shading).
    """

    def _init_extras(self, emission=None, occlusion=None, occlusion_strength=1.0, normal_map=None):
        self.emission_value = 0.0 if emission is None else emission
        self.occlusion = occlusion
        self.occlusion_strength = float(occlusion_strength)
        self.normal_map = normal_map

    def albedo(self, ctx):
        a = super().albedo(ctx)
        if self.occlusion is None:
            return a
        occ = self.param(self.occlusion, ctx, 1)
        return a * (1.0 + self.occlusion_strength * (occ - 1.0))[:, None]

    def emission(self, ctx):
        return np.array(self.param(self.emission_value, ctx))


class ObjMaterial(SurfaceExtras, BlinnPhong):
    """An OBJ/MTL opaque material: energy-normalised Blinn-Phong plus MTL ``Ke`` emission."""

    type_name = None

    def __init__(self, kd, ks, exponent, *, emission=None, normal_map=None, name=None):
        BlinnPhong.__init__(self, kd, ks, exponent, name=name)
        self._init_extras(emission=emission, normal_map=normal_map)


if MetallicRoughness is not None:
    class GltfMaterial(SurfaceExtras, MetallicRoughness):
        """The glTF material: :class:`pyrt.materials.MetallicRoughness` plus emission, occlusion, normal map."""

        type_name = None

        def __init__(self, *, base_color, metallic, roughness, emission=None, occlusion=None,
                     occlusion_strength=1.0, normal_map=None, double_sided=True, name=None):
            MetallicRoughness.__init__(self, base_color=base_color, metallic=metallic, roughness=roughness,
                                       name=name)
            self._init_extras(emission=emission, occlusion=occlusion, occlusion_strength=occlusion_strength,
                              normal_map=normal_map)
            self.double_sided = bool(double_sided)
else:  # pragma: no cover
    GltfMaterial = None


def make_metallic_roughness(**kwargs):
    """Adapter: build the glTF metallic-roughness material (:class:`GltfMaterial`).

    Raises :class:`AssetError` if the material library's ``MetallicRoughness`` class is missing:
    no other model is substituted silently.
    """
    if GltfMaterial is None:
        raise AssetError("pyrt.materials.MetallicRoughness is not available, so glTF metallic-roughness "
                         "materials cannot be built (material library, issue 3)")
    return GltfMaterial(**kwargs)


def _slot_tex(slot):
    return None if slot is None else slot.texture


def to_pyrt_material(params, *, vertex_colors=None):
    """A pyrt material for loaded parameters (:class:`PBRParams`, :class:`MTLParams`, :class:`DefaultParams`).

    ``vertex_colors`` (a texture, e.g. :class:`VertexColorTexture`) multiplies the base colour /
    diffuse colour (glTF ``COLOR_0`` semantics).
    """
    if isinstance(params, PBRParams):
        base = params.base_color_factor[:3]
        tex = _slot_tex(params.base_color_texture)
        base_color = base if tex is None else ScaledTexture(tex, base)
        if vertex_colors is not None:
            base_color = ProductTexture(vertex_colors, base_color)
        metallic = params.metallic_factor if params.metallic_texture is None else \
            ScaledTexture(params.metallic_texture, params.metallic_factor)
        roughness = params.roughness_factor if params.roughness_texture is None else \
            ScaledTexture(params.roughness_texture, params.roughness_factor)
        e = params.emissive_factor * params.emissive_strength
        etex = _slot_tex(params.emissive_texture)
        emission = (e if np.any(e > 0) else None) if etex is None else ScaledTexture(etex, e)
        return make_metallic_roughness(base_color=base_color, metallic=metallic, roughness=roughness,
                                       emission=emission, occlusion=params.occlusion_texture,
                                       occlusion_strength=params.occlusion_strength,
                                       normal_map=params.normal_texture, double_sided=params.double_sided,
                                       name=params.name)
    if isinstance(params, DefaultParams):
        base = np.asarray(params.base_color, dtype=np.float64)
        base_color = base if vertex_colors is None else ProductTexture(vertex_colors, base)
        return make_metallic_roughness(base_color=base_color, metallic=params.metallic,
                                       roughness=params.roughness, name=params.name)
    if isinstance(params, MTLParams):
        return _mtl_material(params, vertex_colors)
    raise AssetError(f"unknown material parameters {type(params).__name__}")


def _mtl_is_transparent(p):
    return (p.d is not None and p.d < 1.0) or (p.illum in (4, 6, 7, 9))


def _mtl_kd_ks(p):
    """``(kd, ks, s)``: Kd and Ks clipped to [0, 1] (defaults 0.8 and 0), ks already scaled by ``s <= 1``
    so that ``kd * max(map_Kd) + ks <= 1`` in every channel."""
    kd = np.clip(p.Kd if p.Kd is not None else np.full(3, 0.8), 0.0, 1.0)
    ks = np.clip(p.Ks if p.Ks is not None else np.zeros(3), 0.0, 1.0)
    kd_max = kd * (float(np.max(p.map_Kd.image)) if p.map_Kd is not None else 1.0)
    s = _ks_scale(kd_max, ks)
    return kd, ks * s, s


def _mtl_material(p, vertex_colors=None):
    if _mtl_is_transparent(p):
        ior = p.Ni if (p.Ni is not None and p.Ni > 1.0) else 1.5
        tint = np.clip(p.Tf, 0, 1) if p.Tf is not None else 1.0
        return Glass(ior=ior, tint=tint, name=p.name)
    kd, ks, _ = _mtl_kd_ks(p)
    kd_param = kd if p.map_Kd is None else ScaledTexture(p.map_Kd, kd)
    if vertex_colors is not None:
        kd_param = ProductTexture(vertex_colors, kd_param)
    emission = None
    ke = p.Ke if p.Ke is not None else np.zeros(3)
    if p.map_Ke is not None:
        emission = ScaledTexture(p.map_Ke, ke if p.Ke is not None else np.ones(3))
    elif np.any(ke > 0):
        emission = ke
    exponent = float(p.Ns) if p.Ns is not None else 10.0
    return ObjMaterial(kd_param, ks, max(exponent, 0.0), emission=emission, normal_map=p.norm, name=p.name)


def _ks_scale(kd_max, ks):
    """Uniform factor <= 1 on ks so that kd + ks <= 1 in every channel."""
    room = 1.0 - kd_max
    need = ks > room + 1e-12
    if not np.any(need):
        return 1.0
    return float(np.min(np.where(ks > 0, np.clip(room, 0.0, None) / np.where(ks > 0, ks, 1.0), 1.0)))


# ============================================================================ lights

def light_from_photometric(L):
    """Convert an :class:`AssetLight` (candela / lux) to a pyrt light (W/sr / W/m^2).

    Uses the lights' photometric constructors (``candela=``, ``lux=``; ``I = cd / 683``,
    ``E = lux / 683`` times ``color``, see :mod:`pyrt.lights`), glTF's spot falloff
    (``spot_falloff="gltf"``) and, when the light has a ``range``, glTF's range window
    (``falloff="gltf_range"``).
    """
    color = np.asarray(L.color, dtype=np.float64)
    if L.kind == "directional":
        return DirectionalLight(L.direction, lux=L.intensity, color=color, name=L.name)
    rng = {} if L.range is None else {"falloff": "gltf_range", "range": float(L.range)}
    if L.kind == "point":
        return PointLight(L.position, candela=L.intensity, color=color, name=L.name, **rng)
    if L.kind == "spot":
        return SpotLight(L.position, L.direction, candela=L.intensity, inner_angle=math.degrees(L.inner_cone),
                         outer_angle=math.degrees(L.outer_cone), spot_falloff="gltf", color=color, name=L.name,
                         **rng)
    raise AssetError(f"unknown light type {L.kind!r}")


def _transform_light(light, m):
    """A copy of ``light`` moved by the 4x4 rigid transform ``m``."""
    import copy

    out = copy.copy(light)
    if out.position is not None:
        out.position = m[:3, :3] @ light.position + m[:3, 3]
    if out.direction is not None:
        d = m[:3, :3] @ light.direction
        out.direction = d / np.linalg.norm(d)
    return out


# ============================================================================ normals

def crease_normals(vertices, faces, crease_angle=DEFAULT_CREASE_ANGLE):
    """Smooth vertex normals that keep edges sharper than ``crease_angle`` (degrees).

    Corners are welded by exact position (so UV seams and unindexed triangle soups such as STL are
    smoothed), and a corner's normal is the angle-weighted sum of the normals of the faces around
    its position whose normal is within ``crease_angle`` of its own face's normal (Thürmer &
    Wüthrich 1998 weights). Vertices whose corners disagree are split.

    Parameters
    ----------
    vertices : (V, 3) float
    faces : (F, 3) int
    crease_angle : float
        Degrees in [0, 180]; 0 gives flat shading, 180 smooths everything.

    Returns
    -------
    src : (V', ) int64
        Source vertex of each output vertex (carry UVs and colours with ``uv[src]``).
    faces : (F, 3) int64
        Faces over the output vertices.
    normals : (V', 3) float64
        Unit normals (a degenerate face's own corners get the summed neighbours' normal, or
        (0, 0, 0) if every face around is degenerate).
    """
    v = np.asarray(vertices, dtype=np.float64)
    f = np.asarray(faces, dtype=np.int64)
    if not 0.0 <= crease_angle <= 180.0:
        raise ValueError(f"crease_angle must be in [0, 180] degrees, got {crease_angle}")
    nf = f.shape[0]
    p = v[f]                                                  # (F, 3, 3)
    fn = np.cross(p[:, 1] - p[:, 0], p[:, 2] - p[:, 0])
    ln = np.linalg.norm(fn, axis=1, keepdims=True)
    fn = np.divide(fn, ln, out=np.zeros_like(fn), where=ln > 0)
    # interior angle at each corner
    ang = np.zeros((nf, 3))
    for k in range(3):
        a = p[:, (k + 1) % 3] - p[:, k]
        b = p[:, (k + 2) % 3] - p[:, k]
        na = np.linalg.norm(a, axis=1)
        nb = np.linalg.norm(b, axis=1)
        c = np.divide(np.einsum("ij,ij->i", a, b), na * nb, out=np.zeros(nf), where=(na * nb) > 0)
        ang[:, k] = np.arccos(np.clip(c, -1.0, 1.0))
    corner_vertex = f.ravel()                                  # (3F,)
    corner_face = np.repeat(np.arange(nf), 3)
    _, pos_id = np.unique(v, axis=0, return_inverse=True)
    pos_id = pos_id.ravel()[corner_vertex]
    order = np.argsort(pos_id, kind="stable")
    sorted_pos = pos_id[order]
    starts = np.flatnonzero(np.r_[True, sorted_pos[1:] != sorted_pos[:-1]])
    counts = np.diff(np.r_[starts, sorted_pos.size])
    group_of_sorted = np.repeat(np.arange(starts.size), counts)
    # every (corner i, corner j) pair sharing a position; i in sorted order, j over its group
    cnt_i = counts[group_of_sorted]
    total = int(np.sum(cnt_i))
    rep_i = np.repeat(np.arange(sorted_pos.size), cnt_i)
    first = np.repeat(np.cumsum(cnt_i) - cnt_i, cnt_i)
    j_sorted = starts[group_of_sorted][rep_i] + (np.arange(total) - first)
    ci = order[rep_i]
    cj = order[j_sorted]
    fi, fj = corner_face[ci], corner_face[cj]
    cos_lim = math.cos(math.radians(crease_angle))
    ok = np.einsum("ij,ij->i", fn[fi], fn[fj]) >= cos_lim - 1e-12
    ok |= fi == fj
    w = ang.ravel()[cj] * ok
    acc = np.zeros((3 * nf, 3))
    for c in range(3):
        acc[:, c] = np.bincount(ci, weights=w * fn[fj, c], minlength=3 * nf)
    la = np.linalg.norm(acc, axis=1, keepdims=True)
    acc = np.divide(acc, la, out=np.zeros_like(acc), where=la > 0)
    # split vertices whose corners got different normals
    key = np.concatenate([corner_vertex[:, None].astype(np.float64).view(np.int64), acc.view(np.int64)], axis=1)
    _, first_idx, inv = np.unique(key, axis=0, return_index=True, return_inverse=True)
    src = corner_vertex[first_idx]
    return src.astype(np.int64), inv.reshape(nf, 3).astype(np.int64), acc[first_idx]


def _prepare_mesh(am, crease_angle):
    """(trimesh in object space with UVs, object-space normals, linear colours or None) for add_mesh."""
    v, f, uv, col, nrm = am.vertices, am.faces, am.uv, am.colors, am.normals
    if nrm is None:
        src, f, nrm = crease_normals(v, f, crease_angle)
        v = v[src]
        uv = None if uv is None else uv[src]
        col = None if col is None else col[src]
    tm = trimesh.Trimesh(vertices=v, faces=f, process=False)
    if uv is not None:
        tm.visual = trimesh.visual.TextureVisuals(uv=uv)
    return tm, nrm, col


# ============================================================================ glTF

_COMPONENT = {5120: np.int8, 5121: np.uint8, 5122: np.int16, 5123: np.uint16, 5125: np.uint32, 5126: np.float32}
_NCOMP = {"SCALAR": 1, "VEC2": 2, "VEC3": 3, "VEC4": 4, "MAT2": 4, "MAT3": 9, "MAT4": 16}
_WRAP = {10497: "repeat", 33071: "clamp", 33648: "mirror"}
_GLB_MAGIC = 0x46546C67
_CHUNK_JSON = 0x4E4F534A
_CHUNK_BIN = 0x004E4942


class _Gltf:
    """A parsed glTF container: JSON header, buffers (bytes), base directory for URIs."""

    def __init__(self, path):
        self.path = path
        self.base = os.path.dirname(os.path.abspath(path))
        with open(path, "rb") as fh:
            data = fh.read()
        glb_bin = None
        if data[:4] == b"glTF":
            if len(data) < 20:
                raise AssetError(f"{path}: truncated GLB header ({len(data)} bytes)")
            magic, version, length = struct.unpack_from("<III", data, 0)
            if version != 2:
                raise AssetError(f"{path}: GLB version {version} is not supported (need 2)")
            if length > len(data):
                raise AssetError(f"{path}: GLB header says {length} bytes but the file has {len(data)} (truncated)")
            off, chunks = 12, []
            while off + 8 <= length:
                clen, ctype = struct.unpack_from("<II", data, off)
                if off + 8 + clen > length:
                    raise AssetError(f"{path}: GLB chunk at byte {off} runs past the end of the file")
                chunks.append((ctype, data[off + 8: off + 8 + clen]))
                off += 8 + clen
            if not chunks or chunks[0][0] != _CHUNK_JSON:
                raise AssetError(f"{path}: GLB has no JSON chunk first")
            text = chunks[0][1]
            glb_bin = next((c for t, c in chunks[1:] if t == _CHUNK_BIN), None)
        elif path.lower().endswith(".glb"):
            raise AssetError(f"{path}: not a GLB file (the first 4 bytes are {data[:4]!r}, expected b'glTF')")
        else:
            text = data
        try:
            self.header = json.loads(text.decode("utf-8") if isinstance(text, bytes) else text)
        except (UnicodeDecodeError, json.JSONDecodeError) as exc:
            raise AssetError(f"{path}: not valid glTF JSON: {exc}") from None
        if not isinstance(self.header, dict) or "asset" not in self.header:
            raise AssetError(f"{path}: not a glTF file (no 'asset' object)")
        ver = str(self.header["asset"].get("version", ""))
        if not ver.startswith("2"):
            raise AssetError(f"{path}: glTF version {ver!r} is not supported (need 2.x)")
        required = set(self.header.get("extensionsRequired", [])) - _SUPPORTED_EXTENSIONS
        if required:
            raise AssetError(f"{path}: requires unsupported glTF extension(s) {sorted(required)}")
        self.buffers = []
        for i, b in enumerate(self.header.get("buffers", [])):
            uri = b.get("uri")
            if uri is None:
                if glb_bin is None:
                    raise AssetError(f"{path}: buffer {i} has no uri and there is no GLB binary chunk")
                blob = glb_bin
            else:
                blob = self._read_uri(uri, f"buffer {i}")
            if len(blob) < b.get("byteLength", 0):
                raise AssetError(f"{path}: buffer {i} has {len(blob)} bytes, byteLength says {b['byteLength']}")
            self.buffers.append(blob)
        self._acc_cache = {}
        self._img_cache = {}

    def _read_uri(self, uri, what):
        if uri.startswith("data:"):
            try:
                head, payload = uri.split(",", 1)
                return base64.b64decode(payload) if head.endswith(";base64") else urllib.parse.unquote_to_bytes(payload)
            except (ValueError, base64.binascii.Error) as exc:
                raise AssetError(f"{self.path}: {what}: malformed data URI: {exc}") from None
        fpath = os.path.join(self.base, urllib.parse.unquote(uri))
        if not os.path.isfile(fpath):
            raise AssetError(f"{self.path}: {what}: file not found: {fpath}")
        with open(fpath, "rb") as fh:
            return fh.read()

    def _get(self, kind, i):
        arr = self.header.get(kind, [])
        if not isinstance(i, int) or not 0 <= i < len(arr):
            raise AssetError(f"{self.path}: reference to {kind}[{i}] but the file has {len(arr)}")
        return arr[i]

    def view_bytes(self, vi):
        bv = self._get("bufferViews", vi)
        buf_i = bv.get("buffer")
        if not isinstance(buf_i, int) or not 0 <= buf_i < len(self.buffers):
            raise AssetError(f"{self.path}: bufferView {vi} refers to missing buffer {buf_i}")
        off, length = bv.get("byteOffset", 0), bv.get("byteLength", 0)
        buf = self.buffers[buf_i]
        if off + length > len(buf):
            raise AssetError(f"{self.path}: bufferView {vi} (bytes {off}..{off + length}) runs past the end of "
                             f"buffer {buf_i} ({len(buf)} bytes)")
        return buf[off: off + length], bv.get("byteStride")

    def accessor(self, ai):
        """Accessor ``ai`` as float64 (count, ncomp) (normalised integers mapped to [0, 1] / [-1, 1])."""
        if ai in self._acc_cache:
            return self._acc_cache[ai]
        a = self._get("accessors", ai)
        try:
            dt = np.dtype(_COMPONENT[a["componentType"]]).newbyteorder("<")
            nc = _NCOMP[a["type"]]
            count = int(a["count"])
        except KeyError as exc:
            raise AssetError(f"{self.path}: accessor {ai}: missing or invalid {exc}") from None
        if "bufferView" in a:
            raw, stride = self.view_bytes(a["bufferView"])
            off = a.get("byteOffset", 0)
            elem = dt.itemsize * nc
            stride = stride or elem
            need = off + (count - 1) * stride + elem if count else 0
            if need > len(raw):
                raise AssetError(f"{self.path}: accessor {ai} reads {need} bytes past bufferView "
                                 f"{a['bufferView']} of {len(raw)} bytes")
            u8 = np.frombuffer(raw, dtype=np.uint8, count=need - off if count else 0, offset=off)
            if count:
                rows = np.lib.stride_tricks.as_strided(u8, shape=(count, elem), strides=(stride, 1))
                out = np.ascontiguousarray(rows).view(dt).reshape(count, nc)
            else:
                out = np.zeros((0, nc), dtype=dt)
        else:
            out = np.zeros((count, nc), dtype=dt)
        out = self._normalise(out, a.get("normalized", False))
        sp = a.get("sparse")
        if sp:
            n = int(sp["count"])
            ib, _ = self.view_bytes(sp["indices"]["bufferView"])
            idt = np.dtype(_COMPONENT[sp["indices"]["componentType"]]).newbyteorder("<")
            idx = np.frombuffer(ib, dtype=idt, count=n, offset=sp["indices"].get("byteOffset", 0)).astype(np.int64)
            vb, _ = self.view_bytes(sp["values"]["bufferView"])
            vals = np.frombuffer(vb, dtype=dt, count=n * nc, offset=sp["values"].get("byteOffset", 0)).reshape(n, nc)
            out = out.copy()
            if idx.size and (idx.max() >= count or idx.min() < 0):
                raise AssetError(f"{self.path}: accessor {ai}: sparse index out of range")
            out[idx] = self._normalise(vals, a.get("normalized", False))
        if not np.all(np.isfinite(out)):
            raise AssetError(f"{self.path}: accessor {ai} holds NaN or Inf values")
        self._acc_cache[ai] = out
        return out

    @staticmethod
    def _normalise(x, normalized):
        if np.issubdtype(x.dtype, np.floating):
            return x.astype(np.float64)
        if not normalized:
            return x.astype(np.float64)
        info = np.iinfo(x.dtype)
        y = x.astype(np.float64) / info.max
        return np.maximum(y, -1.0) if info.min < 0 else y

    def image_array(self, ii):
        """Image ``ii`` decoded by :func:`pyrt.textures.load_image`: ``((H, W, C) float32 in its stored
        encoding, label)``, cached. Embedded images go through a temporary file of their type."""
        if ii in self._img_cache:
            return self._img_cache[ii]
        im = self._get("images", ii)
        uri = im.get("uri")
        if uri is not None and not uri.startswith("data:"):
            fpath = os.path.join(self.base, urllib.parse.unquote(uri))
            label = uri
            if not os.path.isfile(fpath):
                raise AssetError(f"{self.path}: image {ii} ({uri}): file not found: {fpath}")
            arr = _load_image_file(fpath, f"{self.path}: image {ii} ({uri})")
        else:
            if uri is not None:
                blob, label = self._read_uri(uri, f"image {ii}"), f"image {ii} (data URI)"
            elif "bufferView" in im:
                blob, label = self.view_bytes(im["bufferView"])[0], f"image {ii} (embedded)"
            else:
                raise AssetError(f"{self.path}: image {ii} has neither uri nor bufferView")
            arr = _decode_image_bytes(blob, f"{self.path}: {label}")
        self._img_cache[ii] = (arr, label)
        return arr, label


def _load_image_file(path, label):
    try:
        return load_image(path)[0]
    except TextureError as exc:
        raise AssetError(f"{label}: {exc}") from None


def _decode_image_bytes(blob, label):
    """Decode PNG/JPEG bytes with pyrt's image reader (16-bit PNGs stay 16-bit) via a temporary file."""
    if blob[:8] == b"\x89PNG\r\n\x1a\n":
        ext = ".png"
    elif blob[:3] == b"\xff\xd8\xff":
        ext = ".jpg"
    else:
        raise AssetError(f"{label}: not a PNG or JPEG image (first bytes {blob[:8]!r})")
    fd, tmp = tempfile.mkstemp(suffix=ext)
    try:
        with os.fdopen(fd, "wb") as fh:
            fh.write(blob)
        return _load_image_file(tmp, label)
    finally:
        os.remove(tmp)


_SUPPORTED_EXTENSIONS = {"KHR_lights_punctual", "KHR_texture_transform", "KHR_materials_emissive_strength",
                         "KHR_mesh_quantization"}


def gltf_uv_transform(ext):
    """``KHR_texture_transform`` -> pyrt ImageTexture (scale, offset, rotation_deg) in flipped UVs.

    glTF applies ``uv' = T R S uv`` in its top-left space with ``R = [[c, s], [-s, c]]``. With
    ``p = (u, 1 - v)`` on both sides: ``p' = R_ccw(theta) S p + o``,
    ``o = (tx + sin(theta) sy, 1 - ty - cos(theta) sy)``.
    """
    tx, ty = (float(x) for x in ext.get("offset", (0.0, 0.0)))
    sx, sy = (float(x) for x in ext.get("scale", (1.0, 1.0)))
    th = float(ext.get("rotation", 0.0))
    offset = (tx + math.sin(th) * sy, 1.0 - ty - math.cos(th) * sy)
    return (sx, sy), offset, math.degrees(th)


def _gltf_texture(g, info, what, *, srgb, kind="image", warnings=None, **extra):
    """Build a texture from a glTF textureInfo ``info`` ({index, texCoord, extensions})."""
    ti = info.get("index")
    tex = g._get("textures", ti)
    src = tex.get("source")
    if src is None:
        raise AssetError(f"{g.path}: {what}: texture {ti} has no image source in a supported format "
                         f"(extensions {sorted(tex.get('extensions', {}))})")
    arr, label = g.image_array(src)
    sampler = g._get("samplers", tex["sampler"]) if "sampler" in tex else {}
    wrap = (_WRAP.get(sampler.get("wrapS", 10497), "repeat"), _WRAP.get(sampler.get("wrapT", 10497), "repeat"))
    filt = "nearest" if sampler.get("magFilter") == 9728 and sampler.get("minFilter") in (9728, None) else "trilinear"
    texcoord = int(info.get("texCoord", 0))
    kw = {}
    tt = info.get("extensions", {}).get("KHR_texture_transform")
    if tt:
        scale, offset, rot = gltf_uv_transform(tt)
        kw = {"scale": scale, "offset": offset, "rotation_deg": rot}
        texcoord = int(tt.get("texCoord", texcoord))
    try:
        if kind == "normal":
            t = NormalMap(arr, strength=float(info.get("scale", 1.0)), wrap=wrap, name=label, **kw, **extra)
        else:
            t = ImageTexture(arr, srgb=srgb, wrap=wrap, filter=filt, name=label, **kw, **extra)
    except TextureError as exc:
        raise AssetError(f"{g.path}: {what}: {exc}") from None
    return TextureSlot(texture=t, texcoord=texcoord, source=label)


def _gltf_material(g, mi, warnings):
    m = g._get("materials", mi)
    name = m.get("name", f"material{mi}")
    pbr = m.get("pbrMetallicRoughness", {})
    what = f"material {mi} ({name})"
    P = PBRParams(name=name)
    bcf = np.asarray(pbr.get("baseColorFactor", [1.0, 1.0, 1.0, 1.0]), dtype=np.float64)
    if bcf.shape != (4,):
        raise AssetError(f"{g.path}: {what}: baseColorFactor must have 4 numbers, got {bcf.tolist()}")
    P.base_color_factor = np.clip(bcf, 0.0, 1.0)
    P.metallic_factor = float(np.clip(pbr.get("metallicFactor", 1.0), 0.0, 1.0))
    P.roughness_factor = float(np.clip(pbr.get("roughnessFactor", 1.0), 0.0, 1.0))
    if "baseColorTexture" in pbr:
        P.base_color_texture = _gltf_texture(g, pbr["baseColorTexture"], f"{what} baseColorTexture", srgb=True,
                                             channels=3)
    if "metallicRoughnessTexture" in pbr:
        slot = _gltf_texture(g, pbr["metallicRoughnessTexture"], f"{what} metallicRoughnessTexture", srgb=False)
        P.metallic_roughness_texture = slot
        raw = slot.texture
        if raw.channels < 3:
            raise AssetError(f"{g.path}: {what}: metallicRoughnessTexture {slot.source} has {raw.channels} "
                             "channel(s); need RGB (G = roughness, B = metallic)")
        P.metallic_texture = _channel(raw, 2, f"{slot.source} B (metallic)")
        P.roughness_texture = _channel(raw, 1, f"{slot.source} G (roughness)")
    if "normalTexture" in m:
        P.normal_scale = float(m["normalTexture"].get("scale", 1.0))
        P.normal_texture = _gltf_texture(g, m["normalTexture"], f"{what} normalTexture", srgb=False,
                                         kind="normal").texture
    if "occlusionTexture" in m:
        P.occlusion_strength = float(m["occlusionTexture"].get("strength", 1.0))
        slot = _gltf_texture(g, m["occlusionTexture"], f"{what} occlusionTexture", srgb=False)
        P.occlusion_texture = _channel(slot.texture, 0, f"{slot.source} R (occlusion)")
    ef = np.asarray(m.get("emissiveFactor", [0.0, 0.0, 0.0]), dtype=np.float64)
    if ef.shape != (3,) or np.any(ef < 0):
        raise AssetError(f"{g.path}: {what}: emissiveFactor must be 3 numbers >= 0, got {ef.tolist()}")
    P.emissive_factor = ef
    if "emissiveTexture" in m:
        P.emissive_texture = _gltf_texture(g, m["emissiveTexture"], f"{what} emissiveTexture", srgb=True,
                                           channels=3)
    P.emissive_strength = float(m.get("extensions", {}).get("KHR_materials_emissive_strength", {})
                                .get("emissiveStrength", 1.0))
    P.double_sided = bool(m.get("doubleSided", False))
    P.alpha_mode = m.get("alphaMode", "OPAQUE")
    P.alpha_cutoff = float(m.get("alphaCutoff", 0.5))
    if P.alpha_mode != "OPAQUE":
        warnings.append(f"{what}: alphaMode {P.alpha_mode} is rendered opaque")
    sets = {s.texcoord for s in (P.base_color_texture, P.metallic_roughness_texture, P.emissive_texture) if s}
    for k in ("normalTexture", "occlusionTexture"):
        if k in m:
            sets.add(int(m[k].get("texCoord", 0)))
    if len(sets) > 1:
        warnings.append(f"{what}: textures use several UV sets {sorted(sets)}; all read TEXCOORD_{min(sets)}")
    P.texcoord = min(sets) if sets else 0
    other = set(m.get("extensions", {})) - _SUPPORTED_EXTENSIONS
    if other:
        warnings.append(f"{what}: material extension(s) {sorted(other)} ignored")
    return P


def _channel(tex, c, label):
    """A 1-channel linear texture from channel ``c`` of an ImageTexture (same wrap/filter/transform)."""
    img = np.asarray(tex.image)
    return ImageTexture(np.ascontiguousarray(img[:, :, c]), srgb=False, wrap=tex.wrap, filter=tex.filter,
                        scale=tex.scale, offset=tex.offset, rotation_deg=tex.rotation_deg, name=label)


def _node_local(node):
    if "matrix" in node:
        m = np.asarray(node["matrix"], dtype=np.float64)
        if m.shape != (16,):
            raise ValueError(f"matrix must have 16 numbers, got {m.size}")
        return m.reshape(4, 4).T  # column-major
    m = np.eye(4)
    if "scale" in node:
        m = np.diag([*np.asarray(node["scale"], dtype=np.float64), 1.0]) @ m
    if "rotation" in node:
        x, y, z, w = (float(q) for q in node["rotation"])
        m = trimesh.transformations.quaternion_matrix([w, x, y, z]) @ m
    if "translation" in node:
        m = trimesh.transformations.translation_matrix(np.asarray(node["translation"], dtype=np.float64)) @ m
    return m


def gltf_node_transforms(header):
    """World transforms of the nodes of the default scene: {node index: (4, 4) world_from_node}."""
    nodes = header.get("nodes", [])
    scenes = header.get("scenes")
    if scenes:
        roots = scenes[header.get("scene", 0)].get("nodes", [])
    else:
        children = {c for n in nodes for c in n.get("children", [])}
        roots = [i for i in range(len(nodes)) if i not in children]
    out = {}
    stack = [(r, np.eye(4)) for r in roots]
    while stack:
        i, parent = stack.pop()
        if not isinstance(i, int) or not 0 <= i < len(nodes):
            raise AssetError(f"reference to node {i} but the file has {len(nodes)} nodes")
        if i in out:
            raise AssetError(f"node {i} is reached twice (a cycle or a node with two parents)")
        try:
            world = parent @ _node_local(nodes[i])
        except (ValueError, TypeError) as exc:
            raise AssetError(f"node {i}: invalid transform: {exc}") from None
        if not np.all(np.isfinite(world)):
            raise AssetError(f"node {i}: transform is not finite")
        out[i] = world
        stack.extend((c, world) for c in nodes[i].get("children", []))
    return out


def pack_glb(header, binary=b""):
    """Encode a glTF JSON ``header`` (dict) and its binary buffer as GLB 2.0 bytes.

    Buffer 0 of ``header`` must be the binary chunk (no ``uri``); chunks are padded to 4 bytes
    (JSON with spaces, binary with zeros) as the specification requires.
    """
    js = json.dumps(header, separators=(",", ":")).encode("utf-8")
    js += b" " * (-len(js) % 4)
    binary = bytes(binary) + b"\0" * (-len(binary) % 4)
    chunks = struct.pack("<II", len(js), _CHUNK_JSON) + js
    if binary:
        chunks += struct.pack("<II", len(binary), _CHUNK_BIN) + binary
    return struct.pack("<III", _GLB_MAGIC, 2, 12 + len(chunks)) + chunks


def read_gltf(path):
    """The JSON header (dict) and the buffers (list of bytes) of a .gltf or .glb file."""
    g = _Gltf(os.fspath(path))
    return g.header, g.buffers


def _strip_faces(idx, mode):
    n = idx.size
    if n < 3:
        return np.zeros((0, 3), dtype=np.int64)
    k = np.arange(n - 2)
    if mode == 5:  # strip: odd triangles flipped to keep the winding
        a = np.where(k % 2 == 0, idx[k], idx[k + 1])
        b = np.where(k % 2 == 0, idx[k + 1], idx[k])
        return np.stack([a, b, idx[k + 2]], axis=1)
    return np.stack([np.full(n - 2, idx[0]), idx[k + 1], idx[k + 2]], axis=1)  # fan


def load_gltf(path):
    """Load a glTF 2.0 (.gltf + files / data URIs) or GLB file into an :class:`Asset`."""
    g = _Gltf(path)
    h = g.header
    asset = Asset(path=path, format="gltf", up_axis="+y")
    W = asset.warnings
    try:
        world = gltf_node_transforms(h)
    except AssetError as exc:
        raise AssetError(f"{path}: {exc}") from None
    # materials
    asset.materials = [_gltf_material(g, i, W) for i in range(len(h.get("materials", [])))]
    # meshes: glTF mesh index -> list of AssetMesh indices (one per triangle primitive)
    mesh_prims = {}

    def decode_mesh(mi):
        if mi in mesh_prims:
            return mesh_prims[mi]
        m = g._get("meshes", mi)
        ids = []
        for pi, p in enumerate(m.get("primitives", [])):
            where = f"mesh {mi} ({m.get('name', '')}) primitive {pi}"
            mode = p.get("mode", 4)
            if mode not in (4, 5, 6):
                W.append(f"{where}: mode {mode} (points/lines) skipped")
                continue
            attrs = p.get("attributes", {})
            if "POSITION" not in attrs:
                raise AssetError(f"{path}: {where}: no POSITION attribute")
            if "targets" in p:
                W.append(f"{where}: morph targets ignored (rest pose rendered)")
            pos = g.accessor(attrs["POSITION"])
            if pos.shape[1] != 3:
                raise AssetError(f"{path}: {where}: POSITION must be VEC3")
            nv = pos.shape[0]
            idx = g.accessor(p["indices"]).astype(np.int64).ravel() if "indices" in p else np.arange(nv)
            if idx.size and (idx.min() < 0 or idx.max() >= nv):
                raise AssetError(f"{path}: {where}: index {int(idx.max())} out of range for {nv} vertices")
            if mode == 4:
                if idx.size % 3:
                    raise AssetError(f"{path}: {where}: {idx.size} indices is not a multiple of 3")
                faces = idx.reshape(-1, 3)
            else:
                faces = _strip_faces(idx, mode)
            if faces.shape[0] == 0:
                W.append(f"{where}: no triangles")
                continue
            normals = None
            if "NORMAL" in attrs:
                normals = g.accessor(attrs["NORMAL"])[:, :3]
                ln = np.linalg.norm(normals, axis=1, keepdims=True)
                normals = np.divide(normals, ln, out=np.zeros_like(normals), where=ln > 0)
            mat = p.get("material", -1)
            if mat >= len(asset.materials):
                raise AssetError(f"{path}: {where}: material {mat} does not exist")
            tc = asset.materials[mat].texcoord if mat >= 0 else 0
            uv = None
            if f"TEXCOORD_{tc}" in attrs:
                uv = g.accessor(attrs[f"TEXCOORD_{tc}"])[:, :2].copy()
                uv[:, 1] = 1.0 - uv[:, 1]          # glTF top-left -> pyrt bottom-left
            elif mat >= 0 and _has_textures(asset.materials[mat]):
                W.append(f"{where}: material {asset.materials[mat].name!r} has textures but the primitive has "
                         f"no TEXCOORD_{tc}")
            colors = None
            if "COLOR_0" in attrs:
                colors = np.clip(g.accessor(attrs["COLOR_0"])[:, :3], 0.0, None)
            for arr, nm in ((normals, "NORMAL"), (uv, "TEXCOORD"), (colors, "COLOR_0")):
                if arr is not None and arr.shape[0] != nv:
                    raise AssetError(f"{path}: {where}: {nm} has {arr.shape[0]} entries for {nv} vertices")
            asset.meshes.append(AssetMesh(name=f"{m.get('name', f'mesh{mi}')}.{pi}", vertices=pos, faces=faces,
                                          normals=normals, uv=uv, colors=colors, material=mat))
            ids.append(len(asset.meshes) - 1)
        mesh_prims[mi] = ids
        return ids

    lights_def = h.get("extensions", {}).get("KHR_lights_punctual", {}).get("lights", [])
    nodes = h.get("nodes", [])
    for ni in sorted(world):
        node = nodes[ni]
        M = world[ni]
        nname = node.get("name", f"node{ni}")
        if "skin" in node:
            W.append(f"node {ni} ({nname}): skinning ignored (bind pose rendered)")
        if "mesh" in node:
            for am in decode_mesh(node["mesh"]):
                asset.instances.append(AssetInstance(mesh=am, world_from_object=M, node=nname))
        if "camera" in node:
            cam = g._get("cameras", node["camera"])
            if cam.get("type") == "perspective" and "perspective" in cam:
                pp = cam["perspective"]
                asset.cameras.append(AssetCamera(
                    name=cam.get("name", nname), position=M[:3, 3].copy(), forward=_unit(-M[:3, 2]),
                    up=_unit(M[:3, 1]), yfov_deg=math.degrees(float(pp["yfov"])), aspect=pp.get("aspectRatio")))
            else:
                W.append(f"camera {node['camera']} ({cam.get('type')}): only perspective cameras are supported")
        lext = node.get("extensions", {}).get("KHR_lights_punctual")
        if lext is not None:
            li = lext.get("light")
            if not isinstance(li, int) or not 0 <= li < len(lights_def):
                raise AssetError(f"{path}: node {ni} refers to KHR_lights_punctual light {li}, "
                                 f"but the file defines {len(lights_def)}")
            asset.lights.append(_gltf_light(lights_def[li], li, M, path))
    if not asset.instances:
        raise AssetError(f"{path}: the default scene has no triangle meshes")
    return asset


def _has_textures(P):
    return any(x is not None for x in (P.base_color_texture, P.metallic_roughness_texture, P.normal_texture,
                                       P.occlusion_texture, P.emissive_texture))


def _unit(v):
    n = np.linalg.norm(v)
    if not n > 0:
        raise AssetError("a camera or light node has a degenerate (zero-scale) transform")
    return v / n


def _gltf_light(d, li, M, path):
    kind = d.get("type")
    if kind not in ("point", "spot", "directional"):
        raise AssetError(f"{path}: KHR_lights_punctual light {li}: unknown type {kind!r}")
    color = np.asarray(d.get("color", [1.0, 1.0, 1.0]), dtype=np.float64)
    intensity = float(d.get("intensity", 1.0))
    if color.shape != (3,) or np.any(color < 0) or intensity < 0:
        raise AssetError(f"{path}: KHR_lights_punctual light {li}: color must be 3 numbers >= 0 and intensity >= 0")
    spot = d.get("spot", {})
    return AssetLight(name=d.get("name", f"light{li}"), kind=kind, color=color, intensity=intensity,
                      position=M[:3, 3].copy(), direction=_unit(-M[:3, 2]), range=d.get("range"),
                      inner_cone=float(spot.get("innerConeAngle", 0.0)),
                      outer_cone=float(spot.get("outerConeAngle", math.pi / 4)))


# ============================================================================ OBJ / MTL

_MTL_OPTS = {"-blendu": 1, "-blendv": 1, "-bm": 1, "-boost": 1, "-cc": 1, "-clamp": 1, "-imfchan": 1,
             "-mm": 2, "-texres": 1, "-type": 1, "-o": 3, "-s": 3, "-t": 3}


def _mtl_map(tokens, base, what, *, srgb, warnings, normal=False):
    """Parse ``map_* [options] file`` -> texture (missing file: AssetError)."""
    opts, i = {}, 0
    while i < len(tokens) and tokens[i] in _MTL_OPTS:
        k = tokens[i]
        n = _MTL_OPTS[k]
        vals = []
        i += 1
        while len(vals) < n and i < len(tokens):
            try:
                vals.append(float(tokens[i]))
            except ValueError:
                if k in ("-o", "-s", "-t") and vals:
                    break
                vals.append(tokens[i])
            i += 1
        opts[k] = vals
    fname = " ".join(tokens[i:])
    if not fname:
        raise AssetError(f"{what}: no file name")
    fpath = fname if os.path.isabs(fname) else os.path.join(base, fname.replace("\\", "/"))
    if not os.path.isfile(fpath):
        raise AssetError(f"{what}: texture file not found: {fpath}")
    kw = {}
    if "-s" in opts:
        s = [float(x) for x in opts["-s"][:2]] + [1.0] * (2 - len(opts["-s"][:2]))
        kw["scale"] = tuple(s)
    if "-o" in opts:
        o = [float(x) for x in opts["-o"][:2]] + [0.0] * (2 - len(opts["-o"][:2]))
        kw["offset"] = tuple(o)
    ignored = set(opts) - {"-s", "-o"}
    if ignored:
        warnings.append(f"{what}: map options {sorted(ignored)} ignored")
    try:
        if normal:
            return NormalMap(fpath, **kw)
        return ImageTexture(fpath, srgb=srgb, channels=3, **kw)
    except TextureError as exc:
        raise AssetError(f"{what}: {exc}") from None


def parse_mtl(path, warnings=None):
    """Parse an MTL file into {name: :class:`MTLParams`}; texture files are loaded (missing -> AssetError)."""
    warnings = warnings if warnings is not None else []
    base = os.path.dirname(os.path.abspath(path))
    out, cur = {}, None
    with open(path, "r", encoding="utf-8", errors="replace") as fh:
        for lineno, line in enumerate(fh, 1):
            line = line.strip()
            if not line or line.startswith("#"):
                continue
            tok = line.split()
            key, args = tok[0], tok[1:]
            where = f"{path}:{lineno}"
            if key == "newmtl":
                name = " ".join(args)
                cur = out[name] = MTLParams(name=name)
                continue
            if cur is None:
                raise AssetError(f"{where}: '{key}' before any 'newmtl'")
            try:
                if key in ("Kd", "Ks", "Ke", "Tf"):
                    if args and args[0] in ("spectral", "xyz"):
                        warnings.append(f"{where}: {key} {args[0]} not supported; ignored")
                        continue
                    vals = [float(a) for a in args[:3]]
                    vals = vals * 3 if len(vals) == 1 else vals
                    if len(vals) != 3:
                        raise ValueError("need 1 or 3 numbers")
                    setattr(cur, key, np.asarray(vals, dtype=np.float64))
                elif key in ("Ns", "Ni"):
                    setattr(cur, key, float(args[0]))
                elif key == "d":
                    cur.d = float(args[-1])
                elif key == "Tr":
                    cur.d = 1.0 - float(args[0])
                elif key == "illum":
                    cur.illum = int(args[0])
                elif key == "map_Kd":
                    cur.map_Kd = _mtl_map(args, base, f"{where}: map_Kd", srgb=True, warnings=warnings)
                elif key == "map_Ke":
                    cur.map_Ke = _mtl_map(args, base, f"{where}: map_Ke", srgb=True, warnings=warnings)
                elif key in ("norm", "map_Kn"):
                    cur.norm = _mtl_map(args, base, f"{where}: {key}", srgb=False, warnings=warnings, normal=True)
                elif key.startswith("map_") or key in ("bump", "disp", "decal", "refl"):
                    warnings.append(f"{where}: {key} not supported; ignored")
                elif key in ("Ka", "Pr", "Pm", "Ps", "Pc", "Pcr", "aniso", "anisor", "sharpness"):
                    pass  # not used by the mapping (see the module docstring)
                else:
                    warnings.append(f"{where}: unknown MTL statement {key!r} ignored")
            except AssetError:
                raise
            except (ValueError, IndexError) as exc:
                raise AssetError(f"{where}: cannot parse {line!r}: {exc}") from None
    return out


def load_obj(path):
    """Load an OBJ (+ MTL) file into an :class:`Asset` (MTL mapping: see the module docstring)."""
    asset = Asset(path=path, format="obj")
    W = asset.warnings
    with open(path, "r", encoding="utf-8", errors="replace") as fh:
        text = fh.read()
    has_vn = re.search(r"^\s*vn\s", text, flags=re.M) is not None
    mtls = {}
    base = os.path.dirname(os.path.abspath(path))
    for m in re.finditer(r"^\s*mtllib\s+(.+?)\s*$", text, flags=re.M):
        mpath = os.path.join(base, m.group(1).replace("\\", "/"))
        if not os.path.isfile(mpath):
            raise AssetError(f"{path}: material library not found: {mpath}")
        mtls.update(parse_mtl(mpath, W))
    used = set(re.findall(r"^\s*usemtl\s+(.+?)\s*$", text, flags=re.M))
    missing = used - set(mtls)
    if missing:
        W.append(f"{path}: material(s) {sorted(missing)} not defined in the MTL; default material used")
    tm = _trimesh_load(path, "OBJ")
    names = list(mtls)
    asset.materials = [mtls[n] for n in names]
    geoms = tm.geometry.items() if isinstance(tm, trimesh.Scene) else [("mesh", tm)]
    # trimesh groups OBJ faces by material; read each group's material name from the OBJ itself
    groups = _obj_material_groups(text)
    for gname, mesh in geoms:
        if not isinstance(mesh, trimesh.Trimesh) or len(mesh.faces) == 0:
            continue
        mname = _trimesh_obj_material_name(mesh, gname, groups)
        mi = names.index(mname) if mname in names else -1
        uv = getattr(mesh.visual, "uv", None)
        uv = np.asarray(uv, dtype=np.float64) if uv is not None and len(uv) == len(mesh.vertices) else None
        colors = _vertex_colors(mesh)
        normals = np.asarray(mesh.vertex_normals, dtype=np.float64) if has_vn else None
        asset.meshes.append(AssetMesh(name=str(gname), vertices=np.asarray(mesh.vertices, dtype=np.float64),
                                      faces=np.asarray(mesh.faces, dtype=np.int64), normals=normals, uv=uv,
                                      colors=colors, material=mi))
        asset.instances.append(AssetInstance(mesh=len(asset.meshes) - 1, world_from_object=np.eye(4),
                                             node=str(gname)))
    if not asset.instances:
        raise AssetError(f"{path}: no triangles found in the OBJ file")
    for p in asset.materials:
        if _mtl_is_transparent(p) and not (p.Ni is not None and p.Ni > 1.0):
            W.append(f"material {p.name!r}: transparent with Ni {p.Ni}; glass with ior 1.5 used")
        if not _mtl_is_transparent(p):
            s = _mtl_kd_ks(p)[2]
            if s < 1.0:
                W.append(f"material {p.name!r}: Kd + Ks > 1; Ks scaled by {s:.3f} to conserve energy")
    return asset


def _obj_material_groups(text):
    return re.findall(r"^\s*usemtl\s+(.+?)\s*$", text, flags=re.M)


def _trimesh_obj_material_name(mesh, gname, groups):
    mat = getattr(mesh.visual, "material", None)
    name = getattr(mat, "name", None)
    if name in groups:
        return name
    return gname if gname in groups else None


def _trimesh_load(path, fmt, **kw):
    try:
        return trimesh.load(path, process=False, **kw)
    except Exception as exc:  # trimesh raises many exception types for malformed files
        raise AssetError(f"{path}: cannot read {fmt} file: {type(exc).__name__}: {exc}") from None


def _vertex_colors(mesh):
    """Linear RGB vertex colours (8-bit sRGB in the file) or None."""
    vis = mesh.visual
    if getattr(vis, "kind", None) != "vertex":
        return None
    c = np.asarray(vis.vertex_colors)
    if c.shape[0] != len(mesh.vertices):
        return None
    rgb = c[:, :3].astype(np.float64) / 255.0 if c.dtype == np.uint8 else np.clip(c[:, :3], 0, 1)
    return _color.srgb_decode(rgb)


def _load_single(path, fmt):
    asset = Asset(path=path, format=fmt)
    tm = _trimesh_load(path, fmt.upper())
    if isinstance(tm, trimesh.Scene):
        meshes = [g for g in tm.dump() if isinstance(g, trimesh.Trimesh)] if hasattr(tm, "dump") else []
        tm = trimesh.util.concatenate(meshes) if meshes else None
    if not isinstance(tm, trimesh.Trimesh) or len(tm.faces) == 0:
        raise AssetError(f"{path}: no triangles found in the {fmt.upper()} file")
    normals = None
    if fmt == "ply" and _ply_has_normals(path):
        normals = np.asarray(tm.vertex_normals, dtype=np.float64)
    colors = _vertex_colors(tm)
    uv = getattr(tm.visual, "uv", None)
    uv = np.asarray(uv, dtype=np.float64) if uv is not None and len(uv) == len(tm.vertices) else None
    v = np.asarray(tm.vertices, dtype=np.float64)
    if not np.all(np.isfinite(v)):
        raise AssetError(f"{path}: vertex positions contain NaN or Inf")
    asset.meshes.append(AssetMesh(name=os.path.basename(path), vertices=v, faces=np.asarray(tm.faces, dtype=np.int64),
                                  normals=normals, uv=uv, colors=colors, material=-1))
    asset.instances.append(AssetInstance(mesh=0, world_from_object=np.eye(4), node=os.path.basename(path)))
    return asset


def _ply_has_normals(path):
    with open(path, "rb") as fh:
        head = fh.read(4096)
    end = head.find(b"end_header")
    return re.search(rb"property\s+\w+\s+nx\b", head[: end if end > 0 else None]) is not None


def load_asset(path):
    """Load any supported file (by extension: .gltf .glb .obj .ply .stl) into an :class:`Asset`."""
    path = os.fspath(path)
    if not os.path.isfile(path):
        raise AssetError(f"asset file not found: {path}")
    ext = os.path.splitext(path)[1].lower()
    fmt = FORMATS.get(ext)
    if fmt is None:
        raise AssetError(f"{path}: unsupported file type {ext!r}; supported: {sorted(FORMATS)}")
    t0 = time.perf_counter()
    if fmt == "gltf":
        asset = load_gltf(path)
    elif fmt == "obj":
        asset = load_obj(path)
    else:
        asset = _load_single(path, fmt)
    asset.load_time = time.perf_counter() - t0
    return asset
