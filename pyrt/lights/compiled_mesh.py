"""The emissive-mesh light's compiled form: its tables in the light table and its sampling for one shading point.

:class:`pyrt.EmissiveMeshLight` packs its record (tag :data:`pyrt.lights.compiled.MESH`) and a block of float64
tables (:meth:`pyrt.EmissiveMeshLight.compiled_record`); the compiled scene appends the block after the light records
(the same flat array, :func:`pyrt.core.unmanaged.pointer`) and writes where it starts into the record's field
:data:`R_DATA`. Record fields: :data:`R_DATA` the block's start, :data:`R_TRIS` light triangles ``F``,
:data:`R_CLUSTERS` clusters ``K`` (0: ``selection="power"``), :data:`R_MESHES` scene meshes ``M``, :data:`R_LIVE` triangles in clusters
``L``, :data:`pyrt.lights.compiled.AREA_SAMPLES` samples per hit. The block, in order:

=========  ===========================================================================================================
triangles  ``F`` rows of :data:`TRI_W`: vertices ``v0``, ``v1``, ``v2`` (world, float64 as the scene's), unit winding
           normal, area, ``pmf`` (power), the probability inside its cluster (``oriented``), its cluster (-1: none),
           the radiance emitted from its front and from its back (RGB; the material's constant emission with its
           sidedness)
cdf        ``F``: the power CDF (``EmissiveMeshLight``'s own, its last entry 1)
meshes     ``M``: per scene mesh, its first light triangle (-1: not the light's)
clusters   ``K`` rows of :data:`CL_W` (:class:`pyrt.lights.mesh_clusters.ClusterChoice`): ``-2 c``, ``|c|^2``,
           ``r^2``, power, the normal of a cluster cut behind (zeros where it is not), its offset (``-inf``: not cut),
           its first and last-plus-one row in the ordered triangles
seg        ``L``: cluster index plus the cumulative probability inside it, over the ordered triangles
order      ``L``: the light triangle of each ordered row
=========  ===========================================================================================================

Every function is ``numba.extending.register_jitable`` (nopython code and plain Python): :func:`choose` and
:func:`triangle_probability` are :meth:`~pyrt.lights.mesh_clusters.ClusterChoice.choose` /
:meth:`~pyrt.lights.mesh_clusters.ClusterChoice.triangle_probability` (or the power CDF's search), :func:`sample` is
:meth:`pyrt.EmissiveMeshLight.sample_li` for one point and :func:`pdf_hit` is :meth:`~pyrt.EmissiveMeshLight.pdf_hit`,
the same arithmetic in the same order (a sum over the clusters runs left to right where NumPy's sum pairs terms: the
probabilities agree to rounding).
"""
from __future__ import annotations

import math

import numpy as np
from numba.extending import register_jitable

from pyrt.lights import compiled as LC

#: record fields (the block's start, its sizes)
R_DATA, R_TRIS, R_CLUSTERS, R_MESHES, R_LIVE = 0, 1, 2, 3, 4
#: a triangle row: vertices 0-8, normal 9-11, then these fields
TRI_W = 22
T_N, T_AREA, T_PMF, T_PMF_IN, T_CLUSTER, T_FRONT, T_BACK = 9, 12, 13, 14, 15, 16, 19
#: a cluster row: -2 c 0-2, then these fields
CL_W = 12
C_CC, C_R2, C_POWER, C_NORMAL, C_OFFSET, C_START, C_END = 3, 4, 5, 6, 9, 10, 11


@register_jitable(forceinline=True)
def offsets(pars, j):
    """``(triangles, cdf, meshes, clusters, seg, order, F, K, M)``: where light ``j``'s tables start in the flat light
    table ``pars``, and its numbers of triangles, clusters and scene meshes."""
    b = j * LC.RECORD
    o = int(pars[b + R_DATA])
    n_f, n_k, n_m, n_l = int(pars[b + R_TRIS]), int(pars[b + R_CLUSTERS]), int(pars[b + R_MESHES]), \
        int(pars[b + R_LIVE])
    o_cdf = o + n_f * TRI_W
    o_map = o_cdf + n_f
    o_cl = o_map + n_m
    o_seg = o_cl + n_k * CL_W
    return o, o_cdf, o_map, o_cl, o_seg, o_seg + n_l, n_f, n_k, n_m


