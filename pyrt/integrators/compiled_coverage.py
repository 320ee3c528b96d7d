"""Coverage on the compiled path: back-face culling, alpha masks and blend surfaces,
:mod:`pyrt.integrators.coverage` for the camera packets, the specular tree's single rays and the shadow rays of
:mod:`pyrt.integrators.compiled_kernel`.

A material record says what camera and secondary rays skip or split (:data:`pyrt.materials.compiled.CULL`,
:data:`pyrt.materials.compiled.MASK`):

- culled (:attr:`pyrt.materials.Material.culls_back_faces`: ``double_sided`` False, not a dielectric or transmitting
  material): a hit whose winding normal faces away from the ray (``fn . d > 0``);
- mask (``alpha_mode="mask"``): a hit where the coverage alpha ``a`` is below ``alpha_cutoff``;
- blend (``alpha_mode="blend"``): ``a = 0`` skips the hit, ``a = 1`` is opaque; in between the hit is kept with the
  weight ``a`` and the ray continues past it with the weight ``1 - a``, at the same bounce (:func:`push_through`: a
  row of the specular stack, dropped where its throughput is at most the throughput cutoff): the radiance is
  ``a L_surface + (1 - a) L_behind``, as on the NumPy path. The hit's own share is :data:`V_BW` of a camera lane
  (:func:`cover_packet`) or the weight :func:`cover_single` returns.

``a`` is a constant, or a factor times a channel of an image texture at the hit's uv (:func:`opacity`); a trilinear
(MIP) texture is read at the ray's footprint (:func:`pyrt.integrators.compiled_diffs.uv_footprint` of the ray's offset
rays, which a continuation keeps: offset rays are lines), as the NumPy path filters it like the base colour.

A skipped hit is re-traced from the hit point pushed through the surface by the ``robust`` offset
(:func:`pyrt.geometry.offsets.local_bound`: the flat point's local error bound along the viewer-side ng, toward the
ray's side, rounded outward to float32), direction kept, ``t`` still measured from the ray's first origin (the depth
AOV). After ``opts[O_LAYERS]`` (:data:`pyrt.integrators.coverage.MAX_LAYERS`) skipped or split surfaces a ray is
dropped (radiance 0, no AOV), as on the NumPy path: with culling alone (``cull_hits``) when it meets one more surface
to skip, with masks or blending (``resolve``) when it meets one more surface of a culled, masked or blend material (a
continuation counts the surfaces of the ray it continues). Shadow rays pass mask surfaces where ``a <
alpha_cutoff`` and blend surfaces with the factor ``1 - a`` (:func:`pyrt.integrators.shadows.transmittance`: ``a`` at
the full-resolution texture, shadow rays carry no footprint; the walk through them:
:mod:`pyrt.integrators.compiled_shadows`); both sides of a culled surface block. The re-traced rays count as
secondary (camera and specular rays) or shadow rays, as the NumPy path counts them.

Nothing here runs unless ``opts[O_COVER]`` is set (1: culling only, 2: masks or blend surfaces too).
"""
from __future__ import annotations

import numba
import numpy as np

from pyrt.integrators import kernel_cache

kernel_cache.use_cache_dir()      # before the decorators below run

from pyrt.geometry import embree_jit as E  # noqa: E402
from pyrt.integrators import compiled_diffs as D  # noqa: E402
from pyrt.integrators.compiled_layout import (  # noqa: E402
    LANES, STACK, STACK_DIFF, STACK_LAYER, STACK_PDF, STACK_ROW, STACK_TB, V_BL, V_BW, V_D, V_L, V_MAG, V_NG, V_P,
    V_RAY, V_T, V_TB, T_INF, C_POS, _njit, lane_vec, set_lane_vec)
from pyrt.materials import compiled as MC  # noqa: E402
from pyrt.shaders.jit import EPS32, EPS64, bary3, dot, gamma, round_away, row3  # noqa: E402
from pyrt.textures import compiled as TC  # noqa: E402
from pyrt.textures.compiled import texture_rgb  # noqa: E402

#: ``opts[O_COVER]``: some material culls back faces (and none is masked or blended); some material is masked or
#: blended
CULL_ONLY, MASKS = 1, 2
#: :data:`pyrt.materials.compiled.MASK`'s first field: an alpha mask, a blend surface (0: neither)
MODE_MASK, MODE_BLEND = 1.0, 2.0


