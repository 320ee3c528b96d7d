"""The material family's compiled form: type tags, parameter records and the per-hit switch over them.

A material that the compiled tile kernel (:mod:`pyrt.integrators.compiled`) can shade packs itself into one row
of the material table (:meth:`pyrt.materials.Material.compiled_record`): a type tag (:data:`LAMBERT`, ...) and a
float64 parameter record of :data:`RECORD` entries. Colours that may come from a texture are a *colour slot*:
``[texture index or -1, r, g, b]`` (the constant used when the index is -1; textures are rows of the texture
table, :mod:`pyrt.textures.compiled`). A material that returns None from ``compiled_record`` renders through the
NumPy path (the whole render falls back; ``result.stats.backend`` says which path ran).

Record layouts (offsets into the record):

===================  ============================================================================================
LAMBERT              0-3 albedo slot, 4-6 emission (constant RGB)
BLINN_PHONG          0-3 kd slot, 4-6 ks (constant RGB), 7 exponent
MIRROR               0-2 reflectance (constant RGB)
GLASS                0 ior, 1-3 tint (constant RGB)
CONDUCTOR            0-3 albedo slot (zero), 4-6 eta, 7-9 k (exact conductor Fresnel of the mirror lobe)
PHONG, PHONG_CLASSIC,
BLINN_PHONG_CLASSIC  0-3 albedo slot (constant: ``albedo()``, what the ambient term uses), 4-6 kd, 7-9 ks,
                     10 exponent
OREN_NAYAR           0-3 albedo slot, 4-6 albedo, 7 sigma (radians)
WARD                 0-3 albedo slot, 4-6 kd, 7-9 ks, 10 alpha (isotropic), 11 variant
COOK_TORRANCE        0-3 albedo slot, 4-6 kd, 7-9 ks, 10 alpha, 11 distribution, 12 geometry, 13 Fresnel model,
                     14-16 f0 / ior / eta, 17-19 k (:func:`pyrt.shaders.jit_brdfs.cook_torrance_f_cos`)
METALLIC_ROUGHNESS   0-3 albedo slot, 4-6 base colour, 7 metallic, 8 roughness, 9 geometry (also LearnOpenGLPBR)
EMITTER              4-6 radiance (constant RGB), 7 two-sided (1) or front only (0): an area light's visible mesh
                     (:class:`pyrt.lights.area.AreaEmitter`: emits, reflects nothing)
UNLIT                0-3 colour slot: :class:`pyrt.Unlit`'s colour, emitted from both sides, its albedo; reflects
                     nothing (:func:`pyrt.materials.gltf_record.unlit_record`)
GLTF                 glTF's metallic-roughness family with textured parameters, emission and occlusion: the layout
                     of :mod:`pyrt.materials.gltf_record` (0-23, 41-44), resolved per hit by :func:`gltf_inputs`
(every material)     24-27 its normal map (:data:`NORMAL_MAP`), 28 1 when it culls back faces (:data:`CULL`), 29-33
                     its alpha mask or blend (:data:`MASK`), 34 its glossy alpha (:data:`GLOSSY`), 35 the area light it is the
                     visible emitter of (:data:`TRACED`), written by the compiled scene; 36 the vertex colours its
                     colour slot 0 (GLTF: the base colour) multiplies by (:data:`VERTEX_COLOR`, :func:`vertex_slot`)
GLTF (transmission)  37-40 (:data:`TRANSMISSION`) a smooth transmitting ``GltfPBR``'s constant ``w = (1 - metallic)
                     transmission``, its ``transmission``, 1 for a thin wall (0: a volume) and its ``ior``; zeros
                     for the opaque ones
GLTF (specular)      41 ``f0(ior)``, 42-44 the scalar slot of ``GltfPBR.specular`` (:data:`SPECULAR`; 20-23 the colour
                     slot of its ``specular_color``)
GLTF (clear coat)    45-56 (:data:`COAT`) a :class:`pyrt.Clearcoat` over an opaque GLTF base: 45 1 (0: no coat), 46-48
                     the clear coat's scalar slot ``[row or -1, factor, channel]``, 49-51 the coat roughness's, 52-55
                     the coat's normal map (as :data:`NORMAL_MAP`; row 0: none), 56 the coat's F0
                     (:func:`pyrt.materials.gltf_record.clearcoat_record`)
(every material)     57-62 (:data:`MEDIUM`) its medium: 1 when it takes part in nested media, its priority rank, its
                     ``ior``, its absorption (RGB), written by the compiled scene (:mod:`pyrt.integrators.compiled_media`)
===================  ============================================================================================

The models after BLINN_PHONG but GLTF have constant parameters only (a textured one is not compiled); their formulas
are the scalar twins in :mod:`pyrt.shaders.jit_brdfs`, held to the NumPy materials' ``f_cos`` by
tests/test_jit_brdfs.py (GLTF's: tests/test_compiled_gltf.py).

A colour slot 0 may be multiplied by the hit's vertex colours (a :class:`pyrt.io.assets.ProductTexture` of
:class:`pyrt.io.assets.VertexColorTexture` and a constant or texture, as the glTF loader builds glTF's ``COLOR_0``):
the record's :data:`VERTEX_COLOR` field is then the vertex-colour texture's row in the texture table plus one (a row
of tag :data:`pyrt.textures.compiled.VERTEX`, never looked up by uv: the colours are packed with the geometry and
interpolated at the hit, :func:`pyrt.integrators.compiled_diffs.vertex_color`), and the slot holds the other factor.

A hit's *inputs* (:func:`albedo_at`) are an 18-tuple: its ``albedo()`` (what the ambient term and the albedo AOV
read; Lambert's albedo, Blinn-Phong's kd), then GLTF's per-hit base colour, metallic, roughness, occlusion factor
``1 + strength (occ - 1)`` (what the environment preview multiplies), specular weight and dielectric F0 (RGB) (zeros
for the other tags), then a coated GLTF's clear coat ``c``, the coat's ``alpha = roughness^2`` and the coat's normal
in the local shading frame (``(0, 0, 1)`` where it is the shading normal; :func:`with_coat_normal`). The BSDF
functions take them as ``albedo``; a coated GLTF's BSDF is :mod:`pyrt.materials.compiled_sampling`'s
(``f_cos_world``, ``f_cos_local``), not :func:`f_cos`.

The kernel reads the record table through its flat data (:func:`pyrt.core.unmanaged.pointer`: material ``m``'s
record at ``pars[m * RECORD:]``; a pointer binds no array, so the per-sample code pays no reference counting).
The formulas are the scalar twins in :mod:`pyrt.shaders.jit` of the NumPy kernels the materials use.
"""
from __future__ import annotations

