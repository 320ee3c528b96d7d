"""Load real assets (glTF 2.0 / GLB, OBJ + MTL, PLY, STL, OFF; also inside a ZIP archive) into a :class:`pyrt.Scene`.

``asset = load_asset(path)`` reads a file into an :class:`Asset` (object-space meshes, instances with
their world transforms, materials, cameras, lights, warnings); ``asset.add_to_scene(scene)`` adds it
to a scene. A broken file raises :class:`AssetError` with a message naming the file and the part
that is wrong (an accessor past the end of its buffer, invalid JSON, an index out of range, a corrupt image, ...).

Forgiving where the model itself is fine (each a *substitution*, :attr:`Asset.substitutions`, also a warning, listed
per model in ``pyrt-preview``'s batch summary): a missing texture file -> the slot's factor alone (glTF, MTL maps);
a missing MTL -> the default material. Grey, grey + alpha, palette (with or without transparency), 16-bit and
CMYK images are converted (to RGB / RGBA, :func:`colour_texels`; CMYK by Pillow's ``255 - ink``); PLY face colours
are read (:class:`FaceColorTexture`) and PLY ``tristrips`` are read into triangles (:func:`read_ply_tristrips`);
OFF vertex and face colours are read (:mod:`pyrt.io.assets.off`).

Conventions
-----------
- **UVs** follow pyrt's convention (:mod:`pyrt.textures`): ``(0, 0)`` is the *bottom-left* of the
  image, ``v`` up, texel row ``(1 - v) H``. glTF puts ``(0, 0)`` at the top-left, so glTF
  ``TEXCOORD_n`` are stored as ``(u, 1 - v)`` (the same flip trimesh applies; ``TEXCOORD_0`` is the mesh's UVs,
  a further set is kept, in ``AssetMesh.uv_sets``, only when a texture's ``texCoord`` reads it); OBJ, PLY and trimesh
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
- **Coverage** (:mod:`~pyrt.io.assets.alpha`): ``alphaMode`` MASK / BLEND with ``alphaCutoff`` and
  ``doubleSided`` become the material's coverage (:meth:`pyrt.materials.Material.set_coverage`, rendered by
  :mod:`pyrt.integrators.coverage`); the alpha is baseColorFactor.a x baseColorTexture.a (linear) x
  ``COLOR_0``.a; OPAQUE ignores every alpha.
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
- **Pose** (:mod:`pyrt.io.assets.gltf_pose`): the file's pose without animations. Morph targets are summed at
  the node's ``weights``, else the mesh's, else 0. Skinned meshes are posed by their joints' node transforms
  times the inverse bind matrices (linear blend skinning); the skinned node's own transform is ignored, as glTF
  requires.
- **Instancing**: a glTF mesh used by several nodes is decoded once; its object-space arrays,
  smooth normals, UVs and materials are shared by the instances. The Embree scene holds one
  world-space copy per instance (:mod:`pyrt.geometry.accel` has no instancing). A model of at least
  :data:`pyrt.io.assets.asset.FLATTEN_MIN_INSTANCES` (64) instances adds the instances of one material as one
  world-space scene mesh (the same triangles, fewer scene meshes and Embree geometries).
- **Materials that differ only in their base colour** (glTF ``baseColorFactor``, MTL ``Kd``) are added as one
  material, the colour moved into the vertex colours (:mod:`pyrt.io.assets.merge`; ``Asset.merge_materials``).
- **Normals**: file normals are used as given; meshes without normals get crease-angle smooth
  normals (:func:`crease_normals`, default 30 degrees), welded by position so UV seams and STL
  triangle soups are smoothed too. Meshes without UVs render (UV = 0; textures read one texel).

Modules: :mod:`~pyrt.io.assets.common` (errors, file types, material parameters),
:mod:`~pyrt.io.assets.asset` (:class:`Asset` and adding it to a scene),
:mod:`~pyrt.io.assets.materials` (parameters -> pyrt materials), :mod:`~pyrt.io.assets.alpha` (glTF coverage),
:mod:`~pyrt.io.assets.gltf` (and its container
:mod:`~pyrt.io.assets.gltf_file`, which documents the files a glTF may name; :mod:`~pyrt.io.assets.gltf_khr`, the
``KHR_materials_*`` extensions and what each becomes),
:mod:`~pyrt.io.assets.obj` (with the OBJ + MTL mapping), :mod:`~pyrt.io.assets.ply_stl`.
"""
from __future__ import annotations

import contextlib
import os
import time

from pyrt.geometry.normals import crease_normals
from pyrt.io.assets.common import (DEFAULT_CREASE_ANGLE, FORMATS, AssetError, DefaultParams, MTLParams, PBRParams,
                                   TextureSlot, colour_texels, malformed_is_asset_error, metadata_up_axis)
from pyrt.io.assets.materials import (GltfMaterial, GltfPBRMaterial, ObjMaterial, ProductTexture, ScaledTexture, SurfaceExtras,
                                      VertexColorTexture, FaceColorTexture, make_metallic_roughness,
                                      to_pyrt_material)
