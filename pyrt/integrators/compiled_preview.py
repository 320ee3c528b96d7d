"""The environment light's noise-free ``strategy="preview"`` in the compiled tile kernel.

The estimator of :func:`pyrt.integrators.direct._environment_preview`, per hit, the same formulas in the same order
(no shadow rays, no random numbers): Lambert ``albedo / pi E_SH(n_s)``; with ``preview_method="split_sum"`` the
materials that declare preview lobes (:meth:`pyrt.materials.Material.preview_lobes`: in the kernel the
METALLIC_ROUGHNESS and GLTF records, i.e. ``MetallicRoughness``, ``LearnOpenGLPBR``, isotropic ``GltfPBR`` (opaque or
smooth transmitting: the transmission's share of the lobes, :meth:`pyrt.GltfPBR.preview_lobes`) and
the glTF loader's materials) ``occlusion (diffuse / pi E_SH(n_s) + weight x prefiltered(dominant direction, alpha))``
with the lobes of :mod:`pyrt.shaders.jit_preview`; every other material with a non-delta lobe (and those, with
``"samples"``) the mean over ``preview_samples`` fixed Hammersley BSDF samples (:func:`pyrt.materials.
compiled_sampling.sample_f`) of ``weight x prefiltered(wi, alpha(1 / (K pdf)))`` over samples above the geometric
surface. The environment's side is :mod:`pyrt.lights.compiled_env_preview`.

The glTF occlusion ``k = 1 + strength (occ - 1)`` the split sum multiplies by, the specular weight and the dielectric
F0 of its lobes are the hit's inputs (:func:`pyrt.materials.compiled.gltf_inputs`).

:func:`preview_stage` lights the camera hits of a packet (lanes ``[0, n)``, added into the scratch's radiance);
:func:`preview` one hit of the specular tree.
"""
from __future__ import annotations

import math

import numba

from pyrt.integrators import kernel_cache

kernel_cache.use_cache_dir()      # before the decorators below run

from pyrt.integrators.compiled_layout import LANES, V_D, V_L, V_MAT, V_NG, V_NS, lane_inputs, lane_vec  # noqa: E402
from pyrt.lights import compiled_env as CE  # noqa: E402
from pyrt.lights import compiled_env_preview as CP  # noqa: E402
from pyrt.materials import compiled as MC  # noqa: E402
from pyrt.materials import compiled_sampling as CS  # noqa: E402
from pyrt.shaders import jit_preview as JP  # noqa: E402

_own = numba.njit(nogil=True, cache=True, error_model="numpy")


@_own
def split_sum(etag, erec, edata, mtag, mpars, m, albedo, ns, wo):
    """The split sum at a hit of a METALLIC_ROUGHNESS or GLTF material (module docstring): RGB."""
    b = m * MC.RECORD
    occ = 1.0
    if mtag == MC.METALLIC_ROUGHNESS:
        br, bg, bb, metal, rough = mpars[b + 4], mpars[b + 5], mpars[b + 6], mpars[b + 7], mpars[b + 8]
        geometry, model = int(mpars[b + 9]), 0.0
    else:
        br, bg, bb, metal, rough = albedo[3], albedo[4], albedo[5], albedo[6], albedo[7]
        geometry, model = int(mpars[b + 19]), mpars[b + 18]
        occ = albedo[8]
    alpha = rough * rough
    mu = JP.view_cosine(wo, ns)
    e5 = CP.diffuse_loss(erec, edata, mu)
    a, bt = CP.specular_ab(erec, edata, geometry, mu, alpha)
    if model == 0.0:
        dif, spec = JP.metallic_roughness_lobes(br, bg, bb, metal, e5, a, bt)
    else:
        t = mpars[b + MC.TRANSMISSION + 1]        # a smooth transmitting GltfPBR's (0: opaque)
        dif, spec = JP.gltf_pbr_lobes(br, bg, bb, metal, albedo[9], albedo[10], albedo[11], albedo[12], t, 1.0 - t,
                                      e5, a, bt)
    e = CP.irradiance_sh(erec, edata, ns[0], ns[1], ns[2])
    d = JP.dominant_direction(wo, ns, alpha)
    p = CP.prefiltered(etag, erec, edata, d[0], d[1], d[2], alpha)
    r = dif[0] / math.pi * e[0] + spec[0] * p[0]
    g = dif[1] / math.pi * e[1] + spec[1] * p[1]
    bl = dif[2] / math.pi * e[2] + spec[2] * p[2]
    if MC.is_coated(mtag, mpars, m):
        r, g, bl = coat_split_sum(etag, erec, edata, mpars, b, albedo, ns, wo, (r, g, bl))
    if mtag == MC.GLTF:          # the occlusion (1 without one: exact)
        return r * occ, g * occ, bl * occ
    return r, g, bl


