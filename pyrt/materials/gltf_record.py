"""The compiled kernel's record of the glTF metallic-roughness family (:data:`pyrt.materials.compiled.GLTF`).

One record serves :class:`pyrt.materials.MetallicRoughness` with textured parameters and :class:`pyrt.GltfPBR`
without anisotropy, opaque or with smooth transmission (:func:`gltf_pbr_record`), an opaque one of them under a
:class:`pyrt.Clearcoat` (:func:`clearcoat_record`), each optionally with glTF's emission and occlusion on top
(:class:`pyrt.io.assets.materials.SurfaceExtras`): the base colour, metallic, roughness, emission, occlusion and
GltfPBR's ``specular`` and ``specular_color`` are *slots*, a constant or a factor times a texture of the kernel's
texture table (a channel of it for the scalars), resolved per hit by :func:`pyrt.materials.compiled.gltf_inputs`.
Layout (offsets into the record):

======  ==========================================================================================================
0-3     base colour: texture row or -1, factor (RGB): ``factor x texture`` (the factor alone without a texture)
4-6     metallic: texture row or -1, factor, channel of the texture (glTF: 2, B)
7-9     roughness: texture row or -1, factor, channel (glTF: 1, G)
10-13   emission (as the base colour; emitted radiance, both sides)
14-16   occlusion (as metallic; the constant 1 without one), 17 its strength: ``albedo() = base (1 + s (occ - 1))``
18      the reflection model: :data:`MR` (``MetallicRoughness.f_cos``) or :data:`GLTF_PBR` (``GltfPBR.f_cos``)
19      the geometry term (:data:`pyrt.shaders.jit_brdfs.GEOMETRY_TERMS` index)
20-23   GltfPBR's ``specular_color`` (as the base colour; 1 for MetallicRoughness)
37-40   a smooth transmitting GltfPBR's transmission (:data:`pyrt.materials.compiled.TRANSMISSION`; zeros: opaque)
41      ``f0(ior)`` (0.04 for MetallicRoughness): the dielectric F0 is ``min(f0(ior) specular_color, 1)`` per hit
42-44   GltfPBR's ``specular`` (as metallic; the constant 1 for MetallicRoughness)
45-56   a clear coat (:data:`pyrt.materials.compiled.COAT`; zeros: none)
======  ==========================================================================================================

A base colour that is a product with vertex colours (glTF's ``COLOR_0``) is the slot of its other factor, the
vertex colours named by the record's :data:`pyrt.materials.compiled.VERTEX_COLOR` field.

:func:`gltf_record` returns None (the render takes the NumPy path) for a texture the kernel cannot read as such a
slot: a grey image, a filter other than nearest, bilinear and
trilinear (:meth:`pyrt.textures.Texture.compiled_color`, :meth:`~pyrt.textures.Texture.compiled_scalar`).
"""
from __future__ import annotations

import numpy as np

from pyrt.materials import compiled as _compiled
from pyrt.materials.compiled import pack_color_slot as color_slot
from pyrt.materials.base import is_texture
from pyrt.shaders import fresnel
from pyrt.shaders import jit_brdfs as _JB

#: the reflection models of field 18
MR, GLTF_PBR = 0, 1


def scalar_slot(value, pack_texture):
    """``[row or -1, factor, channel]`` of a constant or a factor times a channel of a table texture; None when the
    kernel cannot read the texture."""
    if not is_texture(value):
        return [-1.0, float(np.asarray(value, dtype=np.float64).reshape(-1)[0]), 0.0]
    form = value.compiled_scalar()
    if form is None:
        return None
    row = pack_texture(form[0])
    return None if row is None else [float(row), float(form[2]), float(form[1])]


def gltf_record(material, pack_texture, *, model, geometry, specular=1.0, specular_color=1.0, f0_ior=0.04,
                emission=0.0, occlusion=None, occlusion_strength=1.0):
    """``(GLTF, record)`` of a material with ``base_color``, ``metallic`` and ``roughness`` (constants or textures),
    the reflection ``model`` (:data:`MR` or :data:`GLTF_PBR`, which reads ``specular`` and the dielectric F0
    ``min(f0_ior specular_color, 1)``, each a constant or a texture), ``geometry`` (a name of
    :data:`pyrt.shaders.jit_brdfs.GEOMETRY_TERMS`), ``emission`` (a constant or a texture) and ``occlusion`` (None
    or a 1-channel texture, with its strength); None when a texture is not readable by the kernel."""
    base, vc = _compiled.vertex_slot(material.base_color, pack_texture, color_slot)
    slots = [base, scalar_slot(material.metallic, pack_texture),
             scalar_slot(material.roughness, pack_texture), color_slot(emission, pack_texture),
             [-1.0, 1.0, 0.0] if occlusion is None else scalar_slot(occlusion, pack_texture)]
    spec = [color_slot(specular_color, pack_texture), scalar_slot(specular, pack_texture)]
    if any(s is None for s in slots + spec):
        return None
    rec = _compiled.empty_record()
    rec[0:17] = [x for s in slots for x in s]
    rec[17] = float(occlusion_strength)
    rec[_compiled.VERTEX_COLOR] = vc
    rec[18] = float(model)
    rec[19] = _JB.GEOMETRY_TERMS.index(geometry)
    rec[20:24] = spec[0]
    S = _compiled.SPECULAR
    rec[S] = float(f0_ior)
    rec[S + 1:S + 4] = spec[1]
    return _compiled.GLTF, rec


