"""BSDF sampling of the compiled material families: scalar twins of the materials' ``sample`` / ``pdf``.

Every function here is ``numba.extending.register_jitable``: callable from nopython code (the compiled tile kernel)
and from plain Python on floats. Each is the scalar form, for ONE hit and ONE direction, of a NumPy function named
in its docstring; tests/test_compiled_sampling.py holds each to its twin (same ``u`` -> the same direction and pdf,
1e-6 relative, grazing ``wo`` and extreme ``u`` included) and runs the chi-square test of every compiled sampler
against its compiled pdf.

Frames. Directions are in the hit's local shading frame (z = shading normal), as the materials' ``sample`` and
``pdf`` take them; :func:`coordinate_frame`, :func:`to_local` and :func:`to_world` are the NumPy path's frame
(:func:`pyrt.shaders.vec.coordinate_frame` of the shading normal, :meth:`pyrt.geometry.SurfaceBatch.to_local` /
``to_world``) with the same operations in the same order, so a sampled local direction is the same world
direction on both paths. :mod:`pyrt.lights.compiled` samples the area lights with :func:`coordinate_frame` and
:func:`square_to_uniform_disk_concentric` from here (one home for each formula).

Which sampler each tag of :mod:`pyrt.materials.compiled` uses (the classes' own ``sample``):

==========================================================  =========================================================
LAMBERT, BLINN_PHONG, PHONG, PHONG_CLASSIC,                 the cosine-weighted hemisphere (:meth:`pyrt.materials.
BLINN_PHONG_CLASSIC, OREN_NAYAR, WARD                       Material.sample`, :meth:`pyrt.materials.Lambert.sample`)
COOK_TORRANCE, METALLIC_ROUGHNESS, GLTF                     the mixture of :class:`pyrt.materials.library.
                                                            _MicrofacetSampling`: with probability ``p_spec`` the
                                                            specular lobe (GGX visible normals; the Beckmann NDF for
                                                            the Beckmann and Blinn distributions), else the cosine
                                                            lobe; ``u0`` is reused for the chosen strategy
==========================================================  =========================================================

``p_spec``: Cook-Torrance ``lum(ks) / (lum(ks) + lum(kd))`` (1 when both are 0); metallic-roughness
``F / (F + lum(base (1 - m)) (1 - F))`` with ``F = lum(Schlick(F0, n.wo))``, ``F0 = mix(0.04, base, m)``.

The pdf returned by :func:`sample_wi` is what the NumPy ``sample`` returns: for the microfacet mixture it is 0
where ``wo`` or ``wi`` is at or below the horizon (and where the mixture density is 0); :func:`pdf_wi` is the
NumPy ``pdf`` (not so masked: ``(1 - p_spec)`` times the cosine density wherever ``wi`` is above the horizon).
"""
from __future__ import annotations

import math

from numba.extending import register_jitable

from pyrt.materials import compiled as MC
from pyrt.shaders import jit_brdfs as JB
from pyrt.shaders.jit_math import sincos

INV_PI = 1.0 / math.pi
#: Rec. 709 luminance weights (:data:`pyrt.shaders.color.LUMINANCE_WEIGHTS`)
LUM_R, LUM_G, LUM_B = 0.2126, 0.7152, 0.0722
#: the largest u the microfacet mixture hands to a warp after reusing u0 (``1 - 1e-12``, as the NumPy path clips)
U_MAX = 1.0 - 1e-12


# ----------------------------------------------------------------------------------------- frames

@register_jitable(forceinline=True)
def coordinate_frame(nx, ny, nz):
    """The tangents ``(s, t)`` (two 3-tuples) around the unit normal ``n``: :func:`pyrt.shaders.vec.coordinate_frame`
    (Duff et al. 2017), the same operations in the same order (bit for bit)."""
    sign = 1.0 if nz >= 0.0 else -1.0
    a = -1.0 / (sign + nz)
    b = nx * ny * a
    return (1.0 + sign * nx * nx * a, sign * b, -sign * nx), (b, sign + ny * ny * a, -ny)


@register_jitable(forceinline=True)
def to_local(v, s, t, n):
    """World vector ``v`` in the frame ``(s, t, n)`` (3-tuples): :func:`pyrt.shaders.vec.to_local` (each component
    ``v.x a.x + v.y a.y + v.z a.z``, summed left to right)."""
    return (v[0] * s[0] + v[1] * s[1] + v[2] * s[2], v[0] * t[0] + v[1] * t[1] + v[2] * t[2],
            v[0] * n[0] + v[1] * n[1] + v[2] * n[2])


