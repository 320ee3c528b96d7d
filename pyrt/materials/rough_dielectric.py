"""Rough dielectric: GGX microfacet reflection and transmission (frosted glass).

B. Walter, S. R. Marschner, H. Li and K. E. Torrance, "Microfacet Models for Refraction through Rough
Surfaces", EGSR 2007; sampling by visible normals (Heitz 2018). Kernels in :mod:`pyrt.shaders.brdfs`
(``rough_dielectric_f_cos``, ``rough_dielectric_pdf``, ``sample_rough_dielectric``).

Its transmitted directions lie below the local frame's horizon (``wi_z < 0``, the side opposite ``wo``):
``transmits`` is declared. What the integrators do with it: the strict Whitted integrator gives it direct
light on the viewer's side only (reflection; shadow rays never leave through the surface, and no
refraction rays are spawned: it has no delta lobe), so rough glass looks like a frosted reflector there.
Seeing *through* it needs an integrator that samples the non-delta lobes with :meth:`sample` and spawns
the rays (the glossy integrator). With ``transparent_shadows`` its shadow is the smooth interface's
Fresnel transmittance (the straight-line approximation of :mod:`pyrt.integrators.shadows`).
"""
from __future__ import annotations

import numpy as np

from pyrt.materials.base import Material, check_color, check_scalar, register
from pyrt.shaders import brdfs
from pyrt.shaders import microfacet as _mf


@register("rough_dielectric")
class RoughDielectric(Material):
    """GGX rough dielectric (Walter et al. 2007): reflection and refraction through microfacets.

    Parameters (keyword-only)
    -------------------------
    ior : float > 0
        Index of refraction of the inside (the side opposite the outward normal) over the outside.
    roughness : float in [0, 1]
        ``alpha = roughness^2`` (default 0.3), clamped below at :data:`pyrt.shaders.microfacet.ALPHA_MIN`.
    tint : RGB in [0, 1]
        Multiplies reflection and transmission (as :class:`pyrt.Glass`).

    ``f_cos`` is reflection ``F D G2 / (4 |cos_o|)`` above the horizon and the radiance-mode transmission
    (with the 1/eta^2 compression of :class:`pyrt.Glass`) below it; ``sample`` draws a visible normal and
    reflects with the Fresnel probability. Not reciprocal in the plain sense: the BTDF obeys
    ``f(wo, wi) / eta_o^2 = f(wi, wo) / eta_i^2`` (eta of the medium on each direction's side, tested),
    so ``reciprocal`` is False. Energy: reflected plus transmitted albedo <= 1 (single scattering: a rough
    interface loses what bounces between microfacets, up to ~10 % at roughness 1).
    """

    has_diffuse = True
    is_dielectric = True
    transmits = True
    reciprocal = False
    ranges = {"ior": ("scalar", 0.0, None, True), "roughness": ("scalar", 0.0, 1.0, False),
              "tint": ("color", 0.0, 1.0, False)}

    def __init__(self, *, ior=1.5, roughness=0.3, tint=1.0, name=None):
        self.name = name
        owner = self.label
        self.ior = check_scalar("ior", ior, owner, lo=0.0, lo_open=True)
        self.roughness = check_scalar("roughness", roughness, owner, lo=0.0, hi=1.0)
        self.tint = check_color("tint", tint, owner, lo=0.0, hi=1.0)
        self.validate()

    @property
    def alpha(self):
        """GGX width ``roughness^2``."""
        return float(_mf.roughness_to_alpha(self.roughness))

    def _eta(self, ctx):
        """Relative index eta_t / eta_i per hit (N,): ``ior`` from the front, ``1 / ior`` from inside, as
        :class:`pyrt.Glass` (the local frame's z is turned toward the viewer, so the kernels see wo_z > 0)."""
        return np.where(ctx.front, self.ior, 1.0 / self.ior)

    def glossy_alpha(self, ctx):
        """``alpha`` per hit: the glossy integrator traces its reflection *and* transmission rays."""
        return np.full(ctx.n_hits, self.alpha)

    def f_cos(self, wo, wi, ctx):
        """BSDF times |cos theta_i| (N, 3): reflection above the horizon, transmission below."""
        f = brdfs.rough_dielectric_f_cos(wo, wi, self.alpha, self._eta(ctx))
        return f[:, None] * self.param(self.tint, ctx)

    def sample(self, wo, u, ctx):
        """Visible-normal sample, reflected or refracted by Fresnel: ``(wi, weight = f_cos / pdf, pdf)``."""
        eta = self._eta(ctx)
        wi, valid = brdfs.sample_rough_dielectric(wo, u, self.alpha, eta)
        wi = np.where(valid[:, None], wi, 0.0)      # a refraction that came out on the wrong side: no sample
        pdf = np.where(valid, brdfs.rough_dielectric_pdf(wo, wi, self.alpha, eta), 0.0)
        f = self.f_cos(wo, wi, ctx)
        weight = np.where((pdf > 0)[:, None], f / np.where(pdf > 0, pdf, 1.0)[:, None], 0.0)
        return wi, weight, pdf

    def pdf(self, wo, wi, ctx):
        """Solid-angle density (N,) of :meth:`sample` over the whole sphere."""
        return brdfs.rough_dielectric_pdf(wo, wi, self.alpha, self._eta(ctx))

    def albedo(self, ctx):
        """No diffuse-like reflectance: zero (the ambient term skips it)."""
        return np.zeros((ctx.n_hits, 3))
