"""One delta light per hit instead of all of them (``light_select_depth``): stochastic light selection.

At a hit lit by several delta lights (point, spot, directional: the previewer's three-light studio rig) the
direct-light estimator of :mod:`pyrt.integrators.direct` traces one shadow ray and evaluates the BSDF once per
light. :func:`one_light_estimate` instead picks one light per hit, light ``i`` with probability
``p_i = w_i / sum_j w_j``, ``w_i`` the mean over RGB of the light's unshadowed irradiance ``E_i`` at the hit
(0 where it cannot contribute: behind the surface, outside a spot's cone or range), and divides its estimate by
``p_i``. The expected value is the sum over the lights (unbiased); the cost is one shadow ray and one BSDF
evaluation per hit; the noise is the spread of ``f_i E_i V_i / p_i`` between the lights (none where one light
dominates or the lights agree). pbrt-v4's ``PowerLightSampler`` picks by power; the irradiance at the hit is
the better-informed choice for a few lights and costs one ``sample_li`` per light and hit (no shadow ray).

Used by :class:`pyrt.integrators.whitted.Integrator` from bounce ``light_select_depth`` on (default None:
never) at camera hits and at the hits of BSDF-sampled (glossy) rays, which are Monte Carlo estimates already;
hits reached by delta rays (what mirrors and glass show) keep every light. The previewer selects from bounce
1: the hits of its glossy rays (TransmissionTest at 160x120: 527 k -> 418 k shadow rays, the same RMSE against
a converged render).
"""
from __future__ import annotations

import numpy as np

from pyrt.integrators import direct
from pyrt.shaders.vec import max_component, put_rows, take_rows


def selectable(light):
    """True for lights the selection may pick: delta lights sampled once per hit (their estimate is one
    shadow ray, no MIS), not an environment."""
    return light.environment is None and light.delta and light.n_samples == 1 and not light.bsdf_samples


def one_light_estimate(lights, surf, bsdf, visible, rng, choose=None):
    """Direct light (N, 3) from the ``lights`` (each :func:`selectable`) at the hits of ``surf``: one light per
    hit chosen by irradiance (module docstring) where ``choose`` (N,) is True (None: everywhere), every light
    elsewhere.

    The directions, distances and irradiances (divided by the choice's probability) are gathered into
    batches of distinct hits: the chosen hits and the first light of the others in one BSDF query, then one more
    per further light for the others only; the shadow rays of all batches go in one query
    (:func:`pyrt.integrators.direct.shadow_queries`; the cost of light sampling is mostly per query, not per ray).

    Parameters
    ----------
    lights : list of pyrt.lights.Light
    surf : pyrt.geometry.SurfaceBatch
        The hits.
    bsdf : pyrt.materials.dispatch.BSDFBatch
        Their BSDFs.
    visible : callable
        ``visible(idx, wi, dist, end=None)`` of the integrator for the hits of ``surf``: a bool (k,) or a
        transmittance (k, 3).
    rng : numpy.random.Generator
        One uniform number per hit chooses the light.
    choose : (N,) bool ndarray, optional
    """
    n = surf.n_hits
    L = np.zeros((n, 3))
    if n == 0 or not lights:
        return L
    u0 = np.zeros((n, 2))
    w = np.zeros((len(lights), n))
    samples = []
    for i, light in enumerate(lights):
        ls = light.sample_li(surf.p, u0)                 # delta lights: u is ignored
        E = ls.irradiance()
        w[i] = np.where(ls.active() & surf.light_side(ls.wi), E.mean(axis=1), 0.0)
        samples.append((ls.wi, np.broadcast_to(np.asarray(ls.dist, dtype=np.float64), (n,)), E))
    choose = np.ones(n, dtype=bool) if choose is None else np.asarray(choose, dtype=bool)
    c = np.cumsum(w, axis=0)
    total = c[-1]
    pick = np.minimum(np.sum(rng.random(n) * total >= c, axis=0), len(lights) - 1)
    chosen = np.flatnonzero(choose & (total > 0))
    chosen = chosen[w[pick[chosen], chosen] > 0]
    others = np.flatnonzero(~choose)
    parts, queries = [], []
    for r in range(len(lights)):
        rest = others[w[r, others] > 0]
        rows = np.concatenate([chosen, rest]) if r == 0 else rest
        if rows.size == 0:
            continue
        which = np.concatenate([pick[chosen], np.full(rest.size, r)]) if r == 0 else np.full(rest.size, r)
        scale = np.ones(rows.size)
        if r == 0:
            scale[:chosen.size] = total[chosen] / w[pick[chosen], chosen]
        order = np.argsort(rows, kind="stable")          # increasing rows: the BSDF batch's fast path
        rows, which, scale = rows[order], which[order], scale[order]
        wi, dist, E = np.zeros((rows.size, 3)), np.zeros(rows.size), np.zeros((rows.size, 3))
        for i, (wi_i, dist_i, E_i) in enumerate(samples):
            k = np.flatnonzero(which == i)
            if k.size == 0:
                continue
            put_rows(wi, k, take_rows(wi_i, rows[k]))
            dist[k] = dist_i[rows[k]]
            put_rows(E, k, take_rows(E_i, rows[k]) * scale[k][:, None])
        f = bsdf.f_cos(rows, wi)
        keep = np.flatnonzero(max_component(f) > 0)
        if keep.size == 0:
            continue
        idx, wi, dist, f, E = rows[keep], take_rows(wi, keep), dist[keep], take_rows(f, keep), take_rows(E, keep)
        parts.append((idx, f * E))
        queries.append((idx, wi, dist, None))            # end points p + wi dist (lights of several positions)
    # every batch's shadow rays in one query (direct.shadow_queries), added in batch order as before
    for (idx, val), vis in zip(parts, direct.shadow_queries(visible, surf, queries) if queries else []):
        if vis.ndim == 1:
            val[~vis] = 0.0
        else:
            val *= vis
        put_rows(L, idx, take_rows(L, idx) + val)
    return L