def gltf_pbr_record(material, pack_texture, *, emission=0.0, occlusion=None, occlusion_strength=1.0):
    """``(GLTF, record)`` of a :class:`pyrt.GltfPBR` (:data:`GLTF_PBR`, its ``specular`` and ``specular_color``
    constants or textures, ``f0(ior)``) that is isotropic, opaque or of :attr:`~pyrt.GltfPBR.smooth_transmission`
    with constant ``metallic``, ``transmission``, ``specular`` and ``specular_color`` (the base colour, which tints the
    transmission, may be a texture or vertex colours: read per hit): then
    ``[(1 - metallic) transmission, transmission, thin, ior]`` at :data:`pyrt.materials.compiled.TRANSMISSION`;
    None otherwise (rough or textured transmission, anisotropy) or when a texture is not readable by the kernel."""
    m = material
    if m.anisotropic:
        return None
    if m.transmits and (not m.smooth_transmission or any(is_texture(v) for v in (
            m.metallic, m.transmission, m.specular, m.specular_color))):
        return None
    out = gltf_record(m, pack_texture, model=GLTF_PBR, geometry=m.geometry, specular=m.specular,
                      specular_color=m.specular_color, f0_ior=float(fresnel.f0_from_ior(m.ior_value)),
                      emission=emission, occlusion=occlusion, occlusion_strength=occlusion_strength)
    if out is not None and m.transmits:
        t = float(m.transmission)
        out[1][_compiled.TRANSMISSION:_compiled.TRANSMISSION + 4] = [(1.0 - float(m.metallic)) * t, t,
                                                                     1.0 if m.thin else 0.0, float(m.ior_value)]
    return out


def unlit_record(material, pack_texture):
    """``(UNLIT, record)`` of a :class:`pyrt.Unlit`: its colour as colour slot 0 (a constant, a factor times an RGB
    image texture, either times vertex colours: :func:`pyrt.materials.compiled.vertex_slot`); None when the kernel
    cannot read its texture."""
    slot, vc = _compiled.vertex_slot(material.color, pack_texture, color_slot)
    if slot is None:
        return None
    rec = _compiled.empty_record()
    rec[0:4] = slot
    rec[_compiled.VERTEX_COLOR] = vc
    return _compiled.UNLIT, rec


def clearcoat_record(coat, pack_texture):
    """``(GLTF, record)`` of a :class:`pyrt.Clearcoat` with ``fresnel="view"`` over an opaque base that packs as a GLTF
    record (its ``compiled_record``, or a constant metallic-roughness model's ``compiled_record_extras`` without
    extras: the same model as a GLTF record): the base's record with the coat at
    :data:`pyrt.materials.compiled.COAT` (1, the clear coat's and the coat roughness's scalar slots, the coat's normal
    map fields, its F0). None otherwise (``fresnel="half"``, a transmitting base, a base the kernel cannot read or
    one that is no GLTF record, a coat texture or normal map the kernel cannot read)."""
    base = coat.base
    if coat.fresnel != "view" or base.transmits:
        return None
    out = base.compiled_record(pack_texture)
    if out is not None and out[0] == _compiled.METALLIC_ROUGHNESS:
        out = base.compiled_record_extras(pack_texture)
    if out is None or out[0] != _compiled.GLTF:
        return None
    slots = [scalar_slot(coat.clearcoat, pack_texture), scalar_slot(coat.roughness, pack_texture)]
    nm = [0.0, 0.0, 0.0, 0.0]
    if coat.coat_normal_map is not None:
        row = pack_texture(coat.coat_normal_map)
        nm = None if row is None else _compiled.normal_map_fields(coat.coat_normal_map, row)
    if nm is None or any(s is None for s in slots):
        return None
    rec = np.array(out[1], dtype=np.float64)
    rec[_compiled.COAT:_compiled.COAT + 12] = [1.0, *slots[0], *slots[1], *nm, coat._f0()]
    return _compiled.GLTF, rec