import math

import numpy as np
from numba.extending import register_jitable

from pyrt.shaders import jit as J
from pyrt.shaders import jit_brdfs as JB
from pyrt.textures.base import Texture, is_texture
from pyrt.textures.compiled import texture_rgb
from pyrt.textures.normal_map import NormalMap

#: parameters per material record
RECORD = 63
#: where every record keeps its normal map (:func:`pyrt.integrators.compiled_diffs.mapped_normal`): the map's row in the
#: texture table plus one (0: none), its strength, 1 for green = -v (DirectX), 1 to bend reflections above the surface
NORMAL_MAP = 24
#: where every record says whether camera and secondary rays skip its back faces (1.0:
#: :attr:`pyrt.materials.Material.culls_back_faces`; :mod:`pyrt.integrators.compiled_coverage`)
CULL = 28
#: where every record keeps its alpha mask or blend (:mod:`pyrt.integrators.compiled_coverage`): 1 when
#: ``alpha_mode`` is ``"mask"``, 2 when ``"blend"`` (0: opaque), ``alpha_cutoff``, then the opacity's scalar slot
#: ``[row or -1, factor, channel]``
MASK = 29
#: where every record keeps its non-delta lobe's glossy alpha for the glossy integrator
#: (:meth:`pyrt.materials.Material.glossy_alpha`; :func:`glossy_alpha`): the constant, ``inf`` for a diffuse-like lobe,
#: -1 where it is per hit (GLTF: its roughness squared)
GLOSSY = 34
#: where every record keeps the area light whose visible emitter mesh it is (:attr:`pyrt.lights.AreaLight.has_mesh`):
#: the light's row plus one (0: none); glossy rays that reach it weigh its emission by MIS
TRACED = 35
#: where every record says which vertex colours its colour slot 0 multiplies by: their texture's row plus one (0:
#: none; module notes)
VERTEX_COLOR = 36
#: where a GLTF record keeps its smooth transmission (:func:`dielectric_lobes`, :func:`shadow_transmission`): ``w``,
#: ``transmission``, thin (1) or volume (0), ``ior``; ``w`` > 0 makes it a dielectric with delta lobes
TRANSMISSION = 37
#: where a GLTF record keeps ``f0(ior)`` and then the scalar slot ``[row or -1, factor, channel]`` of its specular
#: weight (:func:`gltf_inputs`: the dielectric F0 is ``min(f0(ior) specular_color, 1)``, the colour slot at 20-23)
SPECULAR = 41
#: where a GLTF record keeps its clear coat (module notes; :func:`pyrt.materials.gltf_record.clearcoat_record`): 1 when
#: coated, the clear coat's and the coat roughness's scalar slots, the coat's normal map fields, the coat's F0
COAT = 45
#: where every record keeps its medium (:mod:`pyrt.integrators.compiled_media`): 1 when it takes part in the
#: interface stacks of nested dielectrics, its priority's rank, its ``ior``, then its absorption coefficient (RGB; a
#: dielectric's, zeros otherwise)
MEDIUM = 57
#: the vertex colour of a hit whose material reads none (a multiplication by it is exact)
WHITE = (1.0, 1.0, 1.0)
#: type tags (0 is no material)
LAMBERT, BLINN_PHONG, MIRROR, GLASS, CONDUCTOR = 1, 2, 3, 4, 5
#: 1 / pi (a multiplication where a division by pi would cost ~4x; within an ulp of it)
INV_PI = 1.0 / math.pi
PHONG, PHONG_CLASSIC, BLINN_PHONG_CLASSIC, OREN_NAYAR, WARD, COOK_TORRANCE, METALLIC_ROUGHNESS = 6, 7, 8, 9, 10, 11, 12
EMITTER = 13
#: glTF's metallic-roughness family with per-hit parameters (:mod:`pyrt.materials.gltf_record`)
GLTF = 14
#: a surface that shows its colour (:class:`pyrt.Unlit`, glTF ``KHR_materials_unlit``)
UNLIT = 15