@_njit
def opacity(G, mats_par, tex_tag, tex_par, face, b0, b1, b2, V, lane, diffs):
    """The coverage alpha of the hit with barycentrics ``(b0, b1, b2)`` on face ``face`` (its material's
    :data:`pyrt.materials.compiled.MASK` scalar slot at the hit's uv; with ``diffs`` at the footprint of lane
    ``lane``'s ray in ``V``, else at none; clipped to [0, 1], as :meth:`pyrt.materials.Material.coverage`)."""
    verts, uvs, fnorm, faces, fmat = G[0], G[2], G[3], G[6], G[8]
    b = fmat[face] * MC.RECORD + MC.MASK + 2
    if mats_par[b] < 0.0:
        a = mats_par[b + 1]
    else:
        i0, i1, i2 = faces[3 * face], faces[3 * face + 1], faces[3 * face + 2]
        u = b0 * uvs[2 * i0] + b1 * uvs[2 * i1] + b2 * uvs[2 * i2]
        v = b0 * uvs[2 * i0 + 1] + b1 * uvs[2 * i1 + 1] + b2 * uvs[2 * i2 + 1]
        d = TC.NO_DIFFS
        if diffs:
            p = bary3(b0, b1, b2, row3(verts, i0), row3(verts, i1), row3(verts, i2))
            d = D.uv_footprint(G, V, lane, face, p, row3(fnorm, face))
        fp = TC.footprint(d, i0, i1, i2, b0, b1, b2)
        a = MC.slot_scalar(mats_par, b, texture_rgb(tex_tag, tex_par, int(mats_par[b]), u, v, fp))
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
def skipped(G, mats_par, tex_tag, tex_par, geom, prim, u, v, d, masks, V, lane, diffs):
    """``(active, skip, a, origin)`` for the hit ``(geom, prim, u, v)`` of a ray along ``d`` (lane ``lane``'s in ``V``,
    whose offset rays give the opacity's footprint with ``diffs``): whether its material culls, masks or blends
    (``active``), whether the ray skips it (a culled back face; with ``masks``, a mask texel below the cutoff or a
    blend texel of ``a = 0``), the weight of a kept hit (a blend surface's ``a``, else 1) and the origin of the ray
    continued past a skipped hit (:func:`through`; zeros otherwise)."""
    fnorm, foff, fmat = G[3], G[7], G[8]
    face = foff[geom] + prim
    rb = fmat[face] * MC.RECORD
    cull = mats_par[rb + MC.CULL] != 0.0
    mode = mats_par[rb + MC.MASK] if masks else 0.0
    none = (0.0, 0.0, 0.0)
    if not (cull or mode != 0.0):
        return False, False, 1.0, none
    fn = row3(fnorm, face)
    b1, b2 = np.float64(u), np.float64(v)
    b0 = 1.0 - b1 - b2
    skip = cull and dot(fn, d) > 0.0
    a = 1.0
    if not skip and mode != 0.0:
        a = opacity(G, mats_par, tex_tag, tex_par, face, b0, b1, b2, V, lane, diffs)
        if mode == MODE_MASK:
            skip = a < mats_par[rb + MC.MASK + 1]
            a = 1.0
        else:
            skip = not a > 0.0
    if not skip:
        return True, False, a, none
    return True, True, 1.0, through(G, face, b0, b1, b2, fn, d)


@numba.njit(nogil=True, cache=True, error_model="numpy")
def cover_packet(scene, G, mats_par, tex_tag, tex_par, cam, pk, w, V, n, layers, masks, diffs):
    """Skip the surfaces the camera packet ``pk`` (width ``w``, lanes ``[0, n)``, directions at :data:`V_D` of the
    scratch ``V``) hit after its query and does not see (:func:`skipped`): the lanes on one are re-traced together
    (an incoherent packet query of those lanes alone) until none is; the packet's hit fields then hold each lane's
    nearest kept surface (a dropped lane: a miss). :data:`V_TB` gets each lane's distance from the camera to its last
    re-trace origin along ``d`` (0: not re-traced; -1: dropped; :func:`cover_finish` uses it); :data:`V_BW` the kept
    hit's weight (a blend surface's ``a``, else 1) and :data:`V_BL` the layer its continuation starts at
    (:func:`lane_through`). A lane is dropped at its ``layers + 1``-th surface to skip, or with ``masks`` at its
    ``layers + 1``-th surface of a culled, masked or blend material
    (:meth:`pyrt.integrators.coverage.CoverageTable.resolve`). The lanes' origins are put back to the camera's
    (``cam``'s record) and lanes ``[0, n)`` activated again. Returns the number of re-traced rays."""
    cx, cy, cz = cam[C_POS], cam[C_POS + 1], cam[C_POS + 2]
    for lane in range(n):
        V[V_TB * LANES + lane] = 0.0
        V[V_BW * LANES + lane] = 1.0
    n_re = 0
    pending = (1 << n) - 1          # the lanes whose hit is new (every lane, then those just re-traced)
    for layer in range(layers + 1):
        k = 0
        for lane in range(n):
            geom, prim = E.packet_geom_prim(pk, w, lane)
            again = False
            if geom != -1 and (pending >> lane) & 1:
                u, v = E.packet_uv(pk, w, lane)
                d = lane_vec(V, V_D, lane)
                active, skip, a, o = skipped(G, mats_par, tex_tag, tex_par, geom, prim, u, v, d, masks, V, lane,
                                             diffs)
                if layer == layers and (skip or (masks and active)):      # one surface too many: dropped
                    E.packet_set_dir(pk, w, lane, d[0], d[1], d[2], T_INF)
                    V[V_TB * LANES + lane] = -1.0
                elif skip:
                    E.packet_set_dir(pk, w, lane, d[0], d[1], d[2], T_INF)      # a miss until its query
                    E.packet_set_origin(pk, w, lane, o[0], o[1], o[2])
                    V[V_TB * LANES + lane] = (o[0] - cx) * d[0] + (o[1] - cy) * d[1] + (o[2] - cz) * d[2]
                    again = True
                    k += 1
                else:
                    V[V_BW * LANES + lane] = a
                    V[V_BL * LANES + lane] = layer + 1.0
            E.packet_set_active(pk, w, lane, again)
            pending = (pending | (1 << lane)) if again else (pending & ~(1 << lane))
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
def cover_single(scene, G, mats_par, tex_tag, tex_par, layers, masks, hit, prim, geom, u, v, d, ray_buf, start, V,
                 lane, diffs):
    """:func:`cover_packet` for one ray along ``d`` (lane ``lane``'s in ``V``: its offset rays with ``diffs``) whose
    query answered ``(hit, prim, geom, u, v)`` (:func:`pyrt.geometry.embree_jit.intersect1`) and which has skipped or
    split ``start`` surfaces before (a blend continuation): its nearest kept surface ``(hit, prim, geom, u, v,
    dropped, re-traced rays, weight)``, the weight a blend surface's ``a`` (else 1)."""
    n_re = 0
    while hit:
        active, skip, a, o = skipped(G, mats_par, tex_tag, tex_par, geom, prim, u, v, d, masks, V, lane, diffs)
        if start + n_re == layers and (skip or (masks and active)):
            return False, prim, geom, u, v, True, n_re, 1.0
        if not skip:
            return hit, prim, geom, u, v, False, n_re, a
        n_re += 1
        hit, _, prim, geom, u, v, _, _, _ = E.intersect1(scene, o[0], o[1], o[2], d[0], d[1], d[2], 0.0, T_INF,
                                                         ray_buf)
    return hit, prim, geom, u, v, False, n_re, 1.0