@register_jitable(forceinline=True)
def to_world(w, s, t, n):
    """Local vector ``w`` in world space: :meth:`pyrt.geometry.SurfaceBatch.to_world` (``w.x s + w.y t + w.z n`` per
    component, summed left to right)."""
    return (w[0] * s[0] + w[1] * t[0] + w[2] * n[0], w[0] * s[1] + w[1] * t[1] + w[2] * n[1],
            w[0] * s[2] + w[1] * t[2] + w[2] * n[2])


# ----------------------------------------------------------------------------------------- warps

@register_jitable(forceinline=True)
def square_to_uniform_disk_concentric(u0, u1):
    """Shirley-Chiu's concentric map of ``(u0, u1)`` to the unit disk: :func:`pyrt.shaders.sampling.
    square_to_uniform_disk_concentric` (selects and :func:`pyrt.shaders.jit_math.sincos`, no branch and no libm
    call: a packet stage using it vectorises)."""
    x = 2.0 * u0 - 1.0
    y = 2.0 * u1 - 1.0
    wide = abs(x) > abs(y)
    r = x if wide else y
    theta = (math.pi / 4) * (y / x) if wide else math.pi / 2 - (math.pi / 4) * (x / (y if y != 0.0 else 1.0))
    sn, cs = sincos(theta)
    r = 0.0 if (x == 0.0) & (y == 0.0) else r
    return r * cs, r * sn


@register_jitable(forceinline=True)
def square_to_cosine_hemisphere(u0, u1):
    """Cosine-weighted direction (Malley): :func:`pyrt.shaders.sampling.square_to_cosine_hemisphere` (its height from
    the disk radius, well conditioned at the rim)."""
    dx, dy = square_to_uniform_disk_concentric(u0, u1)
    r = max(abs(2.0 * u0 - 1.0), abs(2.0 * u1 - 1.0))
    return dx, dy, math.sqrt(max(0.0, (1.0 - r) * (1.0 + r)))


@register_jitable(forceinline=True)
def cosine_hemisphere_pdf(wz):
    """``cos theta / pi`` above the horizon, else 0: :func:`pyrt.shaders.sampling.cosine_hemisphere_pdf`."""
    if wz > 0.0:
        return wz / math.pi
    return 0.0


@register_jitable(forceinline=True)
def square_to_uniform_sphere(u0, u1):
    """Uniform direction on the sphere: :func:`pyrt.shaders.sampling.square_to_uniform_sphere` (pdf ``1 / 4 pi``)."""
    z = 1.0 - 2.0 * u0
    r = math.sqrt(max(0.0, 1.0 - z * z))
    sp, cp = sincos(2.0 * math.pi * u1)
    return r * cp, r * sp, z


@register_jitable
def power_heuristic(pdf_f, pdf_g, beta, n_f, n_g):
    """Veach's power heuristic ``(n_f p_f)^beta / ((n_f p_f)^beta + (n_g p_g)^beta)`` for ``beta`` 2 (power) or 1
    (balance); 0 where both are 0: :func:`pyrt.shaders.sampling.power_heuristic`."""
    a = n_f * pdf_f
    b = n_g * pdf_g
    if beta == 2.0:
        a = a * a
        b = b * b
    s = a + b
    if s > 0.0:
        return a / s
    return 0.0


# ----------------------------------------------------------------------------------------- microfacet sampling

