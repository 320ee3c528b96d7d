"""Ray differentials through specular bounces: the offset rays of a mirror reflection and of a refraction at a batch
of hits (pbrt's specular-reflection and -transmission differentials), from the surface's position and normal
derivatives (:class:`pyrt.geometry.surface.SurfaceBatch` ``dpdx``, ``dpdy``, ``dndx``, ``dndy``).
"""
from __future__ import annotations

import numpy as np

from pyrt.shaders.vec import dot, scale_rows


def reflect_differential_terms(surf, rx_d, ry_d):
    """The parts of :func:`reflect_differentials` that do not depend on the reflected direction:
    ``(p + dpdx, dwr_x, p + dpdy, dwr_y)``, the offset rays' origins and direction changes (a direction change does
    not involve ``wr``). Several rays leaving one hit (glossy rays) share them."""
    n = surf.ns
    wo = surf.wo
    cos_o = dot(wo, n)
    out = []
    for dp, d_in, dn in ((surf.dpdx, rx_d, surf.dndx), (surf.dpdy, ry_d, surf.dndy)):
        dwo = -d_in - wo
        dcos = dot(dwo, n) + dot(wo, dn)
        inner = scale_rows(n, dcos)
        inner += scale_rows(dn, cos_o)
        dwr = 2.0 * inner
        dwr -= dwo
        out += [surf.p + dp, dwr]
    return tuple(out)


def reflect_differentials(surf, rx_d, ry_d, wr):
    """Offset rays of a mirror reflection (pbrt's specular-reflection differentials).

    ``wr = -wo + 2 (wo.n) n``  =>  ``dwr = -dwo + 2 (d(wo.n) n + (wo.n) dn)``.
    Returns ``(rx_o, rx_d, ry_o, ry_d)`` for the reflected ray.
    """
    ox, dx, oy, dy = reflect_differential_terms(surf, rx_d, ry_d)
    return ox, wr + dx, oy, wr + dy


def refract_differentials(surf, rx_d, ry_d, wt, eta):
    """Offset rays of a refraction; ``eta = eta_t / eta_i``.

    ``wt = -wo/eta + mu n`` with ``mu = cos_o/eta - cos_t``, ``cos_t = -(wt.n)``; differentiating,
    ``dwt = -dwo/eta + mu dn + dmu n`` and ``dmu = (1/eta - cos_o / (eta^2 cos_t)) d(cos_o)``.
    """
    n = surf.ns
    wo = surf.wo
    cos_o = dot(wo, n)
    cos_t = -dot(wt, n)
    mu = cos_o / eta - cos_t
    safe_ct = np.where(np.abs(cos_t) > 1e-12, cos_t, 1e-12)
    out = []
    for dp, d_in, dn in ((surf.dpdx, rx_d, surf.dndx), (surf.dpdy, ry_d, surf.dndy)):
        dwo = -d_in - wo
        dcos = dot(dwo, n) + dot(wo, dn)
        dmu = (1.0 / eta - cos_o / (eta * eta * safe_ct)) * dcos
        dwt = -dwo / eta[:, None] + mu[:, None] * dn + dmu[:, None] * n
        out += [surf.p + dp, wt + dwt]
    return tuple(out)
