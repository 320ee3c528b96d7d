"""Coverage on the compiled path: back-face culling and alpha masks, :mod:`pyrt.integrators.coverage` for the camera
packets, the specular tree's single rays and the shadow rays of :mod:`pyrt.integrators.compiled_kernel`.

A material record says what camera and secondary rays skip (:data:`pyrt.materials.compiled.COVER`):

- culled (:attr:`pyrt.materials.Material.culls_back_faces`: ``double_sided`` False, not a dielectric or transmitting
  material): a hit whose winding normal faces away from the ray (``fn . d > 0``);
- mask (``alpha_mode="mask"``): a hit where the coverage alpha ``a`` (a constant, or a factor times a nearest or
  bilinear image texture at the hit's uv: no footprint) is below ``alpha_cutoff``.

A skipped hit is re-traced from the hit point pushed through the surface by the ``robust`` offset
(:func:`pyrt.geometry.offsets.local_bound`: the flat point's local error bound along the viewer-side ng, toward the
ray's side, rounded outward to float32), direction kept, ``t`` still measured from the ray's first origin (the depth
AOV). After ``opts[O_LAYERS]`` (:data:`pyrt.integrators.coverage.MAX_LAYERS`) skipped surfaces a ray is dropped
(radiance 0, no AOV), as on the NumPy path: with culling alone (``cull_hits``) when it meets one more surface to skip,
with masks (``resolve``) when it meets one more surface of a culled or masked material. Shadow rays pass mask
surfaces where ``a < alpha_cutoff`` (:func:`pyrt.integrators.shadows.transmittance`): a ray the occlusion query
reports blocked is re-traced as closest hits through them, at most that many; both sides of a culled surface block.
The re-traced rays count as secondary (camera and specular rays) or shadow rays, as the NumPy path counts them.

Nothing here runs unless ``opts[O_COVER]`` is set (1: culling only, 2: masks too).
"""
from __future__ import annotations

import numba
import numpy as np

from pyrt.integrators import kernel_cache

kernel_cache.use_cache_dir()      # before the decorators below run

from pyrt.geometry import embree_jit as E  # noqa: E402
from pyrt.integrators.compiled_layout import (  # noqa: E402
    LANES, V_D, V_L, V_LIT, V_SO, V_T, V_TB, V_TMAX, V_WI, T_INF, C_POS, _njit, lane_vec, set_lane_vec)
from pyrt.materials import compiled as MC  # noqa: E402
from pyrt.shaders.jit import EPS32, EPS64, bary3, dot, gamma, round_away, row3  # noqa: E402
from pyrt.textures.compiled import texture_rgb  # noqa: E402

#: ``opts[O_COVER]``: some material culls back faces (and none is masked); some material is masked
CULL_ONLY, MASKS = 1, 2


@_njit
def opacity(G, mats_par, tex_tag, tex_par, face, b0, b1, b2):
    """The coverage alpha of the hit with barycentrics ``(b0, b1, b2)`` on face ``face`` (its material's
    :data:`pyrt.materials.compiled.MASK` scalar slot at the hit's uv, no footprint; clipped to [0, 1], as
    :meth:`pyrt.materials.Material.coverage`)."""
    uvs, faces, fmat = G[2], G[6], G[8]
    b = fmat[face] * MC.RECORD + MC.MASK + 2
    if mats_par[b] < 0.0:
        a = mats_par[b + 1]
    else:
        i0, i1, i2 = faces[3 * face], faces[3 * face + 1], faces[3 * face + 2]
        u = b0 * uvs[2 * i0] + b1 * uvs[2 * i1] + b2 * uvs[2 * i2]
        v = b0 * uvs[2 * i0 + 1] + b1 * uvs[2 * i1 + 1] + b2 * uvs[2 * i2 + 1]
        a = MC.slot_scalar(mats_par, b, texture_rgb(tex_tag, tex_par, int(mats_par[b]), u, v, (0.0, 0.0, 0.0, 0.0)))
    return min(max(a, 0.0), 1.0)