@register_jitable(forceinline=True)
def color_slot(pars, m, k, tex_tag, tex_par, u, v, fp):
    """The colour (an RGB tuple) of the slot at ``k`` of material ``m``'s record at uv ``(u, v)`` with the
    footprint record ``fp`` (:mod:`pyrt.textures.compiled`): a constant, or a texture row times its factor
    (:func:`pyrt.textures.compiled.texture_rgb`, :func:`pack_color_slot`)."""
    return scaled_slot(pars, m * RECORD + k, tex_tag, tex_par, u, v, fp)


@register_jitable(forceinline=True)
def has_diffuse(tag):
    """True for materials lit by the lights (a non-delta lobe)."""
    return tag == LAMBERT or tag == BLINN_PHONG or PHONG <= tag <= METALLIC_ROUGHNESS or tag == GLTF


@register_jitable(forceinline=True)
def has_delta(tag, pars, m):
    """True for the material ``m`` (tag ``tag``) when it spawns specular rays: MIRROR, CONDUCTOR and the dielectrics
    (:func:`is_dielectric`)."""
    return tag == MIRROR or tag == CONDUCTOR or is_dielectric(tag, pars, m)


@register_jitable(forceinline=True)
def is_dielectric(tag, pars, m):
    """True for the material ``m`` (tag ``tag``) when transparent shadows cross it (:attr:`pyrt.materials.Material.
    is_dielectric`) and it has the two delta lobes of :func:`dielectric_lobes`: GLASS, and GLTF with ``w > 0``
    (:data:`TRANSMISSION`)."""
    return tag == GLASS or (tag == GLTF and pars[m * RECORD + TRANSMISSION] > 0.0)


@register_jitable(forceinline=True)
def shadow_transmission(tag, pars, m, cos, base):
    """The factor (an RGB tuple) by which a shadow ray's light is multiplied where it crosses the dielectric ``m``
    at ``cos = |wi . ns|`` (:func:`pyrt.integrators.shadows.transmittance`): ``tint (1 - R)``, ``R`` the Fresnel
    reflectance for ``eta = ior``; GLASS's tint, GLTF's ``base_color w`` (:attr:`pyrt.GltfPBR.tint`, thin or
    not; ``base`` the base colour at the hit)."""
    b = m * RECORD
    if tag == GLTF:
        k = (1.0 - J.fr_dielectric(cos, pars[b + TRANSMISSION + 3])) * pars[b + TRANSMISSION]
        return base[0] * k, base[1] * k, base[2] * k
    k = 1.0 - J.fr_dielectric(cos, pars[b])
    return pars[b + 1] * k, pars[b + 2] * k, pars[b + 3] * k


