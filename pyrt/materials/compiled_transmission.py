"""Rough transmission for the compiled path: scalar twins of the NumPy BSDF of :class:`pyrt.GltfPBR` above its
smooth limit (``KHR_materials_transmission`` with roughness > :data:`pyrt.materials.gltf_pbr.SMOOTH_ROUGHNESS`,
thin or the surface of a volume) and of :class:`pyrt.RoughDielectric`'s GGX BSDF.

Every function is ``numba.extending.register_jitable`` (callable from nopython code and from plain Python on
floats), for ONE hit and ONE pair of local directions (z = shading normal, ``wo`` above the horizon on the viewer's
side), each the scalar form of the NumPy function its docstring names; tests/test_compiled_rough_transmission.py holds
each to its twin (1e-6 relative on random and grazing inputs) and runs the chi-square test of every sampler
against its pdf over the whole sphere, the white furnace and the thin lobe's reciprocity.

The lobes:

- thin (:func:`thin_btdf`, :func:`thin_btdf_pdf`, :func:`sample_thin_btdf`): ``GltfPBR._btdf`` with ``thin=True``,
  the GGX reflection lobe mirrored through the surface plane (:func:`pyrt.shaders.brdfs.thin_transmission_spec_cos`)
  times ``1 - specular max(F)``, sampled by reflecting ``wo`` about a visible normal and mirroring the result;
- volume (:func:`rough_dielectric_f_cos`, :func:`rough_dielectric_pdf`, :func:`sample_rough_dielectric`): Walter
  et al. 2007's GGX BSDF, reflection above the horizon and radiance-mode refraction below
  (:func:`pyrt.shaders.brdfs.rough_dielectric_f_cos` and its pdf and sampler, the Fresnel choice from the digits
  of ``u0`` below ``1 / SPLIT``);
- the glTF mixture (:func:`gltf_f_cos`, :func:`gltf_pdf`, :func:`gltf_sample_f`): ``GltfPBR.f_cos``, ``pdf`` and
  ``sample`` of one hit of a transmitting GltfPBR: the reflection (the base's microfacet mixture,
  :func:`pyrt.materials.compiled_sampling.base_sample_wi`) with probability ``1 - w`` and the transmission lobe with
  probability ``w = (1 - metallic) transmission`` (``u0`` rescaled in each branch,
  :func:`pyrt.materials.layering.split_u`), from the hit's GLTF inputs (:func:`pyrt.materials.compiled.gltf_inputs`)
  and its transmission ``t``.

Not yet wired into the tile kernel: the glossy integrator's rough transmission renders through the NumPy path
(:func:`pyrt.integrators.compiled.glossy_reasons`).
"""
from __future__ import annotations

import math

from numba.extending import register_jitable

from pyrt.materials import compiled as MC
from pyrt.materials import compiled_sampling as CS
from pyrt.shaders import jit as J
from pyrt.shaders import jit_brdfs as JB

#: roughness at or below which a GltfPBR's transmissive share is smooth (delta lobes):
#: :data:`pyrt.materials.gltf_pbr.SMOOTH_ROUGHNESS`
SMOOTH_ROUGHNESS = 0.03
#: the Fresnel choice of :func:`sample_rough_dielectric` reads the digits of ``u0`` below ``1 / SPLIT``
#: (:data:`pyrt.shaders.brdfs.SPLIT`)
SPLIT = 4096.0


# ----------------------------------------------------------------------------------------- the thin wall

