"""The environment light's light samples for a whole packet, as two vectorised stages over its lanes.

:func:`pyrt.integrators.compiled_lighting.env_stage` draws one sample per lane. Lane by lane, a light sample of a
lat-long map (:func:`pyrt.lights.compiled_env.mis_sample_uv`) is a chain of branches, table searches and libm calls
that runs scalar. Here the same numbers come from two stages over the packet's 16 lanes, each its own LLVM function
whose pointer arguments are ``noalias`` and whose vectors are 512-bit (:func:`pyrt.core.unmanaged.noalias_args`,
``wide_vectors``), so that LLVM vectorises them:

- :func:`light_cells`: the table cells of every lane, by fixed-step binary searches run in lockstep (one gather per
  step for all lanes; the same comparisons as :func:`pyrt.lights.compiled_tables._find`, so the same cells), their
  in-cell offsets, the four corner luminances and the cell's ``func``;
- :func:`light_directions`: the bilinear warps, the density, the direction (:func:`pyrt.shaders.jit_math.sincos`,
  branch-free) and its lat-long coordinates: :func:`pyrt.lights.compiled_env.sample_table_uv`'s arithmetic, operation
  for operation.

The results are :func:`~pyrt.lights.compiled_env.mis_sample_uv`'s bit for bit (tests/test_compiled_stages.py). The
stages serve the bilinear lat-long map whose sampled table has a positive integral (:func:`packet_sampling`); other
environments keep the per-lane code.

A packet whose hits are all Lambert (or misses) has the rest of its environment samples vectorised too:
:func:`lambert_bsdf_directions` (the BSDF technique's cosine-hemisphere directions, their densities and lat-long
coordinates) and :func:`lambert_values` (either technique's radiance lookup, MIS weight, value and shadow ray):
:func:`pyrt.integrators.compiled_lighting.env_direction` and ``env_value``'s arithmetic for a Lambert hit, the same
bits (their sines, arc tangents and arc cosines are :mod:`pyrt.shaders.jit_math`'s in both). Measured in isolation (tools/experiments/env_soa_prototype.py, AMD EPYC, one
thread): 189 ns per light sample lane by lane against 73.5 as vectorised stages.
"""
from __future__ import annotations

import math

import numpy as np

from pyrt.integrators import kernel_cache

kernel_cache.use_cache_dir()      # before the decorators below run

from pyrt.core import unmanaged as U  # noqa: E402
from pyrt.integrators.compiled_layout import (  # noqa: E402
    LANES, T_INF, V_A, V_D, V_ECELL, V_ECORNER, V_EFF, V_EFN, V_ELOC, V_EOK, V_EPDF, V_EU, V_EUV, V_EW, V_EWI, V_F,
    V_LIFT, V_LIT, V_MAG, V_MAG_LIFT, V_MAT, V_NG, V_NS, V_NV, V_P, V_SO, V_TMAX, V_WI, _njit, _stage, lane_vec,
    padded_numbers, set_lane_vec)
from pyrt.geometry import embree_jit as E  # noqa: E402
from pyrt.lights import compiled_env as CE  # noqa: E402
from pyrt.lights.compiled_tables import BELOW_ONE  # noqa: E402
from pyrt.materials import compiled as MC  # noqa: E402
from pyrt.materials import compiled_sampling as CS  # noqa: E402
from pyrt.shaders import jit as J  # noqa: E402
from pyrt.shaders.jit_preview import bilinear_latlong, latlong_dir_to_uv  # noqa: E402


@_njit
def packet_sampling(etag, erec):
    """``(o, integral)`` of the table the light technique samples (:func:`pyrt.lights.compiled_env.mis_sample`)
    when the stages serve it (a bilinear lat-long map, a table with a positive integral), else ``(-1, 0.0)``."""
    if etag != CE.LATLONG_BILINEAR:
        return -1, 0.0
    if erec[CE.R_COMPENSATE] == 0.0:
        o, integral = int(erec[CE.R_TABLE]), erec[CE.R_INTEGRAL]
    elif erec[CE.R_HAS_C] != 0.0:
        o, integral = int(erec[CE.R_C_TABLE]), erec[CE.R_C_INTEGRAL]
    else:
        return -1, 0.0
    if not integral > 0.0:
        return -1, 0.0
    return o, integral