@register_jitable
def sample_ggx_vndf(wox, woy, woz, u0, u1, alpha):
    """A GGX visible normal from ``wo`` (Heitz 2018): :func:`pyrt.shaders.microfacet.sample_ggx_vndf` (isotropic)."""
    al = max(alpha, JB.ALPHA_MIN)
    vx, vy, vz = al * wox, al * woy, max(woz, 0.0)
    vl = math.sqrt(vx * vx + vy * vy + vz * vz)
    if vl > 0.0:
        vx, vy, vz = vx / vl, vy / vl, vz / vl
    else:
        vx, vy, vz = 0.0, 0.0, 1.0
    lensq = vx * vx + vy * vy
    if lensq > 0.0:
        inv = 1.0 / math.sqrt(lensq)
        t1x, t1y, t1z = -vy * inv, vx * inv, 0.0
    else:
        t1x, t1y, t1z = 1.0, 0.0, 0.0
    t2x, t2y, t2z = vy * t1z - vz * t1y, vz * t1x - vx * t1z, vx * t1y - vy * t1x      # cross(vh, t1)
    r = math.sqrt(u0)
    sp, cp = sincos(2.0 * math.pi * u1)
    p1 = r * cp
    p2 = r * sp
    s = 0.5 * (1.0 + vz)
    p2 = (1.0 - s) * math.sqrt(max(0.0, 1.0 - p1 * p1)) + s * p2
    p3 = math.sqrt(max(0.0, 1.0 - p1 * p1 - p2 * p2))
    nx = p1 * t1x + p2 * t2x + p3 * vx
    ny = p1 * t1y + p2 * t2y + p3 * vy
    nz = p1 * t1z + p2 * t2z + p3 * vz
    ex, ey, ez = al * nx, al * ny, max(nz, 0.0)
    el = math.sqrt(ex * ex + ey * ey + ez * ez)
    if el > 0.0:
        return ex / el, ey / el, ez / el
    return 0.0, 0.0, 1.0


@register_jitable(forceinline=True)
def sample_beckmann_ndf(u0, u1, alpha):
    """A half vector of density ``D_beckmann(h) (n.h)``: :func:`pyrt.shaders.microfacet.sample_beckmann_ndf`."""
    a2 = max(alpha, JB.ALPHA_MIN) ** 2
    tan2 = -a2 * math.log1p(-min(u0, 1.0 - 1e-16))
    cos_t = 1.0 / math.sqrt(1.0 + tan2)
    sin_t = math.sqrt(max(0.0, 1.0 - cos_t * cos_t))
    phi = 2.0 * math.pi * u1
    return sin_t * math.cos(phi), sin_t * math.sin(phi), cos_t


@register_jitable
def ggx_vndf_pdf(wox, woy, woz, hx, hy, hz, alpha):
    """``G1(wo) max(0, wo.h) D(h) / wo.z`` (0 where ``wo.z <= 0``): :func:`pyrt.shaders.microfacet.ggx_vndf_pdf`."""
    if not woz > 0.0:
        return 0.0
    coh = max(wox * hx + woy * hy + woz * hz, 0.0)
    g1 = 1.0 / (1.0 + JB.ggx_lambda(woz, alpha))
    return g1 * coh * JB.ggx_d(hz, alpha) / woz


@register_jitable
def spec_pdf(distribution, wox, woy, woz, wix, wiy, wiz, alpha):
    """Density of ``wi`` under the specular strategy: ``_MicrofacetSampling._spec_pdf`` (isotropic) with
    :func:`pyrt.shaders.vec.half_vector` and :func:`pyrt.shaders.microfacet.reflect_pdf`; ``distribution`` an index
    of :data:`pyrt.shaders.jit_brdfs.DISTRIBUTIONS` (0 GGX visible normals, else the Beckmann NDF)."""
    if not (woz > 0.0 and wiz > 0.0):
        return 0.0
    hx, hy, hz = wox + wix, woy + wiy, woz + wiz
    hl = math.sqrt(hx * hx + hy * hy + hz * hz)
    if not hl > 0.0:
        return 0.0
    inv = 1.0 / hl
    hx, hy, hz = hx * inv, hy * inv, hz * inv
    if distribution == 0:
        pdf_h = ggx_vndf_pdf(wox, woy, woz, hx, hy, hz, alpha)
    else:
        pdf_h = JB.beckmann_d(hz, alpha) * max(hz, 0.0)
    coh = abs(wox * hx + woy * hy + woz * hz)
    return pdf_h / (4.0 * coh) if coh > 0.0 else 0.0


@register_jitable(forceinline=True)
def _lum(r, g, b):
    return r * LUM_R + g * LUM_G + b * LUM_B