@_own
def coat_split_sum(etag, erec, edata, mpars, b, albedo, ns, wo, base):
    """:meth:`pyrt.Clearcoat.preview_lobes` over the base's split sum ``base`` (RGB) at a hit of the coated GLTF record
    at ``mpars[b:]``: ``base (1 - c F_c) + c F_c (A + B) prefiltered`` of the coat's GGX lobe (height-correlated
    Smith) about the coat's normal ``n_c`` (its inputs, in the frame of ``ns``; ``F_c`` at ``|n_c.wo|``, the tables at
    ``mu = n_c.wo`` clamped)."""
    fs, ft = CS.coordinate_frame(ns[0], ns[1], ns[2])
    nc = CS.to_world((albedo[15], albedo[16], albedo[17]), fs, ft, ns)
    cw = CS.coat_weight(mpars, b, albedo, wo[0] * nc[0] + wo[1] * nc[1] + wo[2] * nc[2])
    alpha = albedo[14]
    a, bt = CP.specular_ab(erec, edata, 0, JP.view_cosine(wo, nc), alpha)
    d = JP.dominant_direction(wo, nc, alpha)
    p = CP.prefiltered(etag, erec, edata, d[0], d[1], d[2], alpha)
    k, w = 1.0 - cw, cw * (a + bt)
    return base[0] * k + w * p[0], base[1] * k + w * p[1], base[2] * k + w * p[2]


@_own
def sampled(etag, erec, edata, mtag, mpars, m, albedo, ng, ns, wo):
    """The mean of ``preview_samples`` Hammersley BSDF samples' ``weight x prefiltered(wi, alpha)`` (samples with
    ``wi . ng > 0`` and a positive pdf; ``alpha`` the GGX width of the sample's solid angle ``1 / (K pdf)``)."""
    k_n = int(erec[CE.R_PK])
    fs, ft = CS.coordinate_frame(ns[0], ns[1], ns[2])
    wol = CS.to_local(wo, fs, ft, ns)
    a0 = a1 = a2 = 0.0
    for k in range(k_n):
        u0, u1 = CP.hammersley_point(erec, edata, k)
        x, y, z, w_r, w_g, w_b, pdf = CS.sample_f(mtag, mpars, m, albedo, wol[0], wol[1], wol[2], u0, u1)
        wi = CS.to_world((x, y, z), fs, ft, ns)
        cos_g = wi[0] * ng[0] + wi[1] * ng[1] + wi[2] * ng[2]
        if cos_g > 0.0 and pdf > 0.0:
            alpha = JP.ggx_lobe_alpha_for_solid_angle(1.0 / (k_n * pdf))
            p = CP.prefiltered(etag, erec, edata, wi[0], wi[1], wi[2], alpha)
            a0 += w_r * p[0]
            a1 += w_g * p[1]
            a2 += w_b * p[2]
    return a0 / k_n, a1 / k_n, a2 / k_n


@_own
def preview(etag, erec, edata, mtag, mpars, m, albedo, ng, ns, wo):
    """The preview's environment light (RGB) at one hit of material ``m`` (a material with a non-delta lobe),
    ``albedo`` its inputs (:func:`pyrt.materials.compiled.albedo_at`), ``ng`` the geometric normal toward the viewer,
    ``ns`` the shading normal, ``wo`` toward the viewer."""
    if mtag == MC.LAMBERT:
        e = CP.irradiance_sh(erec, edata, ns[0], ns[1], ns[2])
        return albedo[0] / math.pi * e[0], albedo[1] / math.pi * e[1], albedo[2] / math.pi * e[2]
    if erec[CE.R_PREVIEW] == CP.SPLIT_SUM and (mtag == MC.METALLIC_ROUGHNESS or mtag == MC.GLTF):
        return split_sum(etag, erec, edata, mtag, mpars, m, albedo, ns, wo)
    return sampled(etag, erec, edata, mtag, mpars, m, albedo, ng, ns, wo)


@_own
def preview_stage(etag, erec, edata, mats_tag, mats_par, V, n):
    """:func:`preview` at the camera hits of the packet's lanes ``[0, n)`` (lanes that missed or whose material has
    no non-delta lobe are skipped), added into their radiance :data:`pyrt.integrators.compiled_layout.V_L`."""
    for lane in range(n):
        m = int(V[V_MAT * LANES + lane])
        if m < 0 or not MC.has_diffuse(mats_tag[m]):
            continue
        d = lane_vec(V, V_D, lane)
        val = preview(etag, erec, edata, mats_tag[m], mats_par, m, lane_inputs(V, lane), lane_vec(V, V_NG, lane),
                      lane_vec(V, V_NS, lane), (-d[0], -d[1], -d[2]))
        for c in range(3):
            V[(V_L + c) * LANES + lane] += val[c]


kernel_cache.restore()