@register_jitable(forceinline=True)
def importance(pars, c, px, py, pz, pp):
    """The unnormalised probability of the cluster whose row starts at ``c`` at the point ``p`` (``pp = |p|^2``):
    ``power / max(|p - c|^2, r^2)``, 0 behind a cluster cut there (:meth:`ClusterChoice.probabilities`)."""
    off = pars[c + C_OFFSET]
    if off > -math.inf:     # (first: no division for the clusters behind the point)
        side = (px * pars[c + C_NORMAL] + py * pars[c + C_NORMAL + 1] + pz * pars[c + C_NORMAL + 2]) - off
        if not side > 0.0:
            return 0.0
    d2 = (px * pars[c] + py * pars[c + 1] + pz * pars[c + 2]) + pars[c + C_CC] + pp
    return pars[c + C_POWER] / max(d2, pars[c + C_R2])


@register_jitable
def _total(pars, o_cl, n_k, px, py, pz, pp):
    """The sum of the clusters' :func:`importance` at ``p``."""
    tot = 0.0
    for k in range(n_k):
        tot += importance(pars, o_cl + k * CL_W, px, py, pz, pp)
    return tot


@register_jitable(forceinline=True)
def search_right(pars, o, lo, hi, x):
    """The first index ``k`` in ``[lo, hi)`` whose ``pars[o + k]`` is above ``x`` (``hi`` if none): numpy's
    ``searchsorted(..., side="right")`` over the sorted entries ``pars[o + lo:o + hi]``."""
    while lo < hi:
        mid = (lo + hi) >> 1
        if pars[o + mid] <= x:
            lo = mid + 1
        else:
            hi = mid
    return lo


@register_jitable
def choose(pars, j, px, py, pz, u0):
    """Light ``j``'s triangle for the point ``p`` and the number ``u0``: ``(tri, r, prob)``, the number re-used inside
    the triangle (in [0, 1]) and the triangle's probability (0: none can light ``p``)."""
    o, o_cdf, o_map, o_cl, o_seg, o_ord, n_f, n_k, n_m = offsets(pars, j)
    if n_k == 0:            # selection="power": the CDF's search (numpy.searchsorted, side "right")
        tri = min(search_right(pars, o_cdf, 0, n_f, u0), n_f - 1)
        pm = pars[o + tri * TRI_W + T_PMF]
        r = 0.0
        if pm > 0.0:
            r = min(max((u0 - (pars[o_cdf + tri] - pm)) / pm, 0.0), 1.0)
        return tri, r, pm
    pp = px * px + py * py + pz * pz
    tot = _total(pars, o_cl, n_k, px, py, pz, pp)
    inv = 1.0 / tot if tot > 0.0 else 0.0
    c = 0.0
    k = n_k - 1
    pk = 0.0
    for i in range(n_k):
        pk = importance(pars, o_cl + i * CL_W, px, py, pz, pp) * inv
        c += pk
        if u0 < c:
            k = i
            break
    if not pk > 0.0:
        return 0, 0.0, 0.0
    r = min(max((u0 - (c - pk)) / pk, 0.0), 1.0)
    cb = o_cl + k * CL_W
    start, end = int(pars[cb + C_START]), int(pars[cb + C_END])
    x = k + r
    row = min(search_right(pars, o_seg, start, end, x), end - 1)     # the first row whose seg is above x
    tri = int(pars[o_ord + row])
    pin = pars[o + tri * TRI_W + T_PMF_IN]
    below = pars[o_seg + row - 1] if row > start else float(k)
    r2 = min(max((x - below) / pin, 0.0), 1.0) if pin > 0.0 else 0.0
    return tri, r2, pk * pin


@register_jitable
def triangle_probability(pars, j, px, py, pz, tri):
    """The probability that light ``j`` chooses its triangle ``tri`` at the point ``p``."""
    o, o_cdf, o_map, o_cl, o_seg, o_ord, n_f, n_k, n_m = offsets(pars, j)
    t = o + tri * TRI_W
    if n_k == 0:
        return pars[t + T_PMF]
    k = int(pars[t + T_CLUSTER])
    if k < 0:
        return 0.0
    pp = px * px + py * py + pz * pz
    tot = _total(pars, o_cl, n_k, px, py, pz, pp)
    inv = 1.0 / tot if tot > 0.0 else 0.0
    return importance(pars, o_cl + k * CL_W, px, py, pz, pp) * inv * pars[t + T_PMF_IN]