@register_jitable
def mixture(tag, pars, m, albedo, woz):
    """``(p_spec, alpha, distribution)`` of the microfacet mixture of material ``m`` (COOK_TORRANCE,
    METALLIC_ROUGHNESS or GLTF, whose parameters are the hit's inputs ``albedo``; ``pars`` the record table):
    ``CookTorrance._spec_prob`` / ``MetallicRoughness._spec_prob``, the lobe's ``_alpha`` and its distribution
    index."""
    b = m * MC.RECORD
    if tag == MC.COOK_TORRANCE:
        s = _lum(pars[b + 7], pars[b + 8], pars[b + 9])
        d = _lum(pars[b + 4], pars[b + 5], pars[b + 6])
        ps = s / (s + d) if s + d > 0.0 else 1.0
        return ps, pars[b + 10], int(pars[b + 11])
    if tag == MC.GLTF:
        base_r, base_g, base_b, metal, rough = albedo[3], albedo[4], albedo[5], albedo[6], albedo[7]
    else:
        base_r, base_g, base_b, metal, rough = pars[b + 4], pars[b + 5], pars[b + 6], pars[b + 7], pars[b + 8]
    c = min(max(woz, 0.0), 1.0)
    mm = (1.0 - c) ** 5
    f0r = JB.GLTF_DIELECTRIC_F0 * (1.0 - metal) + base_r * metal
    f0g = JB.GLTF_DIELECTRIC_F0 * (1.0 - metal) + base_g * metal
    f0b = JB.GLTF_DIELECTRIC_F0 * (1.0 - metal) + base_b * metal
    f = _lum(f0r + (1.0 - f0r) * mm, f0g + (1.0 - f0g) * mm, f0b + (1.0 - f0b) * mm)
    d = _lum(base_r * (1.0 - metal), base_g * (1.0 - metal), base_b * (1.0 - metal)) * (1.0 - f)
    ps = f / (f + d) if f + d > 0.0 else 1.0
    return ps, rough * rough, 0


@register_jitable(forceinline=True)
def is_microfacet(tag):
    """True for the tags sampled by the microfacet mixture (COOK_TORRANCE, METALLIC_ROUGHNESS, GLTF)."""
    return tag == MC.COOK_TORRANCE or tag == MC.METALLIC_ROUGHNESS or tag == MC.GLTF


# ----------------------------------------------------------------------------------------- the switch

@register_jitable
def sample_wi(tag, pars, m, albedo, wox, woy, woz, u0, u1):
    """Sample material ``m`` (tag ``tag``, record table ``pars``, the hit's inputs ``albedo``: :func:`pyrt.materials.
    compiled.albedo_at`) from the local ``wo``: ``(wix, wiy, wiz, pdf)``,
    the local direction and its solid-angle density as the material's NumPy ``sample(wo, u, ctx)`` returns them
    for ``u = (u0, u1)`` (the cosine hemisphere, or ``_MicrofacetSampling._sample_wi`` and its masked pdf; a coated
    GLTF: :func:`coat_sample_wi`). Tags without a non-delta lobe give ``(0, 0, 1, 0)``."""
    if MC.is_coated(tag, pars, m):
        return coat_sample_wi(tag, pars, m, albedo, wox, woy, woz, u0, u1)
    return base_sample_wi(tag, pars, m, albedo, wox, woy, woz, u0, u1)


@register_jitable(forceinline=True)
def split_u(u0, p):
    """``(take, v)``: whether ``u0`` picks the strategy of probability ``p`` (``u0 < p``) and ``u0`` rescaled to [0, 1)
    within the branch taken (clamped below 1): :func:`pyrt.materials.layering.split_u` for one sample."""
    take = u0 < p
    if take:
        v = u0 / (p if p > 0.0 else 1.0)
    else:
        v = (u0 - p) / (1.0 - p if p < 1.0 else 1.0)
    return take, min(max(v, 0.0), U_MAX)


@register_jitable
def base_sample_wi(tag, pars, m, albedo, wox, woy, woz, u0, u1):
    """:func:`sample_wi` without a clear coat (of a coated GLTF: its base's)."""
    if is_microfacet(tag):
        ps, alpha, dist = mixture(tag, pars, m, albedo, woz)
        spec, v = split_u(u0, ps)
        if spec:
            if dist == 0:
                hx, hy, hz = sample_ggx_vndf(wox, woy, woz, v, u1, alpha)
            else:
                hx, hy, hz = sample_beckmann_ndf(v, u1, alpha)
            k = 2.0 * (wox * hx + woy * hy + woz * hz)
            wix, wiy, wiz = -wox + k * hx, -woy + k * hy, -woz + k * hz
        else:
            wix, wiy, wiz = square_to_cosine_hemisphere(v, u1)
        pdf = ps * spec_pdf(dist, wox, woy, woz, wix, wiy, wiz, alpha) + (1.0 - ps) * cosine_hemisphere_pdf(wiz)
        if not (pdf > 0.0 and wiz > 0.0 and woz > 0.0):
            pdf = 0.0
        return wix, wiy, wiz, pdf
    if MC.has_diffuse(tag):
        wix, wiy, wiz = square_to_cosine_hemisphere(u0, u1)
        return wix, wiy, wiz, cosine_hemisphere_pdf(wiz)
    return 0.0, 0.0, 1.0, 0.0