@_njit
def through(G, face, b0, b1, b2, fn, side_ref):
    """The origin (a 3-tuple) of a ray continued past face ``face`` at barycentrics ``(b0, b1, b2)``: the hit point
    rebuilt as :func:`pyrt.shaders.jit.hit_surface` rebuilds it, pushed by its offset magnitude along the ng that
    faces ``-side_ref`` (the ray's direction: the viewer's side), to the side ``side_ref`` goes
    (:func:`pyrt.geometry.offsets.local_bound`: :func:`pyrt.shaders.jit.round_away`)."""
    verts, fabs, fext, faces = G[0], G[4], G[5], G[6]
    i0, i1, i2 = faces[3 * face], faces[3 * face + 1], faces[3 * face + 2]
    p = bary3(b0, b1, b2, row3(verts, i0), row3(verts, i1), row3(verts, i2))
    sign = 1.0 if -dot(fn, side_ref) >= 0.0 else -1.0
    ng = (sign * fn[0], sign * fn[1], sign * fn[2])
    g4 = gamma(4.0, EPS64)
    m = 0.0
    for c in range(3):
        m += abs(ng[c]) * g4 * fabs[3 * face + c]
    mag = m + 8.0 * EPS32 * fext[face]
    return round_away(p, mag, 1.0 if dot(side_ref, ng) >= 0.0 else -1.0, ng)


@_njit
def skipped(G, mats_par, tex_tag, tex_par, geom, prim, u, v, d, masks):
    """``(active, skip, origin)`` for the hit ``(geom, prim, u, v)`` of a ray along ``d``: whether its material culls
    or masks (``active``), whether the ray skips it (a culled back face; with ``masks``, a mask texel below the
    cutoff) and then the origin of the ray continued past it (:func:`through`; zeros otherwise)."""
    fnorm, foff, fmat = G[3], G[7], G[8]
    face = foff[geom] + prim
    rb = fmat[face] * MC.RECORD
    cull = mats_par[rb + MC.CULL] != 0.0
    mask = masks and mats_par[rb + MC.MASK] != 0.0
    none = (0.0, 0.0, 0.0)
    if not (cull or mask):
        return False, False, none
    fn = row3(fnorm, face)
    b1, b2 = np.float64(u), np.float64(v)
    b0 = 1.0 - b1 - b2
    skip = cull and dot(fn, d) > 0.0
    if not skip and mask:
        skip = opacity(G, mats_par, tex_tag, tex_par, face, b0, b1, b2) < mats_par[rb + MC.MASK + 1]
    if not skip:
        return True, False, none
    return True, True, through(G, face, b0, b1, b2, fn, d)


@numba.njit(nogil=True, cache=True, error_model="numpy")
def cover_packet(scene, G, mats_par, tex_tag, tex_par, cam, pk, w, V, n, layers, masks):
    """Skip the surfaces the camera packet ``pk`` (width ``w``, lanes ``[0, n)``, directions at :data:`V_D` of the
    scratch ``V``) hit after its query and does not see (:func:`skipped`): the lanes on one are re-traced together
    (an incoherent packet query of those lanes alone) until none is; the packet's hit fields then hold each lane's
    nearest kept surface (a dropped lane: a miss). :data:`V_TB` gets each lane's distance from the camera to its last
    re-trace origin along ``d`` (0: not re-traced; -1: dropped; :func:`cover_finish` uses it). A lane is dropped at
    its ``layers + 1``-th surface to skip, or with ``masks`` at its ``layers + 1``-th surface of a culled or masked
    material (:meth:`pyrt.integrators.coverage.CoverageTable.resolve`). The lanes' origins are put back to the
    camera's (``cam``'s record) and lanes ``[0, n)`` activated again. Returns the number of re-traced rays."""
    cx, cy, cz = cam[C_POS], cam[C_POS + 1], cam[C_POS + 2]
    for lane in range(n):
        V[V_TB * LANES + lane] = 0.0
    n_re = 0
    for layer in range(layers + 1):
        k = 0
        for lane in range(n):
            geom, prim = E.packet_geom_prim(pk, w, lane)
            again = False
            if geom != -1:
                u, v = E.packet_uv(pk, w, lane)
                d = lane_vec(V, V_D, lane)
                active, skip, o = skipped(G, mats_par, tex_tag, tex_par, geom, prim, u, v, d, masks)
                if layer == layers and (skip or (masks and active)):      # one surface too many: dropped
                    E.packet_set_dir(pk, w, lane, d[0], d[1], d[2], T_INF)
                    V[V_TB * LANES + lane] = -1.0
                elif skip:
                    E.packet_set_dir(pk, w, lane, d[0], d[1], d[2], T_INF)      # a miss until its query
                    E.packet_set_origin(pk, w, lane, o[0], o[1], o[2])
                    V[V_TB * LANES + lane] = (o[0] - cx) * d[0] + (o[1] - cy) * d[1] + (o[2] - cz) * d[2]
                    again = True
                    k += 1
            E.packet_set_active(pk, w, lane, again)
        if k == 0:
            break
        E.packet_query(scene, pk, w, False, False)
        n_re += k
    if n_re > 0:
        for lane in range(n):
            E.packet_set_origin(pk, w, lane, cx, cy, cz)
    E.packet_activate(pk, w, n)
    return n_re