@register_jitable(forceinline=True)
def dielectric_lobes(tag, pars, m, cos_o, front, eta_in, base):
    """The two delta lobes of the dielectric ``m`` (:func:`is_dielectric`) at ``cos_o = n.wo`` > 0 seen from its front
    (``front``) or back: ``(eta, reflection weight, refraction weight)``, the weights RGB tuples, ``eta`` the relative
    index the refraction bends by (1: straight through; ``eta_in`` > 0: that index, from the ray's interface stack,
    :mod:`pyrt.integrators.compiled_media`). The refraction weight is 0 under total internal reflection. ``base``: a
    GLTF hit's base colour (:func:`gltf_inputs`).

    - GLASS (:meth:`pyrt.Glass.delta_lobes`): ``eta = ior`` (``1 / ior`` from the back), ``tint R`` and ``tint (1 -
      R) / eta^2``, ``R`` the exact Fresnel reflectance (1 under total internal reflection);
    - GLTF (:meth:`pyrt.GltfPBR.delta_lobes`, constant ``w``, record fields :data:`TRANSMISSION`): a
      volume as GLASS but the reflection untinted, ``w R`` and ``base w (1 - R) / eta^2``; a thin wall ``eta = 1``,
      ``w F`` and ``base w (1 - max F)``, ``F = specular x`` Schlick of the dielectric F0 at ``cos_o`` (the
      constants of :func:`gltf_specular`: a transmitting record's specular slots hold no texture)."""
    b = m * RECORD
    if tag == GLTF and pars[b + TRANSMISSION + 2] != 0.0:
        w, s, f = pars[b + TRANSMISSION], pars[b + SPECULAR + 2], pars[b + SPECULAR]
        f0, f1, f2 = (s * JB.fr_schlick(cos_o, min(f * pars[b + 21], 1.0)),
                      s * JB.fr_schlick(cos_o, min(f * pars[b + 22], 1.0)),
                      s * JB.fr_schlick(cos_o, min(f * pars[b + 23], 1.0)))
        t = w * (1.0 - max(f0, f1, f2))
        return 1.0, (w * f0, w * f1, w * f2), (base[0] * t, base[1] * t, base[2] * t)
    ior = pars[b + TRANSMISSION + 3] if tag == GLTF else pars[b]
    eta = eta_in if eta_in > 0.0 else (ior if front else 1.0 / ior)
    R = J.fr_dielectric(cos_o, eta)
    if max(0.0, 1.0 - cos_o * cos_o) / (eta * eta) >= 1.0:
        R = 1.0
    if tag == GLTF:
        w = pars[b + TRANSMISSION]
        t = w * (1.0 - R) / (eta * eta)
        return eta, (w * R, w * R, w * R), (base[0] * t, base[1] * t, base[2] * t)
    t = (1.0 - R) / (eta * eta)
    return eta, (pars[b + 1] * R, pars[b + 2] * R, pars[b + 3] * R), (pars[b + 1] * t, pars[b + 2] * t,
                                                                     pars[b + 3] * t)


@register_jitable(forceinline=True)
def mirror_weight(tag, pars, m, cos_o):
    """The RGB weight of the one reflection lobe of a mirror-like material ``m`` (not GLASS, whose two lobes the
    kernel's ``spawn`` computes) at ``cos_o = n.wo``: MIRROR's constant reflectance, CONDUCTOR's exact Fresnel
    reflectance (:func:`pyrt.materials.Conductor.reflectance`)."""
    b = m * RECORD
    if tag == CONDUCTOR:
        return JB.conductor_delta_weight(cos_o, pars[b + 4], pars[b + 5], pars[b + 6], pars[b + 7], pars[b + 8],
                                         pars[b + 9])
    return pars[b], pars[b + 1], pars[b + 2]


@register_jitable(forceinline=True)
def is_coated(tag, pars, m):
    """True for a GLTF material ``m`` under a clear coat (:data:`COAT`)."""
    return tag == GLTF and pars[m * RECORD + COAT] != 0.0


@register_jitable(forceinline=True)
def f_cos(tag, pars, m, albedo, cos_o, cos_i, cos_io):
    """BRDF times cos(theta_i) (an RGB tuple) of material ``m`` (tag ``tag``) for the cosines
    ``n.wo``, ``n.wi``, ``wo.wi`` (shading normal); ``albedo`` (RGB tuple) is the material's diffuse colour at the
    hit (:func:`albedo_at`). Zero below either horizon. Not for a coated GLTF (:func:`is_coated`), whose coat needs
    the directions: :func:`pyrt.materials.compiled_sampling.f_cos_world`.

    LAMBERT: :func:`pyrt.shaders.brdfs.lambert_f_cos_cosines`; BLINN_PHONG:
    :func:`pyrt.shaders.brdfs.blinn_phong_normalized_f_cos_cosines`."""
    c = J.upper_cos(cos_o, cos_i)
    if c == 0.0:
        return 0.0, 0.0, 0.0
    if tag == GLTF:
        cos_h, cos_oh = JB.half_cosines(cos_o, cos_i, cos_io)
        return gltf_f_cos_h(pars, m * RECORD, albedo, cos_o, cos_i, cos_h, cos_oh)
    if tag > BLINN_PHONG:
        return _f_cos_library(tag, pars, m * RECORD, cos_o, cos_i, cos_io)
    if tag == LAMBERT:
        k = c * INV_PI
        return albedo[0] * k, albedo[1] * k, albedo[2] * k
    b = m * RECORD
    spec = J.blinn_phong_spec(cos_o, cos_i, cos_io, pars[b + 7])
    return ((albedo[0] / math.pi + pars[b + 4] * spec) * c, (albedo[1] / math.pi + pars[b + 5] * spec) * c,
            (albedo[2] / math.pi + pars[b + 6] * spec) * c)