@register_jitable
def pdf_wi(tag, pars, m, albedo, wox, woy, woz, wix, wiy, wiz):
    """Solid-angle density of :func:`sample_wi` at the local ``wi``: the material's NumPy ``pdf(wo, wi, ctx)``
    (``Material.pdf``, ``_MicrofacetSampling.pdf``, :meth:`pyrt.Clearcoat.pdf`); 0 for tags without a non-delta
    lobe."""
    if MC.is_coated(tag, pars, m):
        return coat_pdf(pars, m, albedo, wox, woy, woz, wix, wiy, wiz)
    return base_pdf_wi(tag, pars, m, albedo, wox, woy, woz, wix, wiy, wiz)


@register_jitable
def base_pdf_wi(tag, pars, m, albedo, wox, woy, woz, wix, wiy, wiz):
    """:func:`pdf_wi` without a clear coat (of a coated GLTF: its base's)."""
    if is_microfacet(tag):
        ps, alpha, dist = mixture(tag, pars, m, albedo, woz)
        return ps * spec_pdf(dist, wox, woy, woz, wix, wiy, wiz, alpha) + (1.0 - ps) * cosine_hemisphere_pdf(wiz)
    if MC.has_diffuse(tag):
        return cosine_hemisphere_pdf(wiz)
    return 0.0


@register_jitable
def f_cos_local(tag, pars, m, albedo, wox, woy, woz, wix, wiy, wiz):
    """BRDF times ``cos theta_i`` (RGB) for local vectors: :func:`pyrt.materials.compiled.f_cos` of the three cosines,
    but for the microfacet models from ``n.h`` and ``wo.h`` of the normalised half vector (as their NumPy ``f_cos``
    computes them: well conditioned where both directions graze the surface); a coated GLTF's with its coat
    (:func:`coat_f_cos`)."""
    if is_microfacet(tag):
        hx, hy, hz = wox + wix, woy + wiy, woz + wiz
        hl = math.sqrt(hx * hx + hy * hy + hz * hz)
        inv = 1.0 / hl if hl > 0.0 else 0.0
        hx, hy, hz = hx * inv, hy * inv, hz * inv
        cos_h = hz
        cos_oh = min(max(wox * hx + woy * hy + woz * hz, 0.0), 1.0)
        b = m * MC.RECORD
        p = pars
        if tag == MC.GLTF:
            f = MC.gltf_f_cos_h(p, b, albedo, woz, wiz, cos_h, cos_oh)
            if p[b + MC.COAT] != 0.0:
                return coat_f_cos(p, b, albedo, f, wox, woy, woz, wix, wiy, wiz)
            return f
        if tag == MC.COOK_TORRANCE:
            return JB.cook_torrance_f_cos_h(woz, wiz, cos_h, cos_oh, p[b + 4], p[b + 5], p[b + 6], p[b + 7],
                                            p[b + 8], p[b + 9], p[b + 10], int(p[b + 11]), int(p[b + 12]),
                                            int(p[b + 13]), p[b + 14], p[b + 15], p[b + 16], p[b + 17], p[b + 18],
                                            p[b + 19])
        return JB.metallic_roughness_f_cos_h(woz, wiz, cos_h, cos_oh, p[b + 4], p[b + 5], p[b + 6], p[b + 7],
                                             p[b + 8], int(p[b + 9]))
    return MC.f_cos(tag, pars, m, albedo, woz, wiz, wox * wix + woy * wiy + woz * wiz)