@_njit
def cover_finish(V, n):
    """After the surface stage of a packet that went through :func:`cover_packet`: the dropped lanes' radiance 0
    (not the background), and the re-traced lanes' hit distance :data:`V_T` counted from the camera."""
    for lane in range(n):
        tb = V[V_TB * LANES + lane]
        if tb < 0.0:
            set_lane_vec(V, V_L, lane, (0.0, 0.0, 0.0))
        else:
            V[V_T * LANES + lane] += tb


@_njit
def cover_single(scene, G, mats_par, tex_tag, tex_par, layers, masks, hit, prim, geom, u, v, d, ray_buf):
    """:func:`cover_packet` for one ray along ``d`` whose query answered ``(hit, prim, geom, u, v)``
    (:func:`pyrt.geometry.embree_jit.intersect1`): its nearest kept surface ``(hit, prim, geom, u, v, dropped,
    re-traced rays)``."""
    n_re = 0
    while hit:
        active, skip, o = skipped(G, mats_par, tex_tag, tex_par, geom, prim, u, v, d, masks)
        if n_re == layers and (skip or (masks and active)):
            return False, prim, geom, u, v, True, n_re
        if not skip:
            break
        n_re += 1
        hit, _, prim, geom, u, v, _, _, _ = E.intersect1(scene, o[0], o[1], o[2], d[0], d[1], d[2], 0.0, T_INF,
                                                         ray_buf)
    return hit, prim, geom, u, v, False, n_re


@_njit
def shadow_walk(scene, G, mats_par, tex_tag, tex_par, layers, o, wi, tmax, ray_buf):
    """Whether a shadow ray ``o + t wi``, ``0 < t < tmax``, that the occlusion query found blocked is blocked
    (:func:`pyrt.integrators.shadows.transmittance` with masks only): closest hits from ``o``; a mask texel below
    the cutoff is crossed (the origin pushed past it to the light's side, ``tmax`` shortened to the same end point),
    anything else blocks; blocked after ``layers + 1`` queries. Returns ``(blocked, queries)``."""
    fnorm, foff, fmat = G[3], G[7], G[8]
    ox, oy, oz = o
    for k in range(layers + 1):
        hit, _, prim, geom, u, v, _, _, _ = E.intersect1(scene, ox, oy, oz, wi[0], wi[1], wi[2], 0.0, tmax, ray_buf)
        if not hit:
            return False, k + 1
        face = foff[geom] + prim
        rb = fmat[face] * MC.RECORD
        if mats_par[rb + MC.MASK] == 0.0:
            return True, k + 1
        b1, b2 = np.float64(u), np.float64(v)
        b0 = 1.0 - b1 - b2
        if not opacity(G, mats_par, tex_tag, tex_par, face, b0, b1, b2) < mats_par[rb + MC.MASK + 1]:
            return True, k + 1
        nx, ny, nz = through(G, face, b0, b1, b2, row3(fnorm, face), wi)
        tmax = max(tmax - ((nx - ox) * wi[0] + (ny - oy) * wi[1] + (nz - oz) * wi[2]), 0.0)
        ox, oy, oz = nx, ny, nz
    return True, layers + 1


@numba.njit(nogil=True, cache=True, error_model="numpy")
def mask_shadows(scene, G, mats_par, tex_tag, tex_par, sh, w, V, n, layers, ray_buf):
    """After a shadow packet's occlusion query in a scene with masks: each traced lane (:data:`V_LIT`) that it
    found blocked walked through the mask cut-outs (:func:`shadow_walk`, its ray from :data:`V_SO`, :data:`V_WI`,
    :data:`V_TMAX`); a lane that gets through is marked unblocked in ``sh``. Returns the closest-hit queries."""
    n_q = 0
    for lane in range(n):
        if V[V_LIT * LANES + lane] == 0.0 or not E.lane_blocked(sh, w, lane):
            continue
        wi = lane_vec(V, V_WI, lane)
        blocked, k = shadow_walk(scene, G, mats_par, tex_tag, tex_par, layers, lane_vec(V, V_SO, lane), wi,
                                 V[V_TMAX * LANES + lane], ray_buf)
        n_q += k
        if not blocked:
            E.packet_set_dir(sh, w, lane, wi[0], wi[1], wi[2], V[V_TMAX * LANES + lane])
    return n_q


kernel_cache.restore()
