"""Shadow rays through see-through surfaces on the compiled path: alpha-mask cut-outs and, with transparent shadows,
dielectrics (:func:`pyrt.integrators.shadows.transmittance`, the NumPy path's loop).

A shadow ray is first an occlusion query (a packet's, or :func:`shadow_ray`'s single one); only a ray it finds
blocked is walked (:func:`walk`) when the scene has alpha masks or transparent shadows are on: closest hits from its
origin toward the light, and at each surface

- with transparent shadows, a dielectric (:func:`pyrt.materials.compiled.is_dielectric`) is crossed in a straight
  line, its light multiplied by the material's :func:`pyrt.materials.compiled.shadow_transmission` (``tint (1 - R)``,
  ``R`` the Fresnel reflectance at ``|wi . ns|`` for ``eta = ior``); the new origin is the hit offset to the light's
  side as a refracted ray's (:func:`pyrt.shaders.jit.round_away` of the local-bound magnitude);
- a mask texel below ``alpha_cutoff`` is crossed with factor 1, a blend texel with ``1 - a`` (``a`` at the
  full-resolution texture: shadow rays carry no footprint; the origin pushed past it by
  :func:`pyrt.integrators.compiled_coverage.through`);
- anything else blocks (transmittance 0), as do both sides of a culled surface;

``tmax`` shortened to the same end point each time. After ``layers + 1`` queries a ray still crossing counts as
blocked (:data:`pyrt.integrators.shadows.MAX_INTERFACES`, or :data:`pyrt.integrators.coverage.MAX_LAYERS` in a
scene with masks, as on the NumPy path). A segment that ends on a dielectric's back (the ray was inside) is absorbed
by its Beer-Lambert coefficient (:func:`pyrt.integrators.compiled_media.absorbed`) over the segment's length plus the
re-offset lead, as :func:`pyrt.integrators.shadows._cross` counts it.

The walk's options travel as one tuple (:func:`shadow_options`): ``(mask layers, masks, transparent layers,
fallback)``; masks 1: the scene has mask or blend surfaces; transparent layers 0: transparent shadows off.
"""
from __future__ import annotations

import numba
import numpy as np

from pyrt.integrators import kernel_cache

kernel_cache.use_cache_dir()      # before the decorators below run

from pyrt.geometry import embree_jit as E  # noqa: E402
from pyrt.integrators import compiled_diffs as D  # noqa: E402
from pyrt.integrators.compiled_coverage import MASKS, MODE_MASK, opacity, through  # noqa: E402
from pyrt.integrators.compiled_media import absorbed  # noqa: E402
from pyrt.integrators.compiled_layout import (  # noqa: E402
    LANES, O_COVER, O_FALLBACK, O_LAYERS, O_TRANSPARENT, V_F, V_LIT, V_SO, V_TMAX, V_WI, _njit, lane_vec,
    set_lane_vec)
from pyrt.integrators.shadows import GRAZING_COS  # noqa: E402
from pyrt.materials import compiled as MC  # noqa: E402
from pyrt.shaders import jit as J  # noqa: E402
from pyrt.shaders.jit import dot, row3  # noqa: E402
from pyrt.textures import compiled as TC  # noqa: E402


@_njit
def shadow_options(opts):
    """The walk's options from the kernel's integer options: ``(mask layers, 1 with masks or blend surfaces,
    transparent layers (0: off), 1 with the back-facing-normal fallback)``."""
    return (opts[O_LAYERS], 1 if opts[O_COVER] == MASKS else 0, opts[O_TRANSPARENT], opts[O_FALLBACK])


@_njit
def walks(sopt):
    """Whether blocked shadow rays are walked (the scene has mask or blend surfaces, or transparent shadows are
    on)."""
    return sopt[1] != 0 or sopt[2] != 0


@_njit
def walk(scene, G, mats_tag, mats_par, tex_tag, tex_par, sopt, o, wi, tmax, ray_buf):
    """The transmittance ``(t0, t1, t2, queries)`` of the shadow ray ``o + t wi``, ``0 < t < tmax``, that an
    occlusion query found blocked (module docstring)."""
    fnorm, foff, fmat = G[3], G[7], G[8]
    masks, transparent = sopt[1] != 0, sopt[2] != 0
    layers = sopt[2] if transparent else sopt[0]
    wo = (-wi[0], -wi[1], -wi[2])
    ox, oy, oz = o
    t0 = t1 = t2 = 1.0
    lead = 0.0          # how far past its last interface the origin was re-offset (absorbed too)
    for k in range(layers + 1):
        hit, t_hit, prim, geom, u, v, _, _, _ = E.intersect1(scene, ox, oy, oz, wi[0], wi[1], wi[2], 0.0, tmax,
                                                             ray_buf)
        if not hit:
            return t0, t1, t2, k + 1
        face = foff[geom] + prim
        m = fmat[face]
        mtag = mats_tag[m]
        rb = m * MC.RECORD
        if transparent and MC.is_dielectric(mtag, mats_par, m):
            p, ng, ns, _, _, mag, _, front, _, uv = J.hit_surface(G, sopt[3] != 0, False, geom, prim, u, v, wo)
            f = MC.shadow_transmission(mtag, mats_par, m, abs(dot(wi, ns)),
                                       tint_base(G, mats_tag, mats_par, tex_tag, tex_par, m, face, u, v, uv))
            a = absorbed(mats_par, m, front, t_hit + lead)
            t0, t1, t2 = t0 * f[0] * a[0], t1 * f[1] * a[1], t2 * f[2] * a[2]
            if not max(t0, t1, t2) > 0.0:
                return 0.0, 0.0, 0.0, k + 1
            nx, ny, nz = J.round_away(p, mag, 1.0 if dot(wi, ng) >= 0.0 else -1.0, ng)
            lead = abs((nx - p[0]) * ng[0] + (ny - p[1]) * ng[1] + (nz - p[2]) * ng[2]) / max(abs(dot(wi, ng)),
                                                                                               GRAZING_COS)
        elif masks and mats_par[rb + MC.MASK] != 0.0:
            b1, b2 = np.float64(u), np.float64(v)
            b0 = 1.0 - b1 - b2
            a = opacity(G, mats_par, tex_tag, tex_par, face, b0, b1, b2, G[0], 0, False)
            if mats_par[rb + MC.MASK] == MODE_MASK:
                if not a < mats_par[rb + MC.MASK + 1]:
                    return 0.0, 0.0, 0.0, k + 1
            else:
                t0, t1, t2 = t0 * (1.0 - a), t1 * (1.0 - a), t2 * (1.0 - a)
                if not max(t0, t1, t2) > 0.0:
                    return 0.0, 0.0, 0.0, k + 1
            nx, ny, nz = through(G, face, b0, b1, b2, row3(fnorm, face), wi)
            lead = 0.0      # (no absorbing medium beside masks: pyrt.integrators.compiled.unsupported)
        else:
            return 0.0, 0.0, 0.0, k + 1
        tmax = max(tmax - ((nx - ox) * wi[0] + (ny - oy) * wi[1] + (nz - oz) * wi[2]), 0.0)
        ox, oy, oz = nx, ny, nz
    return 0.0, 0.0, 0.0, layers + 1