@register_jitable
def thin_btdf(wox, woy, woz, wix, wiy, wiz, alpha, specular, f0r, f0g, f0b):
    """The thin wall's transmission lobe without its weight: ``GltfPBR._btdf`` with ``thin=True``, i.e.
    ``D G / (4 cos_o)`` (GGX, height-correlated Smith) of ``wo`` and the mirrored ``(wi_x, wi_y, -wi_z)``
    (:func:`pyrt.shaders.brdfs.thin_transmission_spec_cos`) times ``1 - specular max(F)``, ``F`` Schlick of the
    dielectric F0 at the mirrored pair's ``wo.h``; 0 unless ``wo`` is above and ``wi`` below the horizon."""
    fz = -wiz
    if not (woz > 0.0 and fz > 0.0):
        return 0.0
    hx, hy, hz = wox + wix, woy + wiy, woz + fz
    hl = math.sqrt(hx * hx + hy * hy + hz * hz)
    inv = 1.0 / hl if hl > 0.0 else 0.0
    hx, hy, hz = hx * inv, hy * inv, hz * inv
    cos_oh = min(max(wox * hx + woy * hy + woz * hz, 0.0), 1.0)
    spec = JB.microfacet_spec_cos_h(woz, fz, hz, cos_oh, alpha, 0, 0)
    f = max(JB.fr_schlick(cos_oh, f0r), JB.fr_schlick(cos_oh, f0g), JB.fr_schlick(cos_oh, f0b))
    return spec * (1.0 - specular * f)


@register_jitable
def thin_btdf_pdf(wox, woy, woz, wix, wiy, wiz, alpha):
    """Density of :func:`sample_thin_btdf` (``GltfPBR._btdf_pdf`` with ``thin=True``): the visible-normal
    reflection density of the mirrored ``wi``; 0 unless ``wo`` is above and ``wi`` below the horizon."""
    if not (wiz < 0.0 and woz > 0.0):
        return 0.0
    hx, hy, hz = wox + wix, woy + wiy, woz - wiz
    hl = math.sqrt(hx * hx + hy * hy + hz * hz)
    inv = 1.0 / hl if hl > 0.0 else 0.0
    hx, hy, hz = hx * inv, hy * inv, hz * inv
    pdf_h = CS.ggx_vndf_pdf(wox, woy, woz, hx, hy, hz, alpha)
    coh = abs(wox * hx + woy * hy + woz * hz)
    return pdf_h / (4.0 * coh) if coh > 0.0 else 0.0


@register_jitable
def sample_thin_btdf(wox, woy, woz, u0, u1, alpha):
    """``(wix, wiy, wiz, ok)``: ``wo`` reflected about a GGX visible normal (:func:`pyrt.materials.
    compiled_sampling.sample_ggx_vndf`) and mirrored through the surface plane (``GltfPBR._mixture_direction``'s
    thin branch); ``ok`` where the result is below the horizon."""
    hx, hy, hz = CS.sample_ggx_vndf(wox, woy, woz, u0, u1, alpha)
    k = 2.0 * (wox * hx + woy * hy + woz * hz)
    wz = -(-woz + k * hz)
    return -wox + k * hx, -woy + k * hy, wz, wz < 0.0


# ----------------------------------------------------------------------------------------- the rough interface

@register_jitable
def _rough_half(wox, woy, woz, wix, wiy, wiz, eta):
    """Walter et al.'s generalised half vector turned to +z and the lane's class: ``(hx, hy, hz, reflect, etap,
    wo.h, wi.h, ok)`` (``pyrt.shaders.brdfs._rough_dielectric_half``)."""
    reflect = woz * wiz > 0.0
    etap = eta if woz > 0.0 else 1.0 / eta
    k = 1.0 if reflect else etap
    hx, hy, hz = wox + k * wix, woy + k * wiy, woz + k * wiz
    hl = math.sqrt(hx * hx + hy * hy + hz * hz)
    ok = hl > 0.0 and woz != 0.0 and wiz != 0.0
    inv = 1.0 / hl if ok else 1.0
    hx, hy, hz = hx * inv, hy * inv, hz * inv
    if hz < 0.0:
        hx, hy, hz = -hx, -hy, -hz
    doh = wox * hx + woy * hy + woz * hz
    dih = wix * hx + wiy * hy + wiz * hz
    ok = ok and doh * woz > 0.0 and dih * wiz > 0.0
    return hx, hy, hz, reflect, etap, doh, dih, ok


