"""Transparent shadows: shadow rays that pass through dielectrics (an approximation, off by default).

Course 002: "if the object is transparent, the shadow is brighter". Strict Whitted (pyrt's default) lets
a glass sheet cast a shadow of 0, like an opaque one. With ``transparent_shadows=True``
(:func:`pyrt.render_full`, the scene file's ``[render]`` key, the CLI's ``--transparent-shadows``) a shadow
ray that hits a dielectric (``Material.is_dielectric``) goes on *in a straight line* and its light is
multiplied, at each interface it crosses, by

- the Fresnel transmittance ``1 - R``, ``R = fr_dielectric(|cos theta|, ior)`` with theta the angle
  between the ray and the shading normal and ``eta = ior`` (vacuum outside, :class:`pyrt.Glass`'s
  single-interface convention). The unbent ray has no inside angle of its own, so theta is taken as the
  angle on the outer side of every interface: Fresnel reflectance being the same for the pair of angles
  in both directions, leaving a parallel slab then costs exactly what the refracted ray would pay there,
  a slab's transmittance is exact, and no total internal reflection is invented on the way out;
- the material's ``tint`` (once per interface, as :meth:`pyrt.Glass.delta_lobes` weights each refraction);
- Beer-Lambert absorption ``exp(-sigma_a d)`` (:func:`pyrt.integrators.media.beer_lambert`) over each
  segment that ends on the *inner* side of a dielectric (the ray was inside it), ``d`` the straight
  segment's length (the refracted path inside a slab of thickness h at angle theta_t would be
  h / cos theta_t, the straight one is h / cos theta: the approximation).

Opaque materials block (transmittance 0). The same loop carries shadow rays through alpha-masked and blended
surfaces (``coverage=``, :mod:`pyrt.integrators.coverage`, whatever the switch: coverage is part of the surface). Not modelled: the bending of the light (caustics: a lens's
shadow is not focused), nested media priorities (each dielectric counts as bounded by vacuum), and a ray
that crosses more than :data:`MAX_INTERFACES` dielectric surfaces is blocked (0).

Cost model: the closest-hit loop below runs only when the switch is on *and* the scene has a
dielectric; otherwise the integrator keeps its single occlusion query per shadow ray (and its bool
answer, bit-identical images). With the switch on, every shadow ray is first an occlusion (any-hit) query
and only the rays it finds blocked walk the loop (``Integrator.visibility``): a ray with nothing on its way
would have ended on the loop's first step with transmittance 1, so the values are the same, exactly (tested),
and the closest-hit rays are those that meet something (AttenuationTest at 320x240: 1.36 M shadow rays,
267 k of them walked instead of all).
"""
from __future__ import annotations

import numpy as np

from pyrt.geometry.accel import Hits
from pyrt.geometry.surface import surface_from_hits
from pyrt.integrators.media import beer_lambert
from pyrt.shaders import fresnel
from pyrt.shaders.vec import dot, put_rows, take_rows
from pyrt.textures import is_texture

#: dielectric interfaces a shadow ray may cross before it counts as blocked
MAX_INTERFACES = 16
#: |cos| floor for the absorption length lost to a re-offset origin (the offset is ~1e-6 of the scene: at
#: this floor the length it stands for stays below 1e-4 of the scene's size)
GRAZING_COS = 1e-2


def _subset(hits, idx):
    return Hits(hit=hits.hit[idx], t=hits.t[idx], mesh_id=hits.mesh_id[idx], prim_id=hits.prim_id[idx],
                u=hits.u[idx], v=hits.v[idx], ng=take_rows(hits.ng, idx))


def transmittance(ps, offset, origins, wi, tmax, intersect, max_interfaces=MAX_INTERFACES, *, coverage=None,
                  dielectrics=True):
    """Transmittance (N, 3) of shadow rays ``origins + t wi``, ``0 < t < tmax``, through dielectrics.

    Parameters
    ----------
    ps : pyrt.integrators.prepared.PreparedScene
        Its geometry table, materials and ``dielectric`` flags.
    offset : pyrt.geometry.offsets.Strategy
        Re-offsets the ray past every interface it crosses (``offset(surf, wi)``, as for refracted rays).
    origins : (N, 3) float ndarray
        Offset shadow-ray origins (:meth:`Strategy.shadow`).
    wi : (N, 3) float64 ndarray
        Unit directions toward the light.
    tmax : (N,) float64 ndarray
        Distances to the light from ``origins`` (``inf`` for directional and environment lights).
    intersect : callable
        ``intersect(o, d, tmax) -> Hits`` (closest hits; the integrator's, for its statistics).
    coverage : pyrt.integrators.coverage.CoverageTable, optional
        Mask and blend materials let the ray through, multiplied by
        :meth:`CoverageTable.shadow_factor` (1 at cut-out texels, 0 elsewhere; ``1 - a`` for blend).
    dielectrics : bool
        False: dielectrics block like opaque surfaces (only the coverage materials are crossed).

    Returns
    -------
    (N, 3) float64 ndarray
        1 where nothing is hit, 0 where an opaque surface is (or too many interfaces), otherwise the product
        of the factors in the module docstring.
    """
    n = wi.shape[0]
    T = np.ones((n, 3))
    o = np.array(origins, dtype=np.float64)
    tm = np.array(tmax, dtype=np.float64)
    lead = np.zeros(n)          # how far past its last interface each origin was re-offset (absorbed too)
    todo = np.arange(n)
    for _ in range(max_interfaces + 1):
        if todo.size == 0:
            return T
        hits = intersect(take_rows(o, todo), take_rows(wi, todo), np.take(tm, todo))
        hi = np.flatnonzero(hits.hit)
        if hi.size == 0:
            return T
        sel = todo[hi]
        surf = surface_from_hits(ps.geo, _subset(hits, hi), take_rows(o, sel), take_rows(wi, sel))
        mids = surf.material_id
        diel = ps.dielectric[mids] if dielectrics else np.zeros(mids.size, dtype=bool)
        passes = diel if coverage is None else diel | coverage.see_through[mids]
        T[sel[~passes]] = 0.0
        cross = np.flatnonzero(passes)
        if cross.size:
            _cross(ps, offset, coverage, surf, hits.t[hi], sel, cross, diel, wi, T, o, tm, lead)
        todo = sel[cross]
        todo = todo[np.max(T[todo], axis=1) > 0]
    T[todo] = 0.0                                 # still crossing after max_interfaces: blocked
    return T