@_njit
def _top(n):
    """The largest power of two below ``n`` (1 for ``n`` <= 2): the first step of a fixed-step search of ``n``
    cells, whose steps then reach every cell."""
    top = 1
    while 2 * top < n:
        top *= 2
    return top


@_stage
def light_cells(erec, edata, V, o):
    """Stage 1 for the 16 lanes of the scratch ``V``: from the sample numbers at :data:`V_EU`, the cell (row,
    column) of the table at ``edata[o:]`` into :data:`V_ECELL`, the in-cell offsets ``(fu, fv)`` into
    :data:`V_EFF`, the cell's corner luminances into :data:`V_ECORNER` and its ``func`` into :data:`V_EFN`
    (:func:`pyrt.lights.compiled_tables.sample_cells` and the corners of :func:`pyrt.lights.compiled_env.
    sample_table`)."""
    U.wide_vectors()
    U.noalias_args()
    h, w, rows = int(erec[CE.R_H]), int(erec[CE.R_W]), int(erec[CE.R_ROWS])
    o_cond = o + rows * w
    o_marg = o_cond + rows * (w + 1)
    o_lum = int(erec[CE.R_LUM])
    for lane in range(LANES):
        V[V_ECELL * LANES + lane] = 0.0
        V[(V_ECELL + 1) * LANES + lane] = 0.0
    # the marginal: the largest row whose cdf <= u1 (0 if none), every lane one step at a time. A lane that moves
    # adds the step to its (integral) cell, one that does not adds 0: a store in every lane (written against masked
    # stores, vmaskmovpd, slow on AMD's AVX2 CPUs; measured on the sky scene: no change, docs/compiled.md)
    step = _top(rows)
    while step >= 1:
        for lane in range(LANES):
            k = int(V[V_ECELL * LANES + lane]) + step
            ok = (k < rows) & (edata[o_marg + min(k, rows - 1)] + 0.0 <= V[(V_EU + 1) * LANES + lane] + 0.0)
            V[V_ECELL * LANES + lane] += float(step) if ok else 0.0
        step >>= 1
    # the row's conditional CDF, compared shifted by the row's index as the NumPy path compares it
    step = _top(w)
    while step >= 1:
        for lane in range(LANES):
            row = V[V_ECELL * LANES + lane]
            oc = o_cond + int(row) * (w + 1)
            k = int(V[(V_ECELL + 1) * LANES + lane]) + step
            ok = (k < w) & (edata[oc + min(k, w - 1)] + row <= V[V_EU * LANES + lane] + row)
            V[(V_ECELL + 1) * LANES + lane] += float(step) if ok else 0.0
        step >>= 1
    for lane in range(LANES):
        k, i = int(V[V_ECELL * LANES + lane]), int(V[(V_ECELL + 1) * LANES + lane])
        u0, u1 = V[V_EU * LANES + lane], V[(V_EU + 1) * LANES + lane]
        lo = edata[o_marg + k]
        width = edata[o_marg + k + 1] - lo
        fv = (u1 - lo) / width if width > 0.0 else 0.0
        oc = o_cond + k * (w + 1)
        lo = edata[oc + i]
        width = edata[oc + i + 1] - lo
        fu = (u0 - lo) / width if width > 0.0 else 0.0
        V[V_EFF * LANES + lane] = min(max(fu, 0.0), BELOW_ONE)
        V[(V_EFF + 1) * LANES + lane] = min(max(fv, 0.0), BELOW_ONE)
        top, bottom = min(max(k - 1, 0), h - 1) * w, min(max(k, 0), h - 1) * w
        i1 = i + 1 if i + 1 < w else i + 1 - w
        V[V_ECORNER * LANES + lane] = edata[o_lum + top + i]
        V[(V_ECORNER + 1) * LANES + lane] = edata[o_lum + top + i1]
        V[(V_ECORNER + 2) * LANES + lane] = edata[o_lum + bottom + i]
        V[(V_ECORNER + 3) * LANES + lane] = edata[o_lum + bottom + i1]
        V[V_EFN * LANES + lane] = edata[o + k * w + i]


