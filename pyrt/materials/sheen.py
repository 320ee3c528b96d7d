"""Sheen over a base material (``KHR_materials_sheen``): the back-scattering fibres of cloth and velvet.

The extension's layering, as its specification writes it::

    f = f_sheen + f_base (1 - max(sheenColor) E(n.v))
    f_sheen = sheenColor D_charlie(h) V(l, v)        D_charlie = (2 + 1/a) sin(theta_h)^(1/a) / (2 pi),  a = r^2

``r`` the sheen roughness, ``E(mu)`` the directional albedo of ``D_charlie V`` (white sheen) at ``mu = n.v``. The
visibility is Neubelt & Pettineo's ``V = 1 / (4 (n.l + n.v - n.l n.v))`` (the specification's cheaper alternative
to the Charlie visibility of Estevez & Kulla: a documented choice). With that scaling a white sheen over a white
Lambertian base reflects exactly all light at every view (``E + (1 - E) = 1``; tested). ``E`` is tabulated over
``(mu, r)`` by quadrature on first use (the kernels: :mod:`pyrt.shaders.sheen`).
"""
from __future__ import annotations

import numpy as np

from pyrt.materials.base import check_color, check_scalar, is_texture, register
from pyrt.materials.layering import Layer, adopt_base, finish_sample, split_u, weighted_delta_lobes
from pyrt.materials.library import MetallicRoughness
from pyrt.textures import footprinted
from pyrt.shaders import sampling
from pyrt.shaders.sheen import MIN_ROUGHNESS, sheen_albedo, sheen_f_cos


@register("sheen")
class Sheen(Layer):
    """Sheen over a base material [sheen] (``KHR_materials_sheen``; the module docstring has the model).

    Sampling: the sheen lobe (cosine-weighted; it is broad) with probability ``max(sheen_color) E(n.v)`` (at most
    0.9), else the base's own sampling; the density is the mixture's. The base's delta lobes are weighted
    ``1 - max(sheen_color) E(n.v)``; its emission and its own normal map are the surface's.

    Parameters
    ----------
    base : Material, optional
        The material under the sheen (default :class:`pyrt.materials.MetallicRoughness` ()).
    color : RGB or colour texture in [0, 1] (keyword-only, default 1): ``sheenColorFactor`` x texture
    roughness : float or scalar texture in [0, 1] (keyword-only, default 0.5), floored at :data:`MIN_ROUGHNESS`
    """

    ranges = {"color": ("color", 0.0, 1.0, False), "roughness": ("scalar", 0.0, 1.0, False)}
    reciprocal = False      # the base's weight depends on the viewer (as the specification's layering)

    def __init__(self, base=None, *, color=1.0, roughness=0.5, name=None):
        self.name = name
        owner = self.label
        adopt_base(self, base)
        self.color = check_color("color", color, owner, lo=0.0, hi=1.0)
        self.roughness = check_scalar("roughness", roughness, owner, lo=0.0, hi=1.0)
        self.validate()

    @classmethod
    def example(cls):
        """A velvet-like sheen over a dark red base."""
        return cls(MetallicRoughness(base_color=(0.3, 0.02, 0.05), roughness=0.8), color=(0.9, 0.4, 0.5),
                   roughness=0.4)

    def validate(self):
        """The sheen's ranges, then the base's."""
        super().validate()
        self.base.validate()

    @property
    def uses_textures(self):
        return self.base.uses_textures or is_texture(self.color) or is_texture(self.roughness)

    @property
    def uses_footprints(self):
        return self.base.uses_footprints or footprinted(self.color, self.roughness)

    def _alpha(self, ctx):
        r = np.maximum(np.broadcast_to(self.param(self.roughness, ctx, 1), (ctx.n_hits,)), MIN_ROUGHNESS)
        return r * r

    def _color(self, ctx):
        return np.broadcast_to(self.param(self.color, ctx), (ctx.n_hits, 3))

    def _scaling(self, wo, ctx):
        """``max(sheen_color) E(n.v)`` (N,): what the sheen takes from the base."""
        r = np.sqrt(self._alpha(ctx))
        return self._color(ctx).max(axis=1) * sheen_albedo(np.abs(wo[:, 2]), r)

    def f_cos(self, wo, wi, ctx):
        """``f_sheen cos + f_base cos (1 - max(sheen_color) E(n.v))``."""
        s = self._scaling(wo, ctx)
        return (self.base.f_cos(wo, wi, ctx) * (1.0 - s)[:, None]
                + self._color(ctx) * sheen_f_cos(wo, wi, self._alpha(ctx))[:, None])

    def _sheen_prob(self, wo, ctx):
        return np.clip(self._scaling(wo, ctx), 0.0, 0.9)

    def pdf(self, wo, wi, ctx):
        """``p`` cosine-hemisphere density plus ``1 - p`` the base's."""
        p = self._sheen_prob(wo, ctx)
        ok = (wo[:, 2] > 0) & (wi[:, 2] > 0)
        return p * np.where(ok, sampling.cosine_hemisphere_pdf(wi), 0.0) + (1.0 - p) * self.base.pdf(wo, wi, ctx)

    def sample(self, wo, u, ctx):
        """Cosine-weighted directions with probability ``p``, else the base's own sampling."""
        take, uu = split_u(u, self._sheen_prob(wo, ctx))
        wb = self.base.sample_direction(wo, uu, ctx)
        ws = sampling.square_to_cosine_hemisphere(uu)
        wi = np.where(take[:, None], ws, wb)
        valid = np.where(take, True, np.any(wb != 0, axis=1)) & (wo[:, 2] > 0)
        return finish_sample(self, wo, wi, valid, ctx)

    def delta_lobes(self, wo, ctx, *, eta=None):
        """The base's delta lobes weighted ``1 - max(sheen_color) E(n.v)``."""
        return weighted_delta_lobes(self.base, wo, ctx, eta, lambda w, c: 1.0 - self._scaling(w, c))

    def glossy_alpha(self, ctx):
        """The base's (the sheen lobe is broad: diffuse-like for the glossy integrator)."""
        return self.base.glossy_alpha(ctx)

    def preview_lobes(self, ctx):
        """The base's lobes times ``1 - max(sheen_color) E(n.v)``, plus the sheen as a Lambertian part of albedo
        ``sheen_color E(n.v)`` (lit by the irradiance: an approximation of the preview, as its split sum is)."""
        lobes = self.base.preview_lobes(ctx)
        if lobes is None:
            return None
        wo = ctx.to_local(ctx.wo)
        s = self._scaling(wo, ctx)
        out = lobes.scaled(1.0 - s)
        r = np.sqrt(self._alpha(ctx))
        out.diffuse = out.diffuse + self._color(ctx) * sheen_albedo(np.abs(wo[:, 2]), r)[:, None]
        return out

    def albedo(self, ctx):
        """The base's albedo (the ambient term and the albedo AOV)."""
        return self.base.albedo(ctx)

    def emission(self, ctx):
        """The base's emission (not attenuated by the sheen)."""
        return self.base.emission(ctx)