@register_jitable
def rough_dielectric_f_cos(wox, woy, woz, wix, wiy, wiz, alpha, eta):
    """GGX rough dielectric BSDF times ``|cos theta_i|``: :func:`pyrt.shaders.brdfs.rough_dielectric_f_cos`
    (reflection ``F D G2 / (4 |cos_o|)``, transmission ``(1 - F) D G2 |wi.h wo.h| / (|cos_o| (wo.h + etap
    wi.h)^2)``; ``eta`` the inside's index over the outside's)."""
    hx, hy, hz, reflect, etap, doh, dih, ok = _rough_half(wox, woy, woz, wix, wiy, wiz, eta)
    if not ok:
        return 0.0
    co, ci = abs(woz), abs(wiz)
    d = JB.ggx_d(hz, alpha)
    g = 1.0 / (1.0 + JB.ggx_lambda(co, alpha) + JB.ggx_lambda(ci, alpha))
    f = J.fr_dielectric(doh, eta)
    if reflect:
        return f * d * g / (4.0 * co)
    den = doh + etap * dih
    return (1.0 - f) * d * g * abs(dih * doh) / (co * (den * den))


@register_jitable
def rough_dielectric_pdf(wox, woy, woz, wix, wiy, wiz, alpha, eta):
    """Density of :func:`sample_rough_dielectric` over the sphere: :func:`pyrt.shaders.brdfs.rough_dielectric_pdf`
    (the visible-normal density of ``h`` from ``wo``'s side times the Fresnel choice and the reflection or
    refraction Jacobian)."""
    hx, hy, hz, reflect, etap, doh, dih, ok = _rough_half(wox, woy, woz, wix, wiy, wiz, eta)
    if not ok:
        return 0.0
    s = -1.0 if woz < 0.0 else 1.0
    pdf_h = CS.ggx_vndf_pdf(wox * s, woy * s, woz * s, hx, hy, hz, alpha)
    f = J.fr_dielectric(doh, eta)
    if reflect:
        return pdf_h * f * (1.0 / (4.0 * abs(doh)) if doh != 0.0 else 0.0)
    den = doh / etap + dih
    return pdf_h * (1.0 - f) * (abs(dih) / (den * den) if den != 0.0 else 0.0)


@register_jitable
def sample_rough_dielectric(wox, woy, woz, u0, u1, alpha, eta):
    """``(wix, wiy, wiz, valid)``: :func:`pyrt.shaders.brdfs.sample_rough_dielectric`, a GGX visible normal from
    ``wo``'s side, then reflection with probability ``F(wo.h)`` (the number ``frac(SPLIT u0)``) or refraction;
    ``valid`` where the direction is on the side its branch needs."""
    s = -1.0 if woz < 0.0 else 1.0
    ux, uy, uz = wox * s, woy * s, woz * s
    hx, hy, hz = CS.sample_ggx_vndf(ux, uy, uz, u0, u1, alpha)
    doh = ux * hx + uy * hy + uz * hz
    etap = eta if s > 0.0 else 1.0 / eta
    f = J.fr_dielectric(doh, etap)
    x = u0 * SPLIT
    choice = x - math.floor(x)
    if choice < f:
        wx, wy, wz = 2.0 * doh * hx - ux, 2.0 * doh * hy - uy, 2.0 * doh * hz - uz
        valid = wz > 0.0
    else:
        sin2 = max(0.0, 1.0 - doh * doh) / (etap * etap)
        cos_t = math.sqrt(max(0.0, 1.0 - sin2))
        k = doh / etap - cos_t
        wx, wy, wz = -ux / etap + k * hx, -uy / etap + k * hy, -uz / etap + k * hz
        ln = max(math.sqrt(wx * wx + wy * wy + wz * wz), 1e-300)
        wx, wy, wz = wx / ln, wy / ln, wz / ln
        valid = wz < 0.0
    return wx * s, wy * s, wz * s, valid and uz > 0.0


# ----------------------------------------------------------------------------------------- the glTF mixture