@_stage
def light_directions(erec, V, integral):
    """Stage 2 for the 16 lanes of ``V``, from :func:`light_cells`' fields: the world direction into
    :data:`V_EWI`, the environment-frame direction into :data:`V_ELOC`, the solid-angle density into
    :data:`V_EPDF` and the lat-long ``(u, v)`` into :data:`V_EUV` (:func:`pyrt.lights.compiled_env.
    sample_table_uv`'s bilinear branch with a positive integral, then ``env_to_world``)."""
    U.wide_vectors()
    U.noalias_args()
    h, w = int(erec[CE.R_H]), int(erec[CE.R_W])
    b = CE.R_ROT
    for lane in range(LANES):
        k, i = int(V[V_ECELL * LANES + lane]), int(V[(V_ECELL + 1) * LANES + lane])
        fu, fv = V[V_EFF * LANES + lane], V[(V_EFF + 1) * LANES + lane]
        ca, cb = V[V_ECORNER * LANES + lane], V[(V_ECORNER + 1) * LANES + lane]
        cc, cd = V[(V_ECORNER + 2) * LANES + lane], V[(V_ECORNER + 3) * LANES + lane]
        v0, v1 = min(max((k - 0.5) / h, 0.0), 1.0), min(max((k + 0.5) / h, 0.0), 1.0)
        t = CE.sample_linear(fv, ca + cb, cc + cd)
        s = CE.sample_linear(fu, (1.0 - t) * ca + t * cc, (1.0 - t) * cb + t * cd)
        area_scale = (h + 1) * (v1 - v0)
        mean = 0.25 * (ca + cb + cc + cd)
        bil = (1.0 - s) * (1.0 - t) * ca + s * (1.0 - t) * cb + (1.0 - s) * t * cc + s * t * cd
        ratio = bil / mean if mean > 0.0 else 0.0
        p = V[V_EFN * LANES + lane] / integral / area_scale * ratio
        u = (i + 0.5 + s) / w
        u = u - math.floor(u)
        v = v0 + t * (v1 - v0)
        x, y, z, st = CE.latlong_uv_to_dir_st(u, v)
        V[V_EPDF * LANES + lane] = p * CE.INV_2PI2 / st if st > 0.0 else 0.0
        V[V_ELOC * LANES + lane] = x
        V[(V_ELOC + 1) * LANES + lane] = y
        V[(V_ELOC + 2) * LANES + lane] = z
        V[V_EWI * LANES + lane] = x * erec[b] + y * erec[b + 1] + z * erec[b + 2]
        V[(V_EWI + 1) * LANES + lane] = x * erec[b + 3] + y * erec[b + 4] + z * erec[b + 5]
        V[(V_EWI + 2) * LANES + lane] = x * erec[b + 6] + y * erec[b + 7] + z * erec[b + 8]
        V[V_EUV * LANES + lane] = u
        V[(V_EUV + 1) * LANES + lane] = v


