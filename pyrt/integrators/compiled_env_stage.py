"""The environment light's light samples for a whole packet, as two vectorised stages over its lanes.

:func:`pyrt.integrators.compiled_lighting.env_stage` draws one sample per lane. Lane by lane, a light sample of a
lat-long map (:func:`pyrt.lights.compiled_env.mis_sample_uv`) is a chain of branches, table searches and libm calls
that runs scalar. Here the same numbers come from two stages over the packet's 16 lanes, each its own LLVM function
whose pointer arguments are ``noalias`` and whose vectors are 512-bit (:func:`pyrt.core.unmanaged.noalias_args`,
``wide_vectors``), so that LLVM vectorises them:

- :func:`light_cells`: the table cells of every lane, by fixed-step binary searches run in lockstep (one gather per
  step for all lanes; the same comparisons as :func:`pyrt.lights.compiled_tables._find`, so the same cells), their
  in-cell offsets, the four corner luminances and the cell's ``func``;
- :func:`light_directions`: the bilinear warps, the density, the direction (:func:`pyrt.lights.compiled_env.sincos`,
  branch-free) and its lat-long coordinates: :func:`pyrt.lights.compiled_env.sample_table_uv`'s arithmetic, operation
  for operation.

The results are :func:`~pyrt.lights.compiled_env.mis_sample_uv`'s bit for bit (tests/test_compiled_stages.py). The
stages serve the bilinear lat-long map whose sampled table has a positive integral (:func:`packet_sampling`); other
environments keep the per-lane code. Measured in isolation (tools/experiments/env_soa_prototype.py, AMD EPYC, one
thread): 189 ns per light sample lane by lane against 73.5 as vectorised stages.
"""
from __future__ import annotations

import math

from pyrt.integrators import kernel_cache

kernel_cache.use_cache_dir()      # before the decorators below run

from pyrt.core import unmanaged as U  # noqa: E402
from pyrt.integrators.compiled_layout import (  # noqa: E402
    LANES, V_ECELL, V_ECORNER, V_EFF, V_EFN, V_ELOC, V_EPDF, V_EU, V_EUV, V_EWI, _njit, _stage)
from pyrt.lights import compiled_env as CE  # noqa: E402
from pyrt.lights.compiled_tables import BELOW_ONE  # noqa: E402


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
    # the marginal: the largest row whose cdf <= u1 (0 if none), every lane one step at a time
    step = _top(rows)
    while step >= 1:
        for lane in range(LANES):
            k = int(V[V_ECELL * LANES + lane]) + step
            ok = (k < rows) & (edata[o_marg + min(k, rows - 1)] + 0.0 <= V[(V_EU + 1) * LANES + lane] + 0.0)
            V[V_ECELL * LANES + lane] = float(k) if ok else V[V_ECELL * LANES + lane]
        step >>= 1
    # the row's conditional CDF, compared shifted by the row's index as the NumPy path compares it
    step = _top(w)
    while step >= 1:
        for lane in range(LANES):
            row = V[V_ECELL * LANES + lane]
            oc = o_cond + int(row) * (w + 1)
            k = int(V[(V_ECELL + 1) * LANES + lane]) + step
            ok = (k < w) & (edata[oc + min(k, w - 1)] + row <= V[V_EU * LANES + lane] + row)
            V[(V_ECELL + 1) * LANES + lane] = float(k) if ok else V[(V_ECELL + 1) * LANES + lane]
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


kernel_cache.restore()
