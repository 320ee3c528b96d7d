"""The surface stage of the compiled tile kernel (:mod:`pyrt.integrators.compiled_kernel`) for a packet whose camera
rays all hit one triangle, the common case (a packet holds one pixel's samples): that triangle's data read once,
the lanes' surfaces in one loop that LLVM vectorises.

:func:`uniform_surface` is :func:`pyrt.shaders.jit.hit_surface` (the scalar form, used for the other packets and by
the specular tree's single rays) with the triangle's loads hoisted and selects for its branches: the same operations
in the same order, the same bits (tests/test_compiled_surface.py). Why: the kernel's per-lane loops are bound by
their stores (a scalar loop stores ~20 values a lane into the packet scratch; measured, on-CPU samples: fewer
stores per lane, -15 % of the kernel's time); here each field of 8 lanes is one vector store. A stage that
gathered every lane's own triangle instead was no faster than the scalar loop (its ~36 gathers a lane cost what
the stores saved).
"""
from __future__ import annotations

import math

import numpy as np

from pyrt.integrators import kernel_cache

kernel_cache.use_cache_dir()      # before the decorators below run

from pyrt.core import unmanaged as U  # noqa: E402
from pyrt.geometry import embree_jit as E  # noqa: E402
from pyrt.integrators.compiled_layout import (  # noqa: E402
    LANES, V_D, V_P, V_NG, V_NS, V_NV, V_LIFT, V_MAG, V_MAG_LIFT, V_FRONT, V_MAT, V_A, V_L, V_COSO, V_T, _njit,
    _stage, set_lane_vec)
from pyrt.shaders.jit import EPS32, EPS64, bary3, dot, gamma, row3  # noqa: E402


@_njit
def uniform_face(foff, pk, w, n):
    """The face every lane of the camera packet ``pk`` hit after its query, or -1 (a miss, or two faces)."""
    geom, prim = E.packet_geom_prim(pk, w, 0)
    if geom == -1:
        return -1
    face = foff[geom] + prim
    for lane in range(1, n):
        g, q = E.packet_geom_prim(pk, w, lane)
        if g != geom or q != prim:
            return -1
    return face


@_stage
def uniform_surface(G, face, pk, w, V, n, fallback, terminator, m, albedo, le_front, le_back):
    """The surfaces of lanes ``[0, n)`` of the camera packet ``pk`` (width ``w``), all on face ``face`` of material
    ``m``, their ray directions in the scratch ``V`` at :data:`V_D`: into the scratch what the kernel's scalar loop
    stores for a hit (:func:`pyrt.shaders.jit.hit_surface`'s point, normals, lifted point, magnitudes and side,
    ``ns . wo``, the hit distance, the material, its albedo ``albedo`` (constant over the face) and the emitted
    radiance ``le_front`` / ``le_back`` as the lane sees the front or the back)."""
    U.wide_vectors()
    U.noalias_args()
    verts, normals, _, fnorm, fabs, fext, faces, _, _, fsmooth = G
    g4 = gamma(4.0, EPS64)
    i0, i1, i2 = faces[3 * face], faces[3 * face + 1], faces[3 * face + 2]
    v0, v1, v2 = row3(verts, i0), row3(verts, i1), row3(verts, i2)
    n0_, n1_, n2_ = row3(normals, i0), row3(normals, i1), row3(normals, i2)
    fn = row3(fnorm, face)
    fa = (fabs[3 * face], fabs[3 * face + 1], fabs[3 * face + 2])
    ext = 8.0 * EPS32 * fext[face]
    smooth = fsmooth[face] != 0
    for lane in range(n):
        b1u, b2u = E.packet_uv(pk, w, lane)
        b1, b2 = np.float64(b1u), np.float64(b2u)
        b0 = 1.0 - b1 - b2
        p = bary3(b0, b1, b2, v0, v1, v2)
        wo = (-V[V_D * LANES + lane], -V[(V_D + 1) * LANES + lane], -V[(V_D + 2) * LANES + lane])
        front = dot(fn, wo) >= 0.0
        sign = 1.0 if front else -1.0
        ng = (sign * fn[0], sign * fn[1], sign * fn[2])
        n0, n1, n2 = bary3(b0, b1, b2, n0_, n1_, n2_)
        ln = math.sqrt(n0 * n0 + n1 * n1 + n2 * n2)
        k = sign / ln if ln > 0.0 else 1.0
        n0, n1, n2 = n0 * k, n1 * k, n2 * k
        bad = (n0 * n0 + n1 * n1 + n2 * n2 == 0.0) | (fallback & (n0 * wo[0] + n1 * wo[1] + n2 * wo[2] <= 0.0))
        use = smooth & ~bad
        ns = (n0 if use else ng[0], n1 if use else ng[1], n2 if use else ng[2])
        nv = (n0 if smooth else ng[0], n1 if smooth else ng[1], n2 if smooth else ng[2])
        l0, l1, l2 = p              # Hanika's terminator lift (hit_surface's loop, unrolled)
        for j in range(3):
            vk, nk = (v0, n0_) if j == 0 else ((v1, n1_) if j == 1 else (v2, n2_))
            bk = b0 if j == 0 else (b1 if j == 1 else b2)
            h = sign * ((p[0] - vk[0]) * nk[0] + (p[1] - vk[1]) * nk[1] + (p[2] - vk[2]) * nk[2])
            wk = bk * min(h, 0.0) * sign
            l0 -= nk[0] * wk
            l1 -= nk[1] * wk
            l2 -= nk[2] * wk
        up = smooth & terminator
        lift = (l0 if up else p[0], l1 if up else p[1], l2 if up else p[2])
        mg = 0.0
        ml = 0.0
        for c in range(3):
            mg += abs(ng[c]) * g4 * fa[c]
            ml += abs(ng[c]) * g4 * (fa[c] + abs(lift[c] - p[c]))
        set_lane_vec(V, V_P, lane, p)
        set_lane_vec(V, V_NG, lane, ng)
        set_lane_vec(V, V_NS, lane, ns)
        set_lane_vec(V, V_NV, lane, nv)
        set_lane_vec(V, V_LIFT, lane, lift)
        set_lane_vec(V, V_A, lane, albedo)
        set_lane_vec(V, V_L, lane, (le_front[0] if front else le_back[0], le_front[1] if front else le_back[1],
                                    le_front[2] if front else le_back[2]))
        V[V_MAG * LANES + lane] = mg + ext
        V[V_MAG_LIFT * LANES + lane] = ml + ext
        V[V_FRONT * LANES + lane] = 1.0 if front else 0.0
        V[V_MAT * LANES + lane] = m
        V[V_COSO * LANES + lane] = dot(wo, ns)
        V[V_T * LANES + lane] = np.float64(E.packet_tfar(pk, w, lane))


kernel_cache.restore()