@register_jitable
def sample(pars, j, px, py, pz, u0, u1):
    """Sample light ``j`` from the point ``p`` with the numbers ``(u0, u1)`` (:meth:`EmissiveMeshLight.sample_li`):
    ``(wx, wy, wz, dist, pdf, r, g, b)``, the unit direction toward a point uniform on the chosen triangle, its
    distance, the sample's solid-angle density and the radiance the triangle emits toward ``p`` (the irradiance is
    ``L / pdf``); ``pdf`` 0 where the sample adds nothing (no triangle, on the triangle's plane, ``p`` on it)."""
    tri, r, pm = choose(pars, j, px, py, pz, u0)
    t = pars[j * LC.RECORD + R_DATA]
    t = int(t) + tri * TRI_W
    su = math.sqrt(r)
    b0 = 1.0 - su
    b1 = u1 * su
    b2 = max(1.0 - b0 - b1, 0.0)
    yx = b0 * pars[t] + b1 * pars[t + 3] + b2 * pars[t + 6]
    yy = b0 * pars[t + 1] + b1 * pars[t + 4] + b2 * pars[t + 7]
    yz = b0 * pars[t + 2] + b1 * pars[t + 5] + b2 * pars[t + 8]
    dx, dy, dz = yx - px, yy - py, yz - pz
    dist = math.sqrt(dx * dx + dy * dy + dz * dz)
    if not dist > 0.0:
        return 0.0, 0.0, 1.0, 1.0, 0.0, 0.0, 0.0, 0.0
    inv = 1.0 / dist
    wx, wy, wz = dx * inv, dy * inv, dz * inv
    cos_n = pars[t + T_N] * wx + pars[t + T_N + 1] * wy + pars[t + T_N + 2] * wz
    cos_l = abs(cos_n)
    if not (cos_l > 0.0 and pm > 0.0):
        return wx, wy, wz, dist, 0.0, 0.0, 0.0, 0.0
    pdf = (pm / pars[t + T_AREA]) * (dist * dist / cos_l)
    e = t + (T_FRONT if cos_n < 0.0 else T_BACK)         # p sees the front where wi points against the normal
    return wx, wy, wz, dist, pdf, pars[e], pars[e + 1], pars[e + 2]


@register_jitable
def light_triangle(pars, j, geom, prim):
    """Light ``j``'s triangle for the scene mesh ``geom`` and its triangle ``prim``, -1 where the mesh is not the
    light's."""
    o, o_cdf, o_map, o_cl, o_seg, o_ord, n_f, n_k, n_m = offsets(pars, j)
    if geom < 0 or geom >= n_m:
        return -1
    first = int(pars[o_map + geom])
    return first + prim if first >= 0 else -1


@register_jitable
def pdf_hit(pars, j, px, py, pz, geom, prim, dist, cos_l):
    """Light ``j``'s solid-angle density from the point ``p`` at the point a ray from it hits on scene mesh ``geom``'s
    triangle ``prim`` at distance ``dist``, the ray's cosine with the triangle's normal ``cos_l``
    (:meth:`EmissiveMeshLight.pdf_hit`); 0 on triangles the light does not sample."""
    tri = light_triangle(pars, j, geom, prim)
    if tri < 0:
        return 0.0
    c = abs(cos_l)
    prob = triangle_probability(pars, j, px, py, pz, tri)
    t = int(pars[j * LC.RECORD + R_DATA]) + tri * TRI_W
    return (prob / pars[t + T_AREA]) * (dist * dist / c if c > 0.0 else 0.0)


def pack_table(lights):
    """The light table: ``(tags (n,) int64, records (rows, RECORD) float64)`` of the lights' packed forms
    (:meth:`pyrt.lights.Light.compiled_record`), the records first (one zero row when there is none), then the tables
    of those that have some (padded to whole rows), each one's start in the flat array written into its record's
    :data:`R_DATA` field."""
    if not lights:
        return np.zeros(1, dtype=np.int64), np.zeros((1, LC.RECORD))
    tags = np.array([p[0] for p in lights], dtype=np.int64)
    recs = np.array([p[1] for p in lights], dtype=np.float64).reshape(len(lights), LC.RECORD)
    rows = [recs]
    at = recs.size
    for j, packed in enumerate(lights):
        if len(packed) > 2:
            data = np.asarray(packed[2], dtype=np.float64)
            block = np.zeros(-(-data.size // LC.RECORD) * LC.RECORD)
            block[:data.size] = data
            recs[j, R_DATA] = at
            rows.append(block.reshape(-1, LC.RECORD))
            at += block.size
    return tags, np.ascontiguousarray(np.concatenate(rows))