@register_jitable
def _f_cos_library(tag, p, b, cos_o, cos_i, cos_io):
    """f_cos of the models with constant parameters (not inlined: their microfacet terms are long; float arguments
    only, so the call costs no reference counting) for the record at ``p[b:]``."""
    if tag == PHONG:
        return JB.phong_f_cos(cos_o, cos_i, cos_io, p[b + 4], p[b + 5], p[b + 6], p[b + 7], p[b + 8], p[b + 9],
                              p[b + 10])
    if tag == PHONG_CLASSIC:
        return JB.phong_classic_f_cos(cos_o, cos_i, cos_io, p[b + 4], p[b + 5], p[b + 6], p[b + 7], p[b + 8],
                                      p[b + 9], p[b + 10])
    if tag == BLINN_PHONG_CLASSIC:
        return JB.blinn_phong_classic_f_cos(cos_o, cos_i, cos_io, p[b + 4], p[b + 5], p[b + 6], p[b + 7], p[b + 8],
                                            p[b + 9], p[b + 10])
    if tag == OREN_NAYAR:
        return JB.oren_nayar_f_cos(cos_o, cos_i, cos_io, p[b + 4], p[b + 5], p[b + 6], p[b + 7])
    if tag == WARD:
        return JB.ward_f_cos(cos_o, cos_i, cos_io, p[b + 4], p[b + 5], p[b + 6], p[b + 7], p[b + 8], p[b + 9],
                             p[b + 10], int(p[b + 11]))
    if tag == COOK_TORRANCE:
        return JB.cook_torrance_f_cos(cos_o, cos_i, cos_io, p[b + 4], p[b + 5], p[b + 6], p[b + 7], p[b + 8],
                                      p[b + 9], p[b + 10], int(p[b + 11]), int(p[b + 12]), int(p[b + 13]),
                                      p[b + 14], p[b + 15], p[b + 16], p[b + 17], p[b + 18], p[b + 19])
    if tag == METALLIC_ROUGHNESS:
        return JB.metallic_roughness_f_cos(cos_o, cos_i, cos_io, p[b + 4], p[b + 5], p[b + 6], p[b + 7], p[b + 8],
                                           int(p[b + 9]))
    return 0.0, 0.0, 0.0


@register_jitable(forceinline=True)
def emission(tag, pars, m, front):
    """The radiance (an RGB tuple) material ``m`` emits toward the viewer: LAMBERT's and BLINN_PHONG's constant
    emission (both sides), EMITTER's radiance from its front (or both sides when two-sided), UNLIT's constant colour
    (both sides; a textured one: :func:`emission_at`); zeros for the others."""
    b = m * RECORD
    if tag == UNLIT:
        return pars[b + 1], pars[b + 2], pars[b + 3]
    if tag == LAMBERT or (tag == EMITTER and (front or pars[b + 7] != 0.0)):
        return pars[b + 4], pars[b + 5], pars[b + 6]
    if tag == BLINN_PHONG:
        return pars[b + 8], pars[b + 9], pars[b + 10]
    return 0.0, 0.0, 0.0


@register_jitable(forceinline=True)
def albedo_constant(tag, pars, m):
    """True where :func:`albedo_at` of material ``m`` does not depend on the uv (no texture in its colour slot) and
    the material has no normal map (:data:`NORMAL_MAP`): its shading inputs are the surface's alone."""
    return (not (tag == LAMBERT or tag == BLINN_PHONG or CONDUCTOR <= tag <= METALLIC_ROUGHNESS or tag == GLTF
                 or tag == UNLIT)
            or (pars[m * RECORD] < 0.0 and tag != GLTF)) and pars[m * RECORD + NORMAL_MAP] == 0.0 \
        and pars[m * RECORD + VERTEX_COLOR] == 0.0