@register_jitable(forceinline=True)
def gltf_shares(albedo, t):
    """``(w_rough, share)`` of a transmitting GltfPBR's hit of inputs ``albedo`` (:func:`pyrt.materials.compiled.
    gltf_inputs`: metallic ``albedo[6]``, roughness ``albedo[7]``) and transmission ``t``: the rough lobe's weight
    ``(1 - metallic) t`` (0 at or below :data:`SMOOTH_ROUGHNESS`, whose share is delta lobes) and the specular
    share of the reflection (``1 - t`` on smooth hits, else 1): ``GltfPBR._transmission_weights``,
    ``GltfPBR._reflection``."""
    if albedo[7] <= SMOOTH_ROUGHNESS:
        return 0.0, 1.0 - t
    return (1.0 - albedo[6]) * t, 1.0


@register_jitable(forceinline=True)
def transmission_choice(albedo, w, woz):
    """The probability that :func:`gltf_sample_f` draws the transmission lobe of weight ``w``
    (``GltfPBR._transmission_choice``): ``w (1 - specular F(cos_o))``, ``F`` Schlick of the dielectric F0's
    largest channel (``albedo[10:13]``; specular ``albedo[9]``) at ``cos_o = woz`` clipped to [0, 1]: the specular
    reflection on top of a fully transmitting hit is drawn too."""
    f0 = max(albedo[10], albedo[11], albedo[12])
    return w * (1.0 - albedo[9] * JB.fr_schlick(min(max(woz, 0.0), 1.0), f0))


@register_jitable
def btdf(albedo, thin, eta, wox, woy, woz, wix, wiy, wiz):
    """``GltfPBR._btdf``: :func:`thin_btdf` (``thin``) or the volume's :func:`rough_dielectric_f_cos` below the
    horizon (``eta`` the relative index, ``GltfPBR._eta``), of ``alpha = roughness^2``."""
    alpha = albedo[7] * albedo[7]
    if thin:
        return thin_btdf(wox, woy, woz, wix, wiy, wiz, alpha, albedo[9], albedo[10], albedo[11], albedo[12])
    if not wiz < 0.0:
        return 0.0
    return rough_dielectric_f_cos(wox, woy, woz, wix, wiy, wiz, alpha, eta)


@register_jitable
def btdf_pdf(albedo, thin, eta, wox, woy, woz, wix, wiy, wiz):
    """``GltfPBR._btdf_pdf``: :func:`thin_btdf_pdf` or :func:`rough_dielectric_pdf` (both sides)."""
    alpha = albedo[7] * albedo[7]
    if thin:
        return thin_btdf_pdf(wox, woy, woz, wix, wiy, wiz, alpha)
    return rough_dielectric_pdf(wox, woy, woz, wix, wiy, wiz, alpha, eta)


@register_jitable
def gltf_f_cos(albedo, t, thin, eta, geometry, wox, woy, woz, wix, wiy, wiz):
    """``GltfPBR.f_cos`` (RGB) at one hit of a transmitting GltfPBR (isotropic): the reflection
    (:func:`pyrt.shaders.jit_brdfs.gltf_pbr_f_cos_h` with transmission ``t`` and the share of :func:`gltf_shares`,
    from the normalised half vector as :func:`pyrt.materials.compiled_sampling.f_cos_local`) plus the rough lobe
    ``w_rough`` :func:`btdf` times the base colour; ``geometry`` the reflection's
    :data:`pyrt.shaders.jit_brdfs.GEOMETRY_TERMS` index."""
    w, share = gltf_shares(albedo, t)
    hx, hy, hz = wox + wix, woy + wiy, woz + wiz
    hl = math.sqrt(hx * hx + hy * hy + hz * hz)
    inv = 1.0 / hl if hl > 0.0 else 0.0
    hx, hy, hz = hx * inv, hy * inv, hz * inv
    cos_oh = min(max(wox * hx + woy * hy + woz * hz, 0.0), 1.0)
    r, g, b = JB.gltf_pbr_f_cos_h(woz, wiz, hz, cos_oh, albedo[3], albedo[4], albedo[5], albedo[6], albedo[7],
                                  albedo[10], albedo[11], albedo[12], albedo[9], t, share, geometry)
    if w > 0.0:
        k = w * btdf(albedo, thin, eta, wox, woy, woz, wix, wiy, wiz)
        r, g, b = r + k * albedo[3], g + k * albedo[4], b + k * albedo[5]
    return r, g, b