@register_jitable
def sample_f(tag, pars, m, albedo, wox, woy, woz, u0, u1):
    """The material's NumPy ``sample(wo, u, ctx)`` in full: ``(wix, wiy, wiz, w_r, w_g, w_b, pdf)``, the direction
    and pdf of :func:`sample_wi` and the weight ``f_cos / pdf`` (:func:`f_cos_local`; 0 where the pdf is 0 or either
    direction is at or below the horizon). LAMBERT's weight is its albedo where ``wo`` is above the horizon
    (:meth:`pyrt.materials.Lambert.sample`); ``albedo`` (RGB tuple) is :func:`pyrt.materials.compiled.albedo_at`."""
    wix, wiy, wiz, pdf = sample_wi(tag, pars, m, albedo, wox, woy, woz, u0, u1)
    if MC.is_coated(tag, pars, m):      # pyrt.materials.layering.finish_sample: no horizon test of its own
        if not pdf > 0.0:
            return wix, wiy, wiz, 0.0, 0.0, 0.0, 0.0
        fr, fg, fb = f_cos_local(tag, pars, m, albedo, wox, woy, woz, wix, wiy, wiz)
        return wix, wiy, wiz, fr / pdf, fg / pdf, fb / pdf, pdf
    if tag == MC.LAMBERT:
        if woz > 0.0 and pdf > 0.0:
            return wix, wiy, wiz, albedo[0], albedo[1], albedo[2], pdf
        return wix, wiy, wiz, 0.0, 0.0, 0.0, pdf
    if not (pdf > 0.0 and wiz > 0.0 and woz > 0.0):
        return wix, wiy, wiz, 0.0, 0.0, 0.0, pdf
    fr, fg, fb = f_cos_local(tag, pars, m, albedo, wox, woy, woz, wix, wiy, wiz)
    return wix, wiy, wiz, fr / pdf, fg / pdf, fb / pdf, pdf


@register_jitable
def f_cos_world(tag, pars, m, albedo, wo, wi, ns):
    """BRDF times ``cos theta_i`` (RGB) of world directions ``wo``, ``wi`` at a hit of shading normal ``ns``:
    :func:`pyrt.materials.compiled.f_cos` of their cosines, a coated GLTF's (:func:`pyrt.materials.compiled.is_coated`)
    :func:`f_cos_local` in the frame of ``ns`` (its coat's normal is given in that frame)."""
    if MC.is_coated(tag, pars, m):
        fs, ft = coordinate_frame(ns[0], ns[1], ns[2])
        wol, wil = to_local(wo, fs, ft, ns), to_local(wi, fs, ft, ns)
        return f_cos_local(tag, pars, m, albedo, wol[0], wol[1], wol[2], wil[0], wil[1], wil[2])
    return MC.f_cos(tag, pars, m, albedo, wo[0] * ns[0] + wo[1] * ns[1] + wo[2] * ns[2],
                    wi[0] * ns[0] + wi[1] * ns[1] + wi[2] * ns[2], wi[0] * wo[0] + wi[1] * wo[1] + wi[2] * wo[2])


# ----------------------------------------------------------------------------------------- the clear coat

@register_jitable(forceinline=True)
def coat_frame(albedo):
    """``(s, t, n)``: the frame of a coated hit's coat normal ``n`` (the inputs' last three, in the local shading
    frame; :meth:`pyrt.Clearcoat._coat_frame`)."""
    n = (albedo[15], albedo[16], albedo[17])
    s, t = coordinate_frame(n[0], n[1], n[2])
    return s, t, n


@register_jitable(forceinline=True)
def coat_weight(pars, b, albedo, cos_oc):
    """``c F_c`` at ``|n_c.wo| = |cos_oc|``: :meth:`pyrt.Clearcoat.coat_weight` (``fresnel="view"``)."""
    return albedo[13] * JB.fr_schlick(abs(cos_oc), pars[b + MC.COAT + 11])


@register_jitable(forceinline=True)
def coat_prob(pars, b, albedo, cos_oc):
    """The probability of sampling the coat's lobe: ``c F_c``, at least ``c / 4``, at most 0.9
    (:meth:`pyrt.Clearcoat._coat_prob`)."""
    return min(max(max(coat_weight(pars, b, albedo, cos_oc), 0.25 * albedo[13]), 0.0), 0.9)