@_njit
def tint_base(G, mats_tag, mats_par, tex_tag, tex_par, m, face, bu, bv, uv):
    """The base colour a shadow ray reads where it crosses a GLTF dielectric ``m`` (its transmission's tint:
    :func:`pyrt.materials.compiled.shadow_transmission`) at barycentrics ``(bu, bv)`` of ``face``, uv ``uv``: the
    constant, or the texture (no footprint: shadow rays carry none) times the vertex colour; ones for the others."""
    b = m * MC.RECORD
    if mats_tag[m] != MC.GLTF:
        return 1.0, 1.0, 1.0
    if mats_par[b] < 0.0 and mats_par[b + MC.VERTEX_COLOR] == 0.0:
        return mats_par[b + 1], mats_par[b + 2], mats_par[b + 3]
    a = MC.albedo_at(MC.GLTF, mats_par, m, tex_tag, tex_par, uv[0], uv[1],
                     D.hit_footprint(G, face, bu, bv, TC.NO_DIFFS), D.vertex_color(G, mats_par, m, face, bu, bv))
    return a[3], a[4], a[5]


@_njit
def shadow_ray(scene, G, mats_tag, mats_par, tex_tag, tex_par, sopt, o, wi, tmax, ray_buf):
    """One shadow ray: ``(t0, t1, t2, rays traced)``, its transmittance (1: unblocked, 0: blocked; between them
    through dielectrics): an occlusion query, then :func:`walk` where it is blocked and the scene has see-through
    surfaces."""
    if not E.occluded1(scene, o[0], o[1], o[2], wi[0], wi[1], wi[2], 0.0, tmax, ray_buf):
        return 1.0, 1.0, 1.0, 1
    if not walks(sopt):
        return 0.0, 0.0, 0.0, 1
    t0, t1, t2, n = walk(scene, G, mats_tag, mats_par, tex_tag, tex_par, sopt, o, wi, tmax, ray_buf)
    return t0, t1, t2, n + 1


@_njit
def keep_rays(sh, w, V, n):
    """The shadow packet ``sh``'s rays (float32 as traced) into the scratch's :data:`V_SO`, :data:`V_WI`,
    :data:`V_TMAX` for lanes ``[0, n)`` before its query (what :func:`packet_walk` walks: the query overwrites tfar
    of a blocked lane)."""
    for lane in range(n):
        s_o, s_wi, s_tmax = E.packet_ray(sh, w, lane)
        set_lane_vec(V, V_SO, lane, (float(s_o[0]), float(s_o[1]), float(s_o[2])))
        set_lane_vec(V, V_WI, lane, (float(s_wi[0]), float(s_wi[1]), float(s_wi[2])))
        V[V_TMAX * LANES + lane] = float(s_tmax)


@numba.njit(nogil=True, cache=True, error_model="numpy")
def packet_walk(scene, G, mats_tag, mats_par, tex_tag, tex_par, sopt, sh, w, V, n, ray_buf):
    """After a shadow packet's occlusion query: each traced lane (:data:`V_LIT`) that it found blocked is walked
    (:func:`walk`, its ray from :data:`V_SO`, :data:`V_WI`, :data:`V_TMAX`); a lane that gets light through is marked
    unblocked in ``sh`` and its value (:data:`V_F`) multiplied by its transmittance. Returns the closest-hit
    queries."""
    n_q = 0
    for lane in range(n):
        if V[V_LIT * LANES + lane] == 0.0 or not E.lane_blocked(sh, w, lane):
            continue
        wi = lane_vec(V, V_WI, lane)
        t0, t1, t2, k = walk(scene, G, mats_tag, mats_par, tex_tag, tex_par, sopt, lane_vec(V, V_SO, lane), wi,
                             V[V_TMAX * LANES + lane], ray_buf)
        n_q += k
        if max(t0, t1, t2) > 0.0:
            E.packet_set_dir(sh, w, lane, wi[0], wi[1], wi[2], V[V_TMAX * LANES + lane])
            f = lane_vec(V, V_F, lane)
            set_lane_vec(V, V_F, lane, (f[0] * t0, f[1] * t1, f[2] * t2))
    return n_q


kernel_cache.restore()
