"""Shared by every asset format: the error class, the file types, the material parameter records
and the trimesh helpers of the formats trimesh reads (OBJ geometry, PLY, STL)."""
from __future__ import annotations

import contextlib
from dataclasses import dataclass, field
import os
import re
import struct

import numpy as np

from pyrt.shaders import color as _color

from pyrt.core.errors import Error
from pyrt.geometry.normals import DEFAULT_CREASE_ANGLE
from pyrt.textures import ImageTexture, NormalMap, Texture

__all__ = ["AssetError", "FORMATS", "DEFAULT_CREASE_ANGLE", "TextureSlot", "PBRParams", "MTLParams", "DefaultParams",
           "colour_texels"]


class AssetError(Error, ValueError):
    """An asset file cannot be loaded; the message names the file and what is wrong."""


@contextlib.contextmanager
def malformed_is_asset_error(path, fmt):
    """Turn what a malformed file makes Python raise (a JSON string where a number belongs, a missing key ...)
    into an :class:`AssetError` naming the file; pyrt's own errors pass through unchanged. The loaders check the
    common cases with precise messages first; this is the net under them."""
    try:
        yield
    except Error:
        raise
    except (TypeError, KeyError, AttributeError, ValueError, IndexError, OverflowError, struct.error) as exc:
        raise AssetError(f"{path}: malformed {fmt} file: {type(exc).__name__}: {exc}") from None


FORMATS = {".gltf": "gltf", ".glb": "gltf", ".obj": "obj", ".ply": "ply", ".stl": "stl", ".off": "off",
           ".zip": "zip"}


# ============================================================================ material parameters

@dataclass
class TextureSlot:
    """A texture as the file describes it: the decoded texture and the parameters that apply to it."""

    texture: ImageTexture
    texcoord: int = 0
    source: str = ""                # file name or "image 3 (embedded)"
    image: int | None = None        # glTF image index (the key of the per-load texel cache)


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
    alpha_texture: ImageTexture | None = None              # base colour's alpha channel (MASK / BLEND)
    texcoords: tuple = ()                                   # the UV sets its textures read (uv_sets_read)
    # KHR_materials_* (pyrt.io.assets.gltf_khr); None / defaults: the extension is absent
    unlit: bool = False
    ior: float = 1.5
    transmission_factor: float = 0.0
    transmission_texture: ImageTexture | None = None        # R
    thickness_factor: float = 0.0                           # > 0: the mesh bounds a volume
    attenuation_color: np.ndarray = field(default_factory=lambda: np.ones(3))
    attenuation_distance: float = float("inf")
    specular_factor: float = 1.0
    specular_texture: ImageTexture | None = None            # A
    specular_color_factor: np.ndarray = field(default_factory=lambda: np.ones(3))
    specular_color_texture: TextureSlot | None = None       # RGB, sRGB
    clearcoat_factor: float = 0.0
    clearcoat_texture: ImageTexture | None = None           # R
    clearcoat_roughness_factor: float = 0.0
    clearcoat_roughness_texture: ImageTexture | None = None  # G
    clearcoat_normal_texture: NormalMap | None = None
    sheen_color_factor: np.ndarray = field(default_factory=lambda: np.zeros(3))
    sheen_color_texture: TextureSlot | None = None          # RGB, sRGB
    sheen_roughness_factor: float = 0.0
    sheen_roughness_texture: ImageTexture | None = None     # A
    anisotropy_strength: float = 0.0
    anisotropy_rotation: float = 0.0                         # radians, counter-clockwise from the tangent
    anisotropy_texture: ImageTexture | None = None           # RGB, linear: RG direction, B strength
    ext_slots: list = field(default_factory=list)           # the extensions' TextureSlots (UV sets)

    def uv_sets_read(self):
        """The sorted UV sets (``texcoord``, glTF ``TEXCOORD_k``) read by the material's textures, e.g. ``(0, 1)``."""
        found = set()
        for v in vars(self).values():
            for t in (v if isinstance(v, list) else [v]):
                t = t.texture if isinstance(t, TextureSlot) else t
                if isinstance(t, Texture):
                    found.add(t.texcoord)
        return tuple(sorted(found))

    @property
    def uses_pbr_extensions(self):
        """The material needs :class:`pyrt.materials.GltfPBR` (specular, ior or transmission differ from the
        core model's, or ``KHR_materials_anisotropy`` has a strength)."""
        return (self.transmission_factor > 0 or self.transmission_texture is not None or self.ior != 1.5
                or self.specular_factor != 1.0 or self.specular_texture is not None
                or np.any(self.specular_color_factor != 1.0) or self.specular_color_texture is not None
                or self.anisotropy_strength > 0)

    @property
    def tangent_texcoord(self):
        """The UV set whose vertex tangents the material's normal maps and anisotropy use (the normal map's, else the
        clear coat's normal map's; set 0 for anisotropy alone), or None when it needs no tangent frame."""
        for t in (self.normal_texture, self.clearcoat_normal_texture):
            if t is not None:
                return t.texcoord
        return 0 if self.anisotropy_strength > 0 else None

    @property
    def sheened(self):
        """``KHR_materials_sheen`` with a sheen colour that is not black."""
        return bool(np.any(self.sheen_color_factor > 0))

    @property
    def coated(self):
        """``KHR_materials_clearcoat`` with a non-zero coat."""
        return self.clearcoat_factor > 0


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
    map_d: ImageTexture | None = None     # 1 channel: the dissolve (opacity) map, times d
    # the exporters' PBR extension of MTL (Clara.io / Blender "PBR extensions"): roughness, metallic
    Pr: float | None = None
    Pm: float | None = None
    map_Pr: ImageTexture | None = None    # 1 channel
    map_Pm: ImageTexture | None = None    # 1 channel

    @property
    def tangent_texcoord(self):
        """0 when the block has a normal map (its tangent frame's UV set), else None."""
        return None if self.norm is None else 0

    @property
    def pbr(self):
        """True when the block uses the PBR extension (``Pr``, ``Pm``, ``map_Pr`` or ``map_Pm``)."""
        return any(v is not None for v in (self.Pr, self.Pm, self.map_Pr, self.map_Pm))