from pyrt.io.assets.asset import Asset, AssetCamera, AssetInstance, AssetLight, AssetMesh, light_from_photometric
from pyrt.io.assets.gltf import gltf_node_transforms, gltf_uv_transform, load_gltf, pack_glb, read_gltf
from pyrt.io.assets.obj import load_obj, parse_mtl
from pyrt.io.assets.off import load_off
from pyrt.io.assets.archive import load_zip, split_member
from pyrt.io.assets.find_file import OutsideRootError, active_root, reading_root
from pyrt.io.assets.ply_stl import load_ply_stl, read_ply_tristrips, tristrip_faces

__all__ = [
    "load_asset", "Asset", "AssetMesh", "AssetInstance", "AssetCamera", "AssetLight", "AssetError", "FORMATS",
    "DEFAULT_CREASE_ANGLE", "TextureSlot", "PBRParams", "MTLParams", "DefaultParams", "GltfMaterial", "GltfPBRMaterial",
    "ObjMaterial",
    "SurfaceExtras", "ScaledTexture", "ProductTexture", "VertexColorTexture", "make_metallic_roughness",
    "to_pyrt_material", "light_from_photometric", "crease_normals", "load_gltf", "read_gltf", "pack_glb",
    "gltf_node_transforms", "gltf_uv_transform", "load_obj", "parse_mtl", "load_ply_stl", "FaceColorTexture",
    "read_ply_tristrips", "tristrip_faces", "colour_texels",
]


def load_asset(path, *, max_texture=None, generate_tangents=True, root=None):
    """Load any supported file (by extension: .gltf .glb .obj .ply .stl .off, or a .zip
    archive holding one, ``ARCHIVE.zip!member`` for a given one: :mod:`pyrt.io.assets.archive`) into an :class:`Asset`.

    Parameters
    ----------
    path : str or os.PathLike
        The model file.
    max_texture : int, optional
        glTF images, OBJ colour / normal maps and PLY textures whose longer side exceeds this many texels are reduced
        by a power of two as they are decoded (:mod:`pyrt.io.assets.texture_budget`: the box filter of pyrt's MIP levels, named in
        the warnings). None (default): every image whole.
    generate_tangents : bool
        Sets :attr:`Asset.generate_tangents`: meshes with a normal map (or anisotropy) and no tangents of their own (glTF
        ``TANGENT``) get smooth vertex tangents from their UVs when added to a scene (:mod:`pyrt.geometry.tangents`,
        MikkTSpace's main rules, as glTF asks of viewers; default); False: the normal maps use each triangle's own UV
        tangents (constant per triangle).
    root : str or os.PathLike, optional
        The folder whose files a loose model may read (its buffers, MTL, textures): default (None) the model file's
        own folder and its subfolders; a reference leaving it is an :class:`AssetError` naming it, and nothing
        outside is opened (:mod:`pyrt.io.assets.find_file`). A given ``root`` widens the model's folder: it must be
        an existing folder that contains the model file (else an :class:`AssetError` naming both). A model in a ZIP
        archive reads only the archive, whatever ``root`` says.

    Returns
    -------
    Asset
        With ``load_time`` (seconds) set.

    Raises
    ------
    AssetError
        The file is missing, of an unsupported type, or cannot be loaded (the message says why).
    """
    path = os.fspath(path)
    t0 = time.perf_counter()
    archive, member = split_member(path) or (path, None)     # "ARCHIVE.zip!member": that model of the archive
    if member is None:
        if not os.path.isfile(path):
            raise AssetError(f"asset file not found: {path}")
        ext = os.path.splitext(path)[1].lower()
        fmt = FORMATS.get(ext)
        if fmt is None:
            raise AssetError(f"{path}: unsupported file type {ext!r}; supported: {sorted(FORMATS)}")
    if member is not None or fmt == "zip":   # the model inside, loaded by this function from a temporary folder
        asset = load_zip(archive, lambda inner: load_asset(inner, max_texture=max_texture,
                                                           generate_tangents=generate_tangents), member=member)
        asset.load_time = time.perf_counter() - t0
        return asset
    folder = os.path.dirname(os.path.abspath(path))
    if root is not None:
        folder = _widened_root(path, folder, root)
    within = contextlib.nullcontext() if active_root() is not None else reading_root(folder)   # an archive's stays
    try:
        with within, malformed_is_asset_error(path, fmt.upper() if fmt != "gltf" else "glTF"):
            if fmt == "gltf":
                asset = load_gltf(path, max_texture)
            elif fmt == "obj":
                asset = load_obj(path, max_texture)
            elif fmt == "off":
                asset = load_off(path)
            else:
                asset = load_ply_stl(path, fmt, max_texture)
    except OutsideRootError as exc:      # the file that names it (ARCHIVE.zip!member once load_zip rewrites it)
        raise (exc if str(exc).startswith(path) else OutsideRootError(f"{path}: {exc}")) from None
    asset.stated_up_axis = metadata_up_axis(path, fmt)
    asset.load_time = time.perf_counter() - t0
    asset.generate_tangents = bool(generate_tangents)
    return asset


def _widened_root(path, folder, root):
    """``root`` as the folder a loose model at ``path`` (in ``folder``) may read: an existing folder containing it."""
    root = os.fspath(root)
    if not os.path.isdir(root):
        raise AssetError(f"{path}: root {root!r} is not a folder")
    top, own = os.path.realpath(root), os.path.realpath(folder)
    if own != top and not own.startswith(top.rstrip(os.sep) + os.sep):
        raise AssetError(f"{path}: root {root!r} does not contain the model (a root widens the model's folder)")
    return root
