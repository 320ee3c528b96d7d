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
never), i.e. on the hits of reflected, refracted and glossy rays, whose light reaches the image scaled by
their throughput; the previewer selects from bounce 1.
"""
from __future__ import annotations

import numpy as np

from pyrt.integrators import direct
from pyrt.materials.dispatch import BSDFBatch
from pyrt.shaders.vec import put_rows, take_rows


def selectable(light):
    """True for lights the selection may pick: delta lights sampled once per hit (their estimate is one
    shadow ray, no MIS), not an environment."""
    return light.environment is None and light.delta and light.n_samples == 1 and not light.bsdf_samples


def one_light_estimate(lights, surf, visible, rng, materials):
    """Direct light (N, 3) from the ``lights`` (each :func:`selectable`) at the hits of ``surf``, one light per
    hit chosen by irradiance (module docstring).

    Parameters
    ----------
    lights : list of pyrt.lights.Light
    surf : pyrt.geometry.SurfaceBatch
        The hits (ordered by material, as the integrator passes them: subsets keep the order).
    visible : callable
        ``visible(idx, wi, dist, end=None)`` of the integrator for the hits of ``surf``.
    rng : numpy.random.Generator
        One uniform number per hit chooses the light.
    materials : list of pyrt.materials.Material
        The scene's materials (the chosen hits' BSDFs).
    """
    n = surf.n_hits
    L = np.zeros((n, 3))
    if n == 0 or not lights:
        return L
    u0 = np.zeros((n, 2))
    w = np.zeros((len(lights), n))
    for i, light in enumerate(lights):
        ls = light.sample_li(surf.p, u0)                 # delta lights: u is ignored
        lit = ls.active() & surf.light_side(ls.wi)
        w[i] = np.where(lit, ls.irradiance().mean(axis=1), 0.0)
    c = np.cumsum(w, axis=0)
    total = c[-1]
    pick = np.minimum(np.sum(rng.random(n) * total >= c, axis=0), len(lights) - 1)
    for i, light in enumerate(lights):
        idx = np.flatnonzero((pick == i) & (w[i] > 0))
        if idx.size == 0:
            continue
        sub = surf.subset(idx)

        def vis(j, wi, dist, end=None, idx=idx):
            """Shadow rays from the subset's hits ``j``."""
            return visible(idx[j], wi, dist, end)
        est = direct.light_sampling_estimate(light, sub, BSDFBatch(sub, materials), vis, rng)
        put_rows(L, idx, take_rows(L, idx) + est * (total[idx] / w[i, idx])[:, None])
    return L
