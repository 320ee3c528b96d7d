"""The surface stage of the compiled tile kernel (:mod:`pyrt.integrators.compiled_kernel`) for a packet whose camera
rays hit at most a few triangles, the common case (a packet holds one pixel's samples): each triangle's data read
once, its lanes' surfaces in one loop that LLVM vectorises, with masked stores.

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
    LANES, V_D, V_P, V_NG, V_NS, V_NV, V_LIFT, V_MAG, V_MAG_LIFT, V_FRONT, V_MAT, V_A, V_L, V_COSO, V_T, F_AMBIENT,
    F_BG, _njit, _stage, lane_vec, set_lane_vec)
from pyrt.lights import compiled_env as CE  # noqa: E402
from pyrt.materials import compiled as MC  # noqa: E402
from pyrt.shaders.jit import EPS32, EPS64, bary3, dot, gamma, row3  # noqa: E402
from pyrt.textures import compiled as TC  # noqa: E402


#: the most triangles a packet may hit for :func:`face_surfaces` (each costs one pass of :func:`uniform_surface`)
MAX_FACES = 3


@_njit
def packet_faces(pk, w, n):
    """The triangles the lanes of the camera packet ``pk`` hit after its query: ``(k, geoms, prims, misses)`` with
    ``k`` of them (``MAX_FACES + 1``: more than :data:`MAX_FACES`), their (geomID, primID) pairs in first-hit
    order (tuples of :data:`MAX_FACES`, -1 beyond ``k``) and the number of lanes that missed."""
    g0 = g1 = g2 = q0 = q1 = q2 = -1
    k = misses = 0
    for lane in range(n):
        g, q = E.packet_geom_prim(pk, w, lane)
        if g == -1:
            misses += 1
        elif not ((g == g0 and q == q0) or (g == g1 and q == q1) or (g == g2 and q == q2)):
            if k == MAX_FACES:
                return MAX_FACES + 1, (g0, g1, g2), (q0, q1, q2), misses
            if k == 0:
                g0, q0 = g, q
            elif k == 1:
                g1, q1 = g, q
            else:
                g2, q2 = g, q
            k += 1
    return k, (g0, g1, g2), (q0, q1, q2), misses


@_njit
def emitted(mtag, mpars, m, albedo, optf, front):
    """Emission and ambient light at a hit of material ``m`` (the Whitted integrator's per-material pass), seen
    from the front (``front``) or the back."""
    return with_ambient(mtag, MC.emission(mtag, mpars, m, front), albedo, optf)


@_njit
def with_ambient(mtag, e, albedo, optf):
    """The emitted radiance ``e`` plus the ambient term ``albedo ambient`` of a material with a non-delta lobe."""
    if MC.has_diffuse(mtag):
        return (e[0] + albedo[0] * optf[F_AMBIENT], e[1] + albedo[1] * optf[F_AMBIENT + 1],
                e[2] + albedo[2] * optf[F_AMBIENT + 2])
    return e


@_njit
def face_surfaces(G, mats_tag, mats_par, tex_tag, tex_par, optf, pk, w, V, n, fallback, terminator, etag, erec,
                  edata):
    """The camera packet's surfaces, albedo, emission and background into the scratch when its lanes hit at most
    :data:`MAX_FACES` triangles, each of a material with a constant albedo: one :func:`uniform_surface` pass per
    triangle (each writing its own lanes), the missed lanes' background or environment radiance. Returns
    ``(done, any_diffuse, all_lambert)``; ``done`` False (nothing written) where the packet needs the per-lane
    loop."""
    k, geoms, prims, misses = packet_faces(pk, w, n)
    if k > MAX_FACES:
        return False, False, False
    foff, fmat = G[7], G[8]
    for j in range(k):
        m = fmat[foff[geoms[j]] + prims[j]]
        if not MC.albedo_constant(mats_tag[m], mats_par, m):
            return False, False, False
    any_diffuse, lambert = False, True
    for j in range(k):
        face = foff[geoms[j]] + prims[j]
        m = fmat[face]
        mtag = mats_tag[m]
        albedo = MC.albedo_at(mtag, mats_par, m, tex_tag, tex_par, 0.0, 0.0, TC.NO_FOOTPRINT, MC.WHITE)
        uniform_surface(G, face, geoms[j], prims[j], k > 1 or misses > 0, pk, w, V, n, fallback, terminator, m,
                        albedo, emitted(mtag, mats_par, m, albedo, optf, True),
                        emitted(mtag, mats_par, m, albedo, optf, False))
        any_diffuse = any_diffuse or MC.has_diffuse(mtag)
        lambert = lambert and mtag == MC.LAMBERT
    for lane in range(n if misses > 0 else 0):
        g, _ = E.packet_geom_prim(pk, w, lane)
        if g == -1:
            d = lane_vec(V, V_D, lane)
            le = CE.missed(etag, erec, edata, d[0], d[1], d[2], True) if etag != 0 else (optf[F_BG], optf[F_BG + 1],
                                                                                       optf[F_BG + 2])
            set_lane_vec(V, V_L, lane, le)
            V[V_MAT * LANES + lane] = -1
            V[V_T * LANES + lane] = math.inf
    return True, any_diffuse, lambert


@_stage
def uniform_surface(G, face, geom, prim, masked, pk, w, V, n, fallback, terminator, m, albedo, le_front, le_back):
    """The surfaces of the lanes in ``[0, n)`` of the camera packet ``pk`` (width ``w``) that hit face ``face``
    (``(geom, prim)`` in Embree's terms; with ``masked`` False every lane did) of material ``m``, their ray
    directions in the scratch ``V`` at :data:`V_D`: into the scratch what the kernel's scalar loop stores for a hit
    (:func:`pyrt.shaders.jit.hit_surface`'s point, normals, lifted point, magnitudes and side, ``ns . wo``, the hit
    distance, the material, its albedo ``albedo`` (constant over the face) and the emitted radiance ``le_front`` /
    ``le_back`` as the lane sees the front or the back). The other lanes' fields are left as they were (masked
    vector stores)."""
    U.wide_vectors()
    U.noalias_args()
    verts, normals, _, fnorm, fabs, fext, faces, _, _, fsmooth, _, _ = G
    g4 = gamma(4.0, EPS64)
    i0, i1, i2 = faces[3 * face], faces[3 * face + 1], faces[3 * face + 2]
    v0, v1, v2 = row3(verts, i0), row3(verts, i1), row3(verts, i2)
    n0_, n1_, n2_ = row3(normals, i0), row3(normals, i1), row3(normals, i2)
    fn = row3(fnorm, face)
    fa = (fabs[3 * face], fabs[3 * face + 1], fabs[3 * face + 2])
    ext = 8.0 * EPS32 * fext[face]
    smooth = fsmooth[face] != 0
    if not masked:
        # every lane hit this face (most packets): plain vector stores. The selects of the other loop compile to
        # masked stores (vmaskmovpd without AVX-512), slow on AMD's AVX2 CPUs (on an AVX2 EPYC ~12 % of the shadowed
        # bench scene's render time, perf); one loop for both, branching on the flag, was if-converted into masked
        # stores for both
        for lane in range(n):
            p, ng, ns, nv, lift, le, mg, ml, fr, cos_o, t = _lane_surface(
                pk, w, lane, V, v0, v1, v2, n0_, n1_, n2_, fn, fa, ext, g4, smooth, fallback, terminator, le_front,
                le_back)
            for c in range(3):
                V[(V_P + c) * LANES + lane] = p[c]
                V[(V_NG + c) * LANES + lane] = ng[c]
                V[(V_NS + c) * LANES + lane] = ns[c]
                V[(V_NV + c) * LANES + lane] = nv[c]
                V[(V_LIFT + c) * LANES + lane] = lift[c]
                V[(V_A + c) * LANES + lane] = albedo[c]
                V[(V_L + c) * LANES + lane] = le[c]
            V[V_MAG * LANES + lane] = mg
            V[V_MAG_LIFT * LANES + lane] = ml
            V[V_FRONT * LANES + lane] = fr
            V[V_MAT * LANES + lane] = m
            V[V_COSO * LANES + lane] = cos_o
            V[V_T * LANES + lane] = t
        return
    for lane in range(n):
        g, q = E.packet_geom_prim(pk, w, lane)
        sel = (g == geom) & (q == prim)
        p, ng, ns, nv, lift, le, mg, ml, fr, cos_o, t = _lane_surface(
            pk, w, lane, V, v0, v1, v2, n0_, n1_, n2_, fn, fa, ext, g4, smooth, fallback, terminator, le_front, le_back)
        # masked stores written out (a helper that Numba inlines, given conditional expressions, lost the front
        # flag's stores: it stayed 0; tests/test_compiled_surface.py)
        for c in range(3):
            i = (V_P + c) * LANES + lane
            V[i] = p[c] if sel else V[i]
            i = (V_NG + c) * LANES + lane
            V[i] = ng[c] if sel else V[i]
            i = (V_NS + c) * LANES + lane
            V[i] = ns[c] if sel else V[i]
            i = (V_NV + c) * LANES + lane
            V[i] = nv[c] if sel else V[i]
            i = (V_LIFT + c) * LANES + lane
            V[i] = lift[c] if sel else V[i]
            i = (V_A + c) * LANES + lane
            V[i] = albedo[c] if sel else V[i]
            i = (V_L + c) * LANES + lane
            V[i] = le[c] if sel else V[i]
        i = V_MAG * LANES + lane
        V[i] = mg if sel else V[i]
        i = V_MAG_LIFT * LANES + lane
        V[i] = ml if sel else V[i]
        i = V_FRONT * LANES + lane
        V[i] = fr if sel else V[i]
        i = V_MAT * LANES + lane
        V[i] = m if sel else V[i]
        i = V_COSO * LANES + lane
        V[i] = cos_o if sel else V[i]
        i = V_T * LANES + lane
        V[i] = t if sel else V[i]


@_njit
def _lane_surface(pk, w, lane, V, v0, v1, v2, n0_, n1_, n2_, fn, fa, ext, g4, smooth, fallback, terminator, le_front,
                  le_back):
    """One lane of :func:`uniform_surface` (inlined by LLVM): ``(p, ng, ns, nv, lift, le, magnitude, lifted
    magnitude, front flag, ns . wo, hit distance)``; no stores."""
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
    le = (le_front[0] if front else le_back[0], le_front[1] if front else le_back[1],
          le_front[2] if front else le_back[2])
    fr = 0.5 * (sign + 1.0)          # the front flag (1.0 or 0.0) without a conditional expression
    return (p, ng, ns, nv, lift, le, mg + ext, ml + ext, fr, dot(wo, ns),
            np.float64(E.packet_tfar(pk, w, lane)))


kernel_cache.restore()