@register_jitable(forceinline=True)
def albedo_at(tag, pars, m, tex_tag, tex_par, u, v, fp, vc):
    """The hit's inputs (module notes: an 18-tuple) of material ``m`` at uv ``(u, v)`` (set 0) with the footprint
    record ``fp`` (:mod:`pyrt.textures.compiled`: the hit's UV footprint, zeros for none, and what a texture of another
    UV set reads) and the vertex colour ``vc`` (an RGB tuple, :data:`WHITE` where the material reads none): the
    diffuse colour (Lambert albedo, Blinn-Phong kd, the library models' constant ``albedo()``, GLTF's
    :func:`gltf_inputs`; UNLIT's colour; zeros for the others), then GLTF's base colour, metallic, roughness,
    occlusion, specular weight, dielectric F0 and clear coat. Colour slot 0 times ``vc``, as ``ProductTexture``
    multiplies."""
    if tag == GLTF:
        return gltf_inputs(pars, m * RECORD, tex_tag, tex_par, u, v, fp, vc)
    if tag == LAMBERT or tag == BLINN_PHONG or CONDUCTOR <= tag <= METALLIC_ROUGHNESS or tag == UNLIT:
        a = color_slot(pars, m, 0, tex_tag, tex_par, u, v, fp)
        return (vc[0] * a[0], vc[1] * a[1], vc[2] * a[2], 0.0, 0.0, 0.0, 0.0, 0.0, 0.0, 0.0, 0.0, 0.0, 0.0,
                0.0, 0.0, 0.0, 0.0, 1.0)
    return 0.0, 0.0, 0.0, 0.0, 0.0, 0.0, 0.0, 0.0, 0.0, 0.0, 0.0, 0.0, 0.0, 0.0, 0.0, 0.0, 0.0, 1.0


@register_jitable(forceinline=True)
def emission_at(tag, pars, m, front, tex_tag, tex_par, u, v, fp):
    """:func:`emission`, GLTF's emission slot at uv ``(u, v)`` (both sides, as ``SurfaceExtras.emission``) and UNLIT's
    colour slot (without its vertex colours: the caller multiplies by them)."""
    if tag == GLTF:
        return scaled_slot(pars, m * RECORD + 10, tex_tag, tex_par, u, v, fp)
    if tag == UNLIT:
        return scaled_slot(pars, m * RECORD, tex_tag, tex_par, u, v, fp)
    return emission(tag, pars, m, front)


@register_jitable
def scaled_slot(pars, b, tex_tag, tex_par, u, v, fp):
    """The colour slot ``[row or -1, r, g, b]`` at ``pars[b:]`` as :mod:`pyrt.materials.gltf_record` reads it: the
    factor times the texture (``ScaledTexture``), the factor alone without one."""
    t = int(pars[b])
    if t < 0:
        return pars[b + 1], pars[b + 2], pars[b + 3]
    r, g, bb = texture_rgb(tex_tag, tex_par, t, u, v, fp)
    return r * pars[b + 1], g * pars[b + 2], bb * pars[b + 3]


@register_jitable(forceinline=True)
def slot_scalar(pars, b, rgb):
    """The scalar slot ``[row or -1, factor, channel]`` at ``pars[b:]``, the texture's lookup ``rgb`` given."""
    if pars[b] < 0.0:
        return pars[b + 1]
    return rgb[int(pars[b + 2])] * pars[b + 1]