def _constants(ps):
    """Per material (M,): whether it is a dielectric whose ``ior``, ``tint`` and ``absorption`` are constants,
    and those constants ((M,), (M, 3), (M, 3)) and ``absorbs`` (any absorption > 0); kept on ``ps``."""
    tab = ps.__dict__.get("_shadow_constants")
    if tab is None:
        mats = ps.scene.materials
        m = len(mats)
        const = np.zeros(m, dtype=bool)
        ior, tint, sigma = np.ones(m), np.ones((m, 3)), np.zeros((m, 3))
        for k, mat in enumerate(mats):
            if not ps.dielectric[k] or any(is_texture(v) for v in (mat.ior, mat.tint, mat.absorption)):
                continue
            const[k] = True
            ior[k] = float(np.asarray(mat.ior, dtype=np.float64))
            tint[k] = np.broadcast_to(np.asarray(mat.tint, dtype=np.float64), (3,))
            sigma[k] = np.broadcast_to(np.asarray(mat.absorption, dtype=np.float64), (3,))
        tab = ps.__dict__["_shadow_constants"] = (const, ior, tint, sigma, np.any(sigma > 0, axis=1))
    return tab


def _cross(ps, offset, coverage, surf, t_hit, sel, cross, diel, wi, T, o, tm, lead):
    """One step of :func:`transmittance` for the lanes ``cross`` of ``surf`` (rays ``sel[cross]``) that go on
    through the surface they hit: their factor into ``T``, new origins past the surface into ``o``, the rest of
    the way into ``tm``, the re-offset length into ``lead`` (all in place). Dielectrics whose ``ior``, ``tint``
    and ``absorption`` are constants (:func:`_constants`) are done together, the others material by material;
    the same numbers row by row as one material at a time."""
    const, ior, tint, sigma, absorbs = _constants(ps)
    mids = surf.material_id[cross]
    rows = sel[cross]
    w = take_rows(wi, rows)             # row gathers (fancy indexing of (N, 3) rows is 3-4x slower)
    csurf = surf.subset(cross)
    factor = np.empty((cross.size, 3))
    together = const[mids] & diel[cross]
    if together.any():
        v = np.flatnonzero(together)
        mv = mids[v]
        R = fresnel.fr_dielectric(np.abs(dot(take_rows(w, v), take_rows(csurf.ns, v))), np.take(ior, mv))
        f = take_rows(tint, mv) * (1.0 - R)[:, None]
        inside = ~np.take(csurf.front, v)     # the segment just travelled was inside the dielectric
        ab = np.flatnonzero(inside & np.take(absorbs, mv))
        if ab.size:
            d = np.take(t_hit[cross], v[ab]) + np.take(lead, np.take(rows, v[ab]))
            put_rows(f, ab, take_rows(f, ab) * beer_lambert(take_rows(sigma, mv[ab]), d))
        put_rows(factor, v, f)
    rest = np.flatnonzero(~together)
    materials = ps.scene.materials
    for k in np.unique(mids[rest]):
        lanes = rest[mids[rest] == k]
        ctx = csurf.subset(lanes)
        mat = materials[k]
        if not diel[cross[lanes[0]]]:     # a mask / blend surface (pyrt.integrators.coverage)
            put_rows(factor, lanes, np.repeat(coverage.shadow_factor(k, ctx)[:, None], 3, axis=1))
            continue
        w_r = take_rows(w, lanes)
        R = fresnel.fr_dielectric(np.abs(dot(w_r, ctx.ns)), mat.param(mat.ior, ctx, 1))
        f = mat.param(mat.tint, ctx) * (1.0 - R)[:, None]
        inside = ~ctx.front
        if np.any(inside) and np.any(np.asarray(mat.absorption) > 0):
            sig = np.broadcast_to(np.asarray(mat.absorption, dtype=np.float64), (lanes.size, 3))
            f = np.where(inside[:, None], f * beer_lambert(sig, t_hit[cross[lanes]] + lead[rows[lanes]]), f)
        put_rows(factor, lanes, f)
    put_rows(T, rows, take_rows(T, rows) * factor)
    new_o = offset(csurf, w)
    # the offset moves the origin off the surface along ng, not along the ray: the ray line from new_o
    # meets the surface plane (ng . off) / (ng . wi) behind it (|cos| clamped: grazing crossings)
    cos_g = np.abs(dot(w, csurf.ng))
    lead[rows] = np.abs(dot(new_o - csurf.p, csurf.ng)) / np.maximum(cos_g, GRAZING_COS)
    # the same end point, from the new origin
    tm[rows] = np.maximum(np.take(tm, rows) - dot(new_o - take_rows(o, rows), w), 0.0)
    put_rows(o, rows, new_o)
