"""Back-face culling on the compiled path: :meth:`pyrt.integrators.coverage.CoverageTable.cull_hits` for the camera
packets and the specular tree's single rays of :mod:`pyrt.integrators.compiled_kernel`.

A material whose record has :data:`pyrt.materials.compiled.CULL` set (:attr:`pyrt.materials.Material.culls_back_faces`:
``double_sided`` False, not a dielectric or transmitting material) is not seen from behind by camera and secondary
rays: a hit whose winding normal faces away from the ray (``fn . d > 0``) is re-traced from the hit point pushed
through the surface by the ``robust`` offset (:func:`pyrt.geometry.offsets.local_bound`: the flat point's local
error bound along ng, toward the far side, rounded outward to float32), direction kept, ``t`` still measured from the
ray's first origin (the depth AOV). After ``opts[O_LAYERS]`` (:data:`pyrt.integrators.coverage.MAX_LAYERS`) culled
faces a ray meeting one more is dropped: radiance 0, no AOV, as on the NumPy path. Shadow rays are not changed (both
sides of a culled surface block light). The re-traced rays count as secondary rays, as the NumPy path counts them.

Nothing here runs unless ``opts[O_CULL]`` is set (some material culls): other scenes' images and work are unchanged.
"""
from __future__ import annotations

import numba
import numpy as np

from pyrt.integrators import kernel_cache

kernel_cache.use_cache_dir()      # before the decorators below run

from pyrt.geometry import embree_jit as E  # noqa: E402
from pyrt.integrators.compiled_layout import (  # noqa: E402
    LANES, V_D, V_L, V_T, V_TB, T_INF, C_POS, _njit, lane_vec, set_lane_vec)
from pyrt.materials import compiled as MC  # noqa: E402
from pyrt.shaders.jit import EPS32, EPS64, bary3, dot, gamma, round_away, row3  # noqa: E402


@_njit
def culled_exit(G, mats_par, geom, prim, u, v, d):
    """Whether the hit ``(geom, prim, u, v)`` of a ray along ``d`` is a culled back face, and then the origin of the
    ray continued past it (a 3-tuple; zeros otherwise): the hit point rebuilt as
    :func:`pyrt.shaders.jit.hit_surface` rebuilds it, pushed by its offset magnitude ``mag`` along the viewer-side
    normal ``-fn`` to the far side (:func:`pyrt.shaders.jit.round_away`, side -1: ``d . ng < 0`` on a back face)."""
    verts, _, _, fnorm, fabs, fext, faces, foff, fmat, _ = G
    face = foff[geom] + prim
    fn = row3(fnorm, face)
    if mats_par[fmat[face] * MC.RECORD + MC.CULL] == 0.0 or not dot(fn, d) > 0.0:
        return False, (0.0, 0.0, 0.0)
    i0, i1, i2 = faces[3 * face], faces[3 * face + 1], faces[3 * face + 2]
    b1, b2 = np.float64(u), np.float64(v)
    b0 = 1.0 - b1 - b2
    p = bary3(b0, b1, b2, row3(verts, i0), row3(verts, i1), row3(verts, i2))
    ng = (-fn[0], -fn[1], -fn[2])
    g4 = gamma(4.0, EPS64)
    m = 0.0
    for c in range(3):
        m += abs(ng[c]) * g4 * fabs[3 * face + c]
    mag = m + 8.0 * EPS32 * fext[face]
    return True, round_away(p, mag, -1.0, ng)


@numba.njit(nogil=True, cache=True, error_model="numpy")
def cull_packet(scene, G, mats_par, cam, pk, w, V, n, layers):
    """Skip the culled back faces the camera packet ``pk`` (width ``w``, lanes ``[0, n)``, directions at :data:`V_D`
    of the scratch ``V``) hit after its query: the lanes on one are re-traced together (an incoherent packet query of
    those lanes alone) until none is, at most ``layers`` times; the packet's hit fields then hold each lane's nearest
    kept surface (a lane dropped after ``layers`` culled faces: a miss). :data:`V_TB` gets each lane's distance from
    the camera to its last re-trace origin along ``d`` (0: not re-traced; -1: dropped; :func:`cull_finish` uses it).
    The lanes' origins are put back to the camera's (``cam``'s record) and lanes ``[0, n)`` activated again.
    Returns the number of re-traced rays."""
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
                culled, o = culled_exit(G, mats_par, geom, prim, u, v, d)
                if culled:
                    E.packet_set_dir(pk, w, lane, d[0], d[1], d[2], T_INF)      # a miss until its next query
                    if layer == layers:            # one culled face too many: dropped
                        V[V_TB * LANES + lane] = -1.0
                    else:
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
def cull_finish(V, n):
    """After the surface stage of a packet that went through :func:`cull_packet`: the dropped lanes' radiance 0 (not
    the background), and the re-traced lanes' hit distance :data:`V_T` counted from the camera."""
    for lane in range(n):
        tb = V[V_TB * LANES + lane]
        if tb < 0.0:
            set_lane_vec(V, V_L, lane, (0.0, 0.0, 0.0))
        else:
            V[V_T * LANES + lane] += tb


@_njit
def cull_single(scene, G, mats_par, layers, hit, prim, geom, u, v, d, ray_buf):
    """:func:`cull_packet` for one ray along ``d`` whose query answered ``(hit, prim, geom, u, v)``
    (:func:`pyrt.geometry.embree_jit.intersect1`): its nearest kept surface ``(hit, prim, geom, u, v, dropped,
    re-traced rays)``, ``dropped`` True after more than ``layers`` culled faces."""
    n_re = 0
    while hit:
        culled, o = culled_exit(G, mats_par, geom, prim, u, v, d)
        if not culled:
            break
        if n_re == layers:
            return False, prim, geom, u, v, True, n_re
        n_re += 1
        hit, _, prim, geom, u, v, _, _, _ = E.intersect1(scene, o[0], o[1], o[2], d[0], d[1], d[2], 0.0, T_INF,
                                                         ray_buf)
    return hit, prim, geom, u, v, False, n_re


kernel_cache.restore()