@register_jitable
def gltf_inputs(pars, b, tex_tag, tex_par, u, v, fp, vc):
    """The inputs (an 18-tuple) of the GLTF record at ``pars[b:]`` with the vertex colour ``vc``: ``albedo() = base
    k (1 - w)``, ``k = 1 + s (occ - 1)`` (with an occlusion texture; else 1), ``w`` the transmissive share
    (:data:`TRANSMISSION`, 0 when opaque: :meth:`pyrt.GltfPBR.albedo`), the base colour (its slot times ``vc``),
    metallic, roughness, ``k``, the specular weight and the dielectric F0 ``min(f0(ior) specular_color, 1)``
    (:data:`SPECULAR`, ``GltfPBR._f0_dielectric``), then the clear coat ``c`` and the coat's alpha (:data:`COAT`;
    zeros without a coat) and the coat's normal ``(0, 0, 1)`` (the shading normal; a normal map's hit replaces it:
    :func:`with_coat_normal`); one lookup per texture row (metallic and roughness from one packed map read it
    once)."""
    br, bg, bb = scaled_slot(pars, b, tex_tag, tex_par, u, v, fp)
    br, bg, bb = vc[0] * br, vc[1] * bg, vc[2] * bb
    none = (0.0, 0.0, 0.0)
    t_m, t_r, t_o = int(pars[b + 4]), int(pars[b + 7]), int(pars[b + 14])
    rgb_m = texture_rgb(tex_tag, tex_par, t_m, u, v, fp) if t_m >= 0 else none
    rgb_r = rgb_m if t_r == t_m else (texture_rgb(tex_tag, tex_par, t_r, u, v, fp) if t_r >= 0 else none)
    metal, rough = slot_scalar(pars, b + 4, rgb_m), slot_scalar(pars, b + 7, rgb_r)
    s, f0r, f0g, f0b = gltf_specular(pars, b, tex_tag, tex_par, u, v, fp)
    o = 1.0 - pars[b + TRANSMISSION]
    c, alpha_c = coat_inputs(pars, b, tex_tag, tex_par, u, v, fp)
    if t_o < 0:
        return (br * o, bg * o, bb * o, br, bg, bb, metal, rough, 1.0, s, f0r, f0g, f0b, c, alpha_c, 0.0, 0.0,
                1.0)
    rgb_o = rgb_m if t_o == t_m else (rgb_r if t_o == t_r else texture_rgb(tex_tag, tex_par, t_o, u, v, fp))
    k = 1.0 + pars[b + 17] * (slot_scalar(pars, b + 14, rgb_o) - 1.0)
    return (br * k * o, bg * k * o, bb * k * o, br, bg, bb, metal, rough, k, s, f0r, f0g, f0b, c, alpha_c, 0.0, 0.0,
            1.0)


@register_jitable(forceinline=True)
def gltf_specular(pars, b, tex_tag, tex_par, u, v, fp):
    """``(specular, F0 r, g, b)`` of the GLTF record at ``pars[b:]`` at uv ``(u, v)``: the specular weight's scalar
    slot and the dielectric F0 ``min(f0(ior) specular_color, 1)`` (:data:`SPECULAR`, the colour slot at 20-23)."""
    t_s = int(pars[b + SPECULAR + 1])
    rgb_s = texture_rgb(tex_tag, tex_par, t_s, u, v, fp) if t_s >= 0 else (0.0, 0.0, 0.0)
    s = slot_scalar(pars, b + SPECULAR + 1, rgb_s)
    cr, cg, cb = scaled_slot(pars, b + 20, tex_tag, tex_par, u, v, fp)
    f = pars[b + SPECULAR]
    return s, min(f * cr, 1.0), min(f * cg, 1.0), min(f * cb, 1.0)


@register_jitable(forceinline=True)
def coat_inputs(pars, b, tex_tag, tex_par, u, v, fp):
    """``(c, alpha)`` of the clear coat of the GLTF record at ``pars[b:]`` (:data:`COAT`): the clear coat and the
    square of the coat's roughness (:meth:`pyrt.Clearcoat._alpha`), one lookup per texture row; zeros without a
    coat."""
    if pars[b + COAT] == 0.0:
        return 0.0, 0.0
    none = (0.0, 0.0, 0.0)
    t_c, t_r = int(pars[b + COAT + 1]), int(pars[b + COAT + 4])
    rgb_c = texture_rgb(tex_tag, tex_par, t_c, u, v, fp) if t_c >= 0 else none
    rgb_r = rgb_c if t_r == t_c else (texture_rgb(tex_tag, tex_par, t_r, u, v, fp) if t_r >= 0 else none)
    r = slot_scalar(pars, b + COAT + 4, rgb_r)
    return slot_scalar(pars, b + COAT + 1, rgb_c), r * r


@register_jitable(forceinline=True)
def with_coat_normal(a, n):
    """The hit inputs ``a`` (:func:`albedo_at`) with the coat's normal ``n`` (unit, in the local shading frame)."""
    return (a[0], a[1], a[2], a[3], a[4], a[5], a[6], a[7], a[8], a[9], a[10], a[11], a[12], a[13], a[14], n[0], n[1],
            n[2])


@register_jitable
def gltf_f_cos_h(pars, b, albedo, cos_o, cos_i, cos_h, cos_oh):
    """f_cos of the GLTF record at ``pars[b:]`` with the hit's inputs ``albedo`` (:func:`gltf_inputs`: the
    specular weight and dielectric F0 among them), from ``n.h``
    and ``wo.h``: :func:`pyrt.shaders.jit_brdfs.metallic_roughness_f_cos_h` (``MetallicRoughness.f_cos``) or
    :func:`pyrt.shaders.jit_brdfs.gltf_pbr_f_cos_h` (``GltfPBR.f_cos``) by the record's model."""
    if pars[b + 18] == 0.0:
        return JB.metallic_roughness_f_cos_h(cos_o, cos_i, cos_h, cos_oh, albedo[3], albedo[4], albedo[5], albedo[6],
                                             albedo[7], int(pars[b + 19]))
    t = pars[b + TRANSMISSION + 1]
    return JB.gltf_pbr_f_cos_h(cos_o, cos_i, cos_h, cos_oh, albedo[3], albedo[4], albedo[5], albedo[6], albedo[7],
                               albedo[10], albedo[11], albedo[12], albedo[9], t, 1.0 - t, int(pars[b + 19]))