@_stage
def lambert_bsdf_directions(erec, V):
    """The BSDF technique for the 16 lanes of ``V`` whose hits are Lambert, from the sample numbers at
    :data:`V_EU`: the cosine-hemisphere direction (:func:`pyrt.materials.compiled_sampling.sample_f` of a LAMBERT
    material, in the frame of the shading normal) into :data:`V_EWI`, its weight (the albedo where ``wo`` is above the
    shading horizon and the density positive, else zeros) into :data:`V_EW`, its density into :data:`V_EPDF`, the
    direction in the environment's frame into :data:`V_ELOC`, its lat-long ``(u, v)`` into :data:`V_EUV` and whether
    the sample counts (a hit, a positive density and weight) into :data:`V_EOK`: :func:`pyrt.integrators.
    compiled_lighting.env_direction`'s values for a Lambert hit."""
    U.wide_vectors()
    U.noalias_args()
    for lane in range(LANES):
        ns = lane_vec(V, V_NS, lane)
        d = lane_vec(V, V_D, lane)
        fs, ft = CS.coordinate_frame(ns[0], ns[1], ns[2])
        woz = CS.to_local((-d[0], -d[1], -d[2]), fs, ft, ns)[2]
        x, y, z = CS.square_to_cosine_hemisphere(V[V_EU * LANES + lane], V[(V_EU + 1) * LANES + lane])
        pdf = CS.cosine_hemisphere_pdf(z)
        wi = CS.to_world((x, y, z), fs, ft, ns)
        keep = (woz > 0.0) & (pdf > 0.0)
        a = lane_vec(V, V_A, lane)
        wt = (a[0] if keep else 0.0, a[1] if keep else 0.0, a[2] if keep else 0.0)
        lx, ly, lz = CE.env_to_local(erec, wi[0], wi[1], wi[2])
        u, v = latlong_dir_to_uv(lx, ly, lz)
        set_lane_vec(V, V_EWI, lane, wi)
        set_lane_vec(V, V_EW, lane, wt)
        set_lane_vec(V, V_ELOC, lane, (lx, ly, lz))
        V[V_EPDF * LANES + lane] = pdf
        V[V_EUV * LANES + lane] = u
        V[(V_EUV + 1) * LANES + lane] = v
        ok = (V[V_MAT * LANES + lane] >= 0.0) & (pdf > 0.0) & (max(wt[0], wt[1], wt[2]) > 0.0)
        V[V_EOK * LANES + lane] = 1.0 if ok else 0.0


@_stage
def lambert_values(erec, edata, V, o, integral, bsdf_technique, terminator):
    """Either technique's value for the 16 lanes of ``V`` whose hits are Lambert, after its directions
    (:func:`light_directions` or :func:`lambert_bsdf_directions`; :data:`V_EOK` says which lanes count): the radiance
    at the direction's lat-long ``(u, v)``, the MIS weight (the light's density from the table at ``edata[o:]`` of
    integral ``integral`` for a BSDF sample; the cosine density for a light sample), the value into :data:`V_F` (0
    where no ray is traced),
    whether its shadow ray is traced into :data:`V_LIT` and the ray into :data:`V_SO`, :data:`V_WI`, :data:`V_TMAX`
    (unbounded): :func:`pyrt.integrators.compiled_lighting.env_value`'s arithmetic for a Lambert hit, the same bits."""
    U.wide_vectors()
    U.noalias_args()
    h, w = int(erec[CE.R_H]), int(erec[CE.R_W])
    o_img = int(erec[CE.R_IMAGE])
    f32 = erec[CE.R_F32] != 0.0
    s = erec[CE.R_INTENSITY]
    for lane in range(LANES):
        ok = V[V_EOK * LANES + lane] != 0.0
        u, v = V[V_EUV * LANES + lane], V[(V_EUV + 1) * LANES + lane]
        r, g, b = bilinear_latlong(edata, o_img, h, w, u, v)
        r = np.float64(np.float32(r)) if f32 else r
        g = np.float64(np.float32(g)) if f32 else g
        b = np.float64(np.float32(b)) if f32 else b
        le = (s * r, s * g, s * b)
        wi = lane_vec(V, V_EWI, lane)
        pdf = V[V_EPDF * LANES + lane]
        ns = lane_vec(V, V_NS, lane)
        if bsdf_technique:
            loc = lane_vec(V, V_ELOC, lane)
            p_l = CE.pdf_table_uv(CE.LATLONG_BILINEAR, erec, edata, o, integral, loc[0], loc[1], loc[2], u, v)
            k = CE.mis_weights(erec, p_l, pdf)[1] if ok else 0.0
            wt = lane_vec(V, V_EW, lane)
            val = (wt[0] * le[0] * k, wt[1] * le[1] * k, wt[2] * le[2] * k)
        else:
            ok = ok & (max(le[0], le[1], le[2]) > 0.0)
            d = lane_vec(V, V_D, lane)
            fs, ft = CS.coordinate_frame(ns[0], ns[1], ns[2])
            woz = CS.to_local((-d[0], -d[1], -d[2]), fs, ft, ns)[2]
            wiz = CS.to_local(wi, fs, ft, ns)[2]
            kf = J.upper_cos(woz, wiz) * MC.INV_PI
            a = lane_vec(V, V_A, lane)
            k = CE.mis_weights(erec, pdf, CS.cosine_hemisphere_pdf(wiz))[0] / pdf
            val = (a[0] * kf * le[0] * k, a[1] * kf * le[1] * k, a[2] * kf * le[2] * k)
            val = val if ok else (0.0, 0.0, 0.0)
        ng = lane_vec(V, V_NG, lane)
        cg = J.dot(wi, ng)
        ok = ok & ((cg > 0.0) | (J.dot(wi, lane_vec(V, V_NV, lane)) > 0.0)) & (max(val[0], val[1], val[2]) > 0.0)
        p, lift = lane_vec(V, V_P, lane), lane_vec(V, V_LIFT, lane)
        base = (lift[0] if terminator else p[0], lift[1] if terminator else p[1], lift[2] if terminator else p[2])
        mag = V[V_MAG_LIFT * LANES + lane] if terminator else V[V_MAG * LANES + lane]
        set_lane_vec(V, V_SO, lane, J.round_away_vec(base, mag, 1.0 if (terminator | (cg >= 0.0)) else -1.0, ng))
        set_lane_vec(V, V_WI, lane, wi)
        V[V_TMAX * LANES + lane] = T_INF
        set_lane_vec(V, V_F, lane, (val[0] if ok else 0.0, val[1] if ok else 0.0, val[2] if ok else 0.0))
        V[V_LIT * LANES + lane] = 1.0 if ok else 0.0