@dataclass
class DefaultParams:
    """The preview material for files without materials (PLY, STL, OFF): a grey dielectric "clay"."""

    name: str = "default"
    base_color: tuple = (0.8, 0.8, 0.8)
    metallic: float = 0.0
    roughness: float = 0.5
    #: no normal map: no tangent frame
    tangent_texcoord = None


def colour_texels(img):
    """Texels as colour: a grey ``(H, W)`` / ``(H, W, 1)`` image becomes RGB ``(g, g, g)`` and grey + alpha becomes
    ``(g, g, g, a)`` (what a PNG decoder gives for a grey image read as colour); 3 and 4 channels are returned as
    they are. The loaders apply it to every image a material slot reads, so a grey or grey+alpha base colour,
    emissive or metallic-roughness PNG renders instead of being refused for its channel count."""
    img = np.asarray(img)
    if img.ndim == 2:
        img = img[:, :, None]
    if img.ndim == 3 and img.shape[2] in (1, 2):
        rgb = np.repeat(img[:, :, :1], 3, axis=2)
        return rgb if img.shape[2] == 1 else np.concatenate([rgb, img[:, :, 1:2]], axis=2)
    return img


# ============================================================================ trimesh-read formats

def trimesh_load(path, fmt, *, label=None, **kw):
    """``trimesh.load(path, process=False)`` (vertices as in the file: NaN is kept, to be refused by the caller);
    any failure is an :class:`AssetError` naming the file (``label``, default ``path``)."""
    import trimesh  # deferred (pyrt.core.transforms)
    try:
        return trimesh.load(path, process=False, **kw)
    except Exception as exc:  # trimesh raises many exception types for malformed files
        raise AssetError(f"{label or path}: cannot read {fmt} file: {type(exc).__name__}: {exc}") from None


def vertex_colors(mesh):
    """Linear RGB vertex colours (8-bit sRGB in the file) or None."""
    import trimesh  # deferred (pyrt.core.transforms)
    vis = mesh.visual     # ColorVisuals / TextureVisuals: both declare ``kind`` (None when no colours)
    if not isinstance(vis, trimesh.visual.ColorVisuals) or vis.kind != "vertex":
        return None
    c = np.asarray(vis.vertex_colors)
    if c.shape[0] != len(mesh.vertices):
        return None
    rgb = c[:, :3].astype(np.float64) / 255.0 if c.dtype == np.uint8 else np.clip(c[:, :3], 0, 1)
    return _color.srgb_decode(rgb)


def face_colors(mesh):
    """Linear RGB face colours ``(F, 3)`` (8-bit sRGB in the file, e.g. PLY ``face`` ``red green blue``) or None."""
    import trimesh  # deferred (pyrt.core.transforms)
    vis = mesh.visual
    if not isinstance(vis, trimesh.visual.ColorVisuals) or vis.kind != "face":
        return None
    c = np.asarray(vis.face_colors)
    if c.shape[0] != len(mesh.faces):
        return None
    rgb = c[:, :3].astype(np.float64) / 255.0 if c.dtype == np.uint8 else np.clip(c[:, :3], 0, 1)
    return _color.srgb_decode(rgb)


# ============================================================================ up axis stated in a file

_COMMENT_UP = (re.compile(r"\bup[\s_-]*(?:axis|vector|direction|dir)?\s*[:=]?\s*([+-]?)\s*([xyz])\b", re.I),
               re.compile(r"\b([+-]?)([xyz])[\s_-]*up\b", re.I))


def metadata_up_axis(path, fmt):
    """The up axis a PLY header comment or an OBJ ``#`` comment states ("+z" etc.), or None.

    Read: the PLY header up to ``end_header`` and the first 64 KiB of an OBJ's comment lines, for phrases
    such as ``comment up_axis Z``, ``# Z-up``, ``# up: +y`` (case-insensitive). glTF needs none (y-up by
    specification) and STL has no such convention.
    """
    if fmt not in ("ply", "obj") or not path or not os.path.isfile(path):
        return None
    with open(path, "rb") as fh:
        head = fh.read(65536)
    lines = head.decode("latin-1").splitlines()
    if fmt == "ply":
        text = []
        for ln in lines:
            if ln.strip() == "end_header":
                break
            if ln.startswith(("comment", "obj_info")):
                text.append(ln)
    else:
        text = [ln for ln in lines if ln.lstrip().startswith("#")]
    for ln in text:
        for pat in _COMMENT_UP:
            m = pat.search(ln)
            if m:
                return (m.group(1) or "+") + m.group(2).lower()
    return None