def normal_map_fields(normal_map, row):
    """A record's normal-map fields (:data:`NORMAL_MAP`, a clear coat's at :data:`COAT` ``+ 7``) for ``normal_map``,
    the texture table's row ``row``: ``row + 1``, strength, flip green, bend (a texture other than
    :class:`pyrt.NormalMap`: the class defaults, as :func:`pyrt.textures.normal_map.perturb_normal`)."""
    nm = normal_map if isinstance(normal_map, NormalMap) else NormalMap
    return [row + 1.0, nm.strength, 1.0 if nm.flip_green else 0.0, 1.0 if nm.reflection == "bend" else 0.0]


def vertex_slot(value, pack_texture, slot):
    """``(colour slot, VERTEX_COLOR field)`` of a colour-slot-0 value: a product with vertex colours
    (:meth:`pyrt.textures.Texture.compiled_vertex_product`) as the slot of its other factor and its vertex colours'
    row plus one (module notes), anything else as ``slot(value, pack_texture)`` and 0; the slot None where the kernel
    cannot read a texture of it."""
    form = value.compiled_vertex_product() if isinstance(value, Texture) else None
    if form is None:
        return slot(value, pack_texture), 0.0
    row, s = pack_texture(form[0]), slot(form[1], pack_texture)
    return (None, 0.0) if row is None or s is None else (s, row + 1.0)


def pack_color_slot(value, pack_texture):
    """``[row or -1, r, g, b]`` of a constant colour, a factor times a table texture
    (:meth:`pyrt.textures.Texture.compiled_color`) or any other texture the table reads (factor one: a grey checker's
    grey twins); None when the kernel cannot read the texture."""
    if not is_texture(value):
        return constant_slot(value)
    form = value.compiled_color() or (value, (1.0, 1.0, 1.0))
    row = pack_texture(form[0])
    return None if row is None else [float(row), *(float(x) for x in form[1])]


def constant_slot(value):
    """A colour slot ``[-1, r, g, b]`` for a constant colour (a grey number or an RGB triple)."""
    rgb = np.broadcast_to(np.asarray(value, dtype=np.float64).reshape(-1), (3,))
    return [-1.0, *rgb.tolist()]


def empty_record():
    """A zero parameter record."""
    return np.zeros(RECORD)


@register_jitable(forceinline=True)
def glossy_alpha(pars, m, inputs):
    """Material ``m``'s glossy alpha at a hit of inputs ``inputs`` (:func:`albedo_at`): :data:`GLOSSY`'s constant,
    or GLTF's per-hit roughness squared (:func:`pyrt.shaders.microfacet.roughness_to_alpha`), under a clear coat with
    ``c > 0`` the smaller of it and the coat's alpha (:meth:`pyrt.Clearcoat.glossy_alpha`)."""
    a = pars[m * RECORD + GLOSSY]
    if a >= 0.0:
        return a
    a = inputs[7] * inputs[7]
    if pars[m * RECORD + COAT] != 0.0 and inputs[13] > 0.0:
        a = min(a, inputs[14])
    return a


class _OneHit:
    """The context of one hit, for the constant parameters of a material (``Material.param`` reads ``n_hits``)."""

    n_hits = 1


#: what a material's constant parameters are evaluated on when it packs its record
ONE_HIT = _OneHit()


def library_record(material, tag, params):
    """``(tag, record)`` of a model with constant parameters: its constant ``albedo()`` in the colour slot (what the
    ambient term multiplies; zeros when it has none), ``params`` from offset 4."""
    rec = empty_record()
    albedo = np.asarray(material.albedo(ONE_HIT), dtype=np.float64).reshape(-1, 3)[0] if material.has_diffuse \
        else np.zeros(3)
    rec[0:4] = [-1.0, *albedo.tolist()]
    rec[4:4 + len(params)] = params
    return tag, rec


def rgb(value):
    """A constant colour parameter (grey or RGB) as three floats."""
    return tuple(float(x) for x in np.broadcast_to(np.asarray(value, dtype=np.float64).reshape(-1), (3,)))