@_njit
def push_through(stack, top, o, d, thr, depth, pdf, tb, layer, V, lane, diffs):
    """A blend continuation on the stack from row ``top``: the ray along ``d`` from ``o`` past the surface (``tb``
    from the first origin of the ray it continues, ``layer`` surfaces skipped or split so far), throughput ``thr``,
    bounce ``depth``, the density ``pdf`` of the ray it continues (the MIS weight of the emission it reaches), and with
    ``diffs`` that ray's offset rays (lane ``lane``'s :data:`V_RAY`: lines, which a straight continuation keeps).
    Returns the new top."""
    row = STACK_ROW * top
    stack[row], stack[row + 1], stack[row + 2] = o
    stack[row + 3], stack[row + 4], stack[row + 5] = d
    stack[row + 6], stack[row + 7], stack[row + 8] = thr
    stack[row + 9] = depth
    stack[row + STACK_PDF] = pdf
    stack[row + STACK_TB], stack[row + STACK_LAYER] = tb, layer
    if diffs:
        for i in range(12):
            stack[row + STACK_DIFF + i] = V[(V_RAY + i) * LANES + lane]
    return top + 1


@_njit
def split_blend(stack, top, p, ng, mag, o, d, thr, depth, pdf, tb, layer, a, cutoff, V, lane, diffs):
    """At a kept blend hit of weight ``a`` < 1 (point ``p``, viewer-side ``ng``, offset magnitude ``mag``) of the ray
    ``o + t d`` (throughput ``thr``): the continuation past it (:func:`push_through`, from the origin :func:`through`
    gives, throughput ``thr (1 - a)``, dropped at most ``cutoff``); returns ``(top, thr a)``, the hit's own
    throughput."""
    t = (thr[0] * (1.0 - a), thr[1] * (1.0 - a), thr[2] * (1.0 - a))
    if max(t[0], t[1], t[2]) > cutoff and top < STACK:
        oc = round_away(p, mag, 1.0 if dot(d, ng) >= 0.0 else -1.0, ng)
        tb = tb + (oc[0] - o[0]) * d[0] + (oc[1] - o[1]) * d[1] + (oc[2] - o[2]) * d[2]
        top = push_through(stack, top, oc, d, t, depth, pdf, tb, layer, V, lane, diffs)
    return top, (thr[0] * a, thr[1] * a, thr[2] * a)


@_njit
def lane_through(V, lane, cam, stack, top, cutoff, diffs):
    """A camera lane kept on a blend surface (:data:`V_BW` < 1): its continuation past it at bounce 0
    (:func:`split_blend`, from its hit's :data:`V_P`, :data:`V_NG`, :data:`V_MAG`). Returns ``(top, a)``."""
    a = V[V_BW * LANES + lane]
    if not a < 1.0:
        return top, 1.0
    o = (cam[C_POS], cam[C_POS + 1], cam[C_POS + 2])
    top, _ = split_blend(stack, top, lane_vec(V, V_P, lane), lane_vec(V, V_NG, lane), V[V_MAG * LANES + lane], o,
                         lane_vec(V, V_D, lane), (1.0, 1.0, 1.0), 0, 0.0, 0.0, V[V_BL * LANES + lane], a, cutoff, V,
                         lane, diffs)
    return top, a


kernel_cache.restore()