@_njit
def lambert_env_stage(erec, edata, V, n, terminator, bsdf_technique, s, count, pair, lane_s, spp, lane_k32, o_table,
                      integral, sh, w):
    """:func:`pyrt.integrators.compiled_lighting.env_stage` for a packet whose hits are all Lambert (or misses) under a lat-long map the packet stages
    sample (table ``o_table`` of integral ``integral``, :func:`packet_sampling`): the same numbers, every step but the
    padded sample numbers and the prefetches a vectorised stage (:func:`light_cells` and :func:`light_directions` or
    :func:`lambert_bsdf_directions`, then :func:`lambert_values` and :func:`shadow_set`). Returns the number of shadow
    rays."""
    padded_numbers(V, V_EU, lane_s, spp, lane_k32, pair, n, s, count)
    if bsdf_technique:
        lambert_bsdf_directions(erec, V)
    else:
        light_cells(erec, edata, V, o_table)
        light_directions(erec, V, integral)
        for lane in range(LANES):
            ok = (V[V_MAT * LANES + lane] >= 0.0) & (V[V_EPDF * LANES + lane] > 0.0)
            V[V_EOK * LANES + lane] = 1.0 if ok else 0.0
    for lane in range(n):
        if V[V_EOK * LANES + lane] != 0.0:
            CE.prefetch_lookup(CE.LATLONG_BILINEAR, erec, edata, V[V_EUV * LANES + lane],
                               V[(V_EUV + 1) * LANES + lane], bsdf_technique)
    lambert_values(erec, edata, V, o_table, integral, bsdf_technique, terminator)
    return shadow_set(V, sh, w, n)


@_stage
def shadow_set(V, sh, w, n):
    """The shadow rays in the scratch (:data:`V_SO`, :data:`V_WI`, :data:`V_TMAX`) into lanes ``[0, n)`` of the
    packet ``sh`` (width ``w``), each switched on where :data:`V_LIT` says; returns how many are on."""
    U.wide_vectors()
    U.noalias_args()
    n_sh = 0
    for lane in range(n):
        o, wi = lane_vec(V, V_SO, lane), lane_vec(V, V_WI, lane)
        E.packet_set_origin(sh, w, lane, o[0], o[1], o[2])
        E.packet_set_dir(sh, w, lane, wi[0], wi[1], wi[2], V[V_TMAX * LANES + lane])
        ok = V[V_LIT * LANES + lane] != 0.0
        E.packet_set_active(sh, w, lane, ok)
        n_sh += ok
    return n_sh


kernel_cache.restore()