@register_jitable
def coat_f_cos(pars, b, albedo, f, wox, woy, woz, wix, wiy, wiz):
    """:meth:`pyrt.Clearcoat.f_cos` of the base's ``f`` (RGB) for local ``wo``, ``wi`` of the coated GLTF record at
    ``pars[b:]``: ``f (1 - c F_c) + c F_c D G / (4 cos_o)`` (GGX, height-correlated Smith, in the coat's frame; with
    the coat's own normal map 0 where either direction is below the shading frame's horizon)."""
    s, t, n = coat_frame(albedo)
    wo_c = to_local((wox, woy, woz), s, t, n)
    wi_c = to_local((wix, wiy, wiz), s, t, n)
    cw = coat_weight(pars, b, albedo, wo_c[2])
    spec = 0.0
    if wo_c[2] > 0.0 and wi_c[2] > 0.0 and not (pars[b + MC.COAT + 7] != 0.0 and (woz <= 0.0 or wiz <= 0.0)):
        hx, hy, hz = wo_c[0] + wi_c[0], wo_c[1] + wi_c[1], wo_c[2] + wi_c[2]
        hl = math.sqrt(hx * hx + hy * hy + hz * hz)
        inv = 1.0 / hl if hl > 0.0 else 0.0
        hx, hy, hz = hx * inv, hy * inv, hz * inv
        cos_oh = min(max(wo_c[0] * hx + wo_c[1] * hy + wo_c[2] * hz, 0.0), 1.0)
        spec = JB.microfacet_spec_cos_h(wo_c[2], wi_c[2], hz, cos_oh, albedo[14], 0, 0)
    k, cs = 1.0 - cw, cw * spec
    return f[0] * k + cs, f[1] * k + cs, f[2] * k + cs


@register_jitable
def coat_pdf(pars, m, albedo, wox, woy, woz, wix, wiy, wiz):
    """:meth:`pyrt.Clearcoat.pdf`: ``p_coat`` times the GGX visible-normal reflection density in the coat's frame
    plus ``1 - p_coat`` times the base's (:func:`base_pdf_wi`)."""
    b = m * MC.RECORD
    s, t, n = coat_frame(albedo)
    wo_c = to_local((wox, woy, woz), s, t, n)
    wi_c = to_local((wix, wiy, wiz), s, t, n)
    p = coat_prob(pars, b, albedo, wo_c[2])
    pc = spec_pdf(0, wo_c[0], wo_c[1], wo_c[2], wi_c[0], wi_c[1], wi_c[2], albedo[14]) if woz > 0.0 else 0.0
    return p * pc + (1.0 - p) * base_pdf_wi(MC.GLTF, pars, m, albedo, wox, woy, woz, wix, wiy, wiz)


@register_jitable
def coat_sample_wi(tag, pars, m, albedo, wox, woy, woz, u0, u1):
    """:meth:`pyrt.Clearcoat.sample`'s direction and density: the coat's GGX visible normals in its frame with
    probability ``p_coat`` (``u0`` rescaled in each branch, :func:`pyrt.materials.layering.split_u`), else the base's
    (:func:`base_sample_wi`); ``(0, 0, 0, 0)`` where the sample is not valid (the coat's reflection below its horizon,
    ``wo`` below either horizon), else the direction and the mixture's density (:func:`coat_pdf`; 0 where it is
    not positive)."""
    b = m * MC.RECORD
    s, t, n = coat_frame(albedo)
    wo_c = to_local((wox, woy, woz), s, t, n)
    take, v = split_u(u0, coat_prob(pars, b, albedo, wo_c[2]))
    if take:
        hx, hy, hz = sample_ggx_vndf(wo_c[0], wo_c[1], wo_c[2], v, u1, albedo[14])
        k = 2.0 * (wo_c[0] * hx + wo_c[1] * hy + wo_c[2] * hz)
        wc = (-wo_c[0] + k * hx, -wo_c[1] + k * hy, -wo_c[2] + k * hz)
        valid = wc[2] > 0.0 and wo_c[2] > 0.0
        wix, wiy, wiz = to_world(wc, s, t, n)
    else:
        wix, wiy, wiz, _ = base_sample_wi(tag, pars, m, albedo, wox, woy, woz, v, u1)
        valid = wix != 0.0 or wiy != 0.0 or wiz != 0.0
    if not (valid and woz > 0.0):
        return 0.0, 0.0, 0.0, 0.0
    pdf = coat_pdf(pars, m, albedo, wox, woy, woz, wix, wiy, wiz)
    return wix, wiy, wiz, pdf if pdf > 0.0 else 0.0