@register_jitable
def gltf_pdf(pars, m, albedo, t, thin, eta, wox, woy, woz, wix, wiy, wiz):
    """``GltfPBR.pdf``: ``(1 - c)`` times the reflection's mixture density (:func:`pyrt.materials.
    compiled_sampling.base_pdf_wi` of the GLTF tag, 0 below the horizon) plus ``c`` :func:`btdf_pdf`, ``c`` the
    :func:`transmission_choice` of ``w`` of :func:`gltf_shares`; ``pars``, ``m`` the material table and row (the
    GLTF mixture reads the inputs only)."""
    w, _ = gltf_shares(albedo, t)
    p = CS.base_pdf_wi(MC.GLTF, pars, m, albedo, wox, woy, woz, wix, wiy, wiz)
    if not w > 0.0:
        return p
    if not wiz > 0.0:
        p = 0.0
    c = transmission_choice(albedo, w, woz)
    return (1.0 - c) * p + c * btdf_pdf(albedo, thin, eta, wox, woy, woz, wix, wiy, wiz)


@register_jitable
def gltf_sample_f(pars, m, albedo, t, thin, eta, geometry, wox, woy, woz, u0, u1):
    """``GltfPBR.sample`` at one hit: ``(wix, wiy, wiz, w_r, w_g, w_b, pdf)``. With probability
    :func:`transmission_choice` (of ``w`` of :func:`gltf_shares`; ``u0`` rescaled in each branch and clipped below 1
    as :func:`pyrt.materials.layering.split_u`) the transmission lobe's direction (:func:`sample_thin_btdf`, :func:`sample_rough_dielectric`), else
    the reflection mixture's (:func:`pyrt.materials.compiled_sampling.base_sample_wi`); then
    :func:`pyrt.materials.layering.finish_sample`: zeros where the direction is not valid (``wo`` below the horizon,
    a branch's direction on the wrong side) or its density (:func:`gltf_pdf`) is 0, else the weight
    ``f_cos / pdf`` (:func:`gltf_f_cos`). A hit without a rough lobe (``w`` 0) samples as the opaque model
    (:func:`pyrt.materials.compiled_sampling.sample_f` of the GLTF tag)."""
    w, _ = gltf_shares(albedo, t)
    if not w > 0.0:
        wix, wiy, wiz, pdf = CS.base_sample_wi(MC.GLTF, pars, m, albedo, wox, woy, woz, u0, u1)
        if not (pdf > 0.0 and wiz > 0.0 and woz > 0.0):
            return wix, wiy, wiz, 0.0, 0.0, 0.0, pdf
        r, g, b = gltf_f_cos(albedo, t, thin, eta, geometry, wox, woy, woz, wix, wiy, wiz)
        return wix, wiy, wiz, r / pdf, g / pdf, b / pdf, pdf
    take, v = CS.split_u(u0, transmission_choice(albedo, w, woz))
    if take:
        alpha = albedo[7] * albedo[7]
        if thin:
            wix, wiy, wiz, ok = sample_thin_btdf(wox, woy, woz, v, u1, alpha)
        else:
            wix, wiy, wiz, ok = sample_rough_dielectric(wox, woy, woz, v, u1, alpha, eta)
    else:
        wix, wiy, wiz, _ = CS.base_sample_wi(MC.GLTF, pars, m, albedo, wox, woy, woz, v, u1)
        ok = wiz > 0.0
    if not (ok and woz > 0.0):
        return 0.0, 0.0, 0.0, 0.0, 0.0, 0.0, 0.0
    pdf = gltf_pdf(pars, m, albedo, t, thin, eta, wox, woy, woz, wix, wiy, wiz)
    if not pdf > 0.0:
        return wix, wiy, wiz, 0.0, 0.0, 0.0, 0.0
    r, g, b = gltf_f_cos(albedo, t, thin, eta, geometry, wox, woy, woz, wix, wiy, wiz)
    return wix, wiy, wiz, r / pdf, g / pdf, b / pdf, pdf
