"""glTF's layered and unlit materials as pyrt materials (scene-file ``type`` names in brackets; built by
:mod:`pyrt.io.assets.gltf`; the extended metallic-roughness BSDF is :mod:`pyrt.materials.gltf_pbr`):

- :class:`Clearcoat` [clearcoat]: ``base (1 - c F_c) + c F_c D G / (4 |n.l| |n.v|)`` over any base material
  (``KHR_materials_clearcoat``);
- :class:`Unlit` [unlit]: emits its colour, reflects nothing (``KHR_materials_unlit``).
"""
from __future__ import annotations

import numpy as np

from pyrt.materials import gltf_record as _gltf, preview as _preview
from pyrt.materials.base import Material, MaterialError, check_color, check_scalar, is_texture, register
from pyrt.materials.layering import Layer, adopt_base, finish_sample, split_u, weighted_delta_lobes
from pyrt.materials.library import MetallicRoughness, _check_choice
from pyrt.shaders import brdfs, fresnel
from pyrt.shaders import microfacet as _mf
from pyrt.shaders.vec import coordinate_frame, half_vector, reflect, to_local, to_world
from pyrt.textures import footprinted, perturb_normal

#: the index of refraction of glTF's clear coat (normal-incidence reflectance 0.04)
CLEARCOAT_IOR = 1.5


@register("clearcoat")
class Clearcoat(Layer):
    """A clear dielectric coat over a base material [clearcoat] (``KHR_materials_clearcoat``).

    ``f = base (1 - c F_c) + c F_c D_ggx G / (4 |n.l| |n.v|)``, ``F_c = F0 + (1 - F0)(1 - cos)^5`` with
    ``F0 = ((ior - 1)/(ior + 1))^2`` (0.04 at ior 1.5), ``c = clearcoat``, ``alpha = roughness^2`` (GGX,
    height-correlated Smith). The extension's ``fresnel_coat`` takes ``cos = |n.v|`` (``fresnel="view"``, the
    default): energy conserving whenever the base is (the coat lobe's Fresnel-free albedo is <= 1), not
    reciprocal (the weight depends on the viewer only). ``fresnel="half"`` takes ``cos = |v.h|`` of each
    direction pair instead: reciprocal, but then the base loses ``c F`` at the half vector of *its* directions
    while the coat gains it at the mirror direction, so a bright base at grazing view reflects more than it
    receives (white Lambert base, coat roughness 0.3: albedo 1.27 at 85 degrees, 0.90 with "view"; measured in
    tests/test_gltf_materials.py); kept as the documented alternative.

    The base's delta lobes are weighted ``1 - c F_c(n.v)``; its emission is not (emission sits on top of the
    coat, glTF). The coat's normal ``n`` is the surface's normal before the base's normal map
    (``ctx.ns_unmapped``: a base map does not tilt the coat), perturbed by the coat's own ``normal_map`` (glTF
    ``clearcoatNormalTexture``) if it has one; D, G, F and the cosines of the coat lobe are taken in that frame
    (the glTF sample viewer's ``NcdotL``, ``NcdotV``).

    Parameters
    ----------
    base : Material, optional
        The coated material (default :class:`pyrt.materials.MetallicRoughness` ()).
    clearcoat : float or scalar texture in [0, 1] (keyword-only, default 1)
    roughness : float or scalar texture in [0, 1] (keyword-only, default 0)
    ior : float > 0 (keyword-only, default 1.5)
    fresnel : "view" (default) or "half" (keyword-only)
    normal_map : NormalMap, optional (keyword-only)
        The coat's own tangent-space normal map.
    """

    ranges = {"clearcoat": ("scalar", 0.0, 1.0, False), "roughness": ("scalar", 0.0, 1.0, False),
              "coat_ior": ("scalar", 0.0, None, True)}

    def __init__(self, base=None, *, clearcoat=1.0, roughness=0.0, ior=CLEARCOAT_IOR, fresnel="view", normal_map=None,
                 name=None):
        self.name = name
        owner = self.label
        base = adopt_base(self, base)
        self.clearcoat = check_scalar("clearcoat", clearcoat, owner, lo=0.0, hi=1.0)
        self.roughness = check_scalar("roughness", roughness, owner, lo=0.0, hi=1.0)
        self.coat_ior = check_scalar("ior", ior, owner, lo=0.0, lo_open=True)
        self.fresnel = _check_choice(owner, "fresnel", fresnel, ("view", "half"))
        #: the coat's own normal map (None: the coat uses the shading normal)
        self.coat_normal_map = normal_map
        self.validate()

    #: the default ``fresnel="view"`` is not reciprocal (see the class docstring)
    reciprocal = False

    @classmethod
    def example(cls):
        """A coat over a red plastic (roughness 0.35: the contract tests' chi-square cells resolve the lobe)."""
        return cls(MetallicRoughness(base_color=(0.7, 0.1, 0.1), roughness=0.5), clearcoat=0.8, roughness=0.35)

    def validate(self):
        """The coat's ranges, its ``fresnel`` choice and normal map (None or a 3-channel texture) as they are now, then
        the base's; :attr:`reciprocal` follows ``fresnel``."""
        super().validate()
        _check_choice(self.label, "fresnel", self.fresnel, ("view", "half"))
        nm = self.coat_normal_map
        if nm is not None and not (is_texture(nm) and nm.channels == 3):
            raise MaterialError(f"{self.label}: normal_map must be None or a 3-channel texture (a pyrt.NormalMap), "
                                f"got {nm!r}")
        self.base.validate()
        self.reciprocal = self.fresnel == "half" and self.base.reciprocal

    def compiled_record(self, pack_texture):
        """:func:`~pyrt.materials.gltf_record.clearcoat_record`: the base's GLTF record with the coat's fields (None
        where the kernel cannot read the coat or its base)."""
        return _gltf.clearcoat_record(self, pack_texture)

    @property
    def uses_textures(self):
        """The coat's or the base's parameters (or the coat's normal map) are textures."""
        return (self.base.uses_textures or is_texture(self.clearcoat) or is_texture(self.roughness)
                or self.coat_normal_map is not None)

    @property
    def uses_footprints(self):
        return self.base.uses_footprints or footprinted(self.clearcoat, self.roughness, self.coat_normal_map)

    def _coat_frame(self, ctx):
        """``(s, t, n)`` (N, 3) each: the coat's frame in the local shading frame, or None (the coat uses it:
        neither the coat nor the base has a normal map)."""
        if self.coat_normal_map is None and self.base.normal_map is None:
            return None
        cache = ctx.__dict__.setdefault("_param_cache", {})
        key = (self, "coat_frame")
        if key not in cache:
            n0 = ctx.ns
            if self.base.normal_map is not None and ctx.ns_unmapped is not None:
                n0 = ctx.ns_unmapped                 # the base's map perturbed ns; the coat starts before it
            n = n0 if self.coat_normal_map is None else perturb_normal(ctx, self.coat_normal_map, ns=n0)
            n = ctx.to_local(n)
            n /= np.maximum(np.linalg.norm(n, axis=1, keepdims=True), 1e-300)
            cache[key] = (*coordinate_frame(n), n)
        return cache[key]

    def _to_coat(self, w, ctx):
        frame = self._coat_frame(ctx)
        return w if frame is None else to_local(w, *frame)

    def _alpha(self, ctx):
        return _mf.roughness_to_alpha(self.param(self.roughness, ctx, 1))

    def _f0(self):
        return float(fresnel.f0_from_ior(self.coat_ior))

    def coat_weight(self, wo, ctx, wi=None):
        """``c F_c`` (N,): at ``n.v`` (``fresnel="view"``, or ``wi`` None) or at ``v.h`` of ``(wo, wi)``; ``n`` the
        coat's normal (local shading-frame directions are turned into the coat's frame here)."""
        wo = self._to_coat(wo, ctx)
        if self.fresnel == "half" and wi is not None:
            wi = self._to_coat(wi, ctx)
            h, _ = half_vector(wo, wi)
            cos = np.abs(np.einsum("ij,ij->i", wo, h))
        else:
            cos = np.abs(wo[:, 2])
        return self.param(self.clearcoat, ctx, 1) * fresnel.fr_schlick(cos, self._f0())

    def _coat_spec(self, wo, wi, ctx):
        below_shading = (wo[:, 2] <= 0) | (wi[:, 2] <= 0)
        wo, wi = self._to_coat(wo, ctx), self._to_coat(wi, ctx)
        spec, _ = brdfs.microfacet_spec_cos(wo, wi, self._alpha(ctx), distribution="ggx", geometry="smith_correlated")
        return spec if self.coat_normal_map is None else np.where(below_shading, 0.0, spec)

    def f_cos(self, wo, wi, ctx):
        """``base (1 - c F_c) + c F_c D G / (4 cos_o)`` (times cos_i)."""
        cw = self.coat_weight(wo, ctx, wi)
        return self.base.f_cos(wo, wi, ctx) * (1.0 - cw)[:, None] + (cw * self._coat_spec(wo, wi, ctx))[:, None]

    def _coat_prob(self, wo, ctx):
        """Probability of sampling the coat lobe: ``c F_c(n.v)``, at least ``c / 4`` (the coat's peak is narrow)."""
        c = self.param(self.clearcoat, ctx, 1)
        return np.clip(np.maximum(self.coat_weight(wo, ctx), 0.25 * c), 0.0, 0.9)

    def pdf(self, wo, wi, ctx):
        """``p_coat`` GGX visible-normal reflection density plus ``1 - p_coat`` the base's."""
        p = self._coat_prob(wo, ctx)
        alpha = self._alpha(ctx)
        wo_c, wi_c = self._to_coat(wo, ctx), self._to_coat(wi, ctx)
        h, _ = half_vector(wo_c, wi_c)
        ok = (wo_c[:, 2] > 0) & (wi_c[:, 2] > 0) & (wo[:, 2] > 0)
        pc = np.where(ok, _mf.reflect_pdf(_mf.ggx_vndf_pdf(wo_c, h, alpha), wo_c, h), 0.0)
        return p * pc + (1.0 - p) * self.base.pdf(wo, wi, ctx)

    def sample(self, wo, u, ctx):
        """The coat's GGX visible normals with probability ``p_coat``, else the base's own sampling."""
        take, uu = split_u(u, self._coat_prob(wo, ctx))
        wb = self.base.sample_direction(wo, uu, ctx)
        wo_c = self._to_coat(wo, ctx)
        wc = reflect(wo_c, _mf.sample_ggx_vndf(wo_c, uu, self._alpha(ctx)))
        valid_c = wc[:, 2] > 0
        frame = self._coat_frame(ctx)
        if frame is not None:
            wc = to_world(wc, *frame)
        wi = np.where(take[:, None], wc, wb)
        valid = np.where(take, valid_c & (wo_c[:, 2] > 0), np.any(wb != 0, axis=1)) & (wo[:, 2] > 0)
        return finish_sample(self, wo, wi, valid, ctx)

    def delta_lobes(self, wo, ctx, *, eta=None):
        """The base's delta lobes weighted ``1 - c F_c(n.v)``."""
        return weighted_delta_lobes(self.base, wo, ctx, eta, lambda w, c: 1.0 - self.coat_weight(w, c))

    def glossy_alpha(self, ctx):
        """The coat's alpha where it coats (``c > 0``), else the base's."""
        a = self.base.glossy_alpha(ctx)
        base_a = np.full(ctx.n_hits, np.inf) if a is None else np.asarray(a, dtype=np.float64)
        coat = np.broadcast_to(self._alpha(ctx), (ctx.n_hits,))
        c = np.broadcast_to(self.param(self.clearcoat, ctx, 1), (ctx.n_hits,))
        return np.where(c > 0, np.minimum(coat, base_a), base_a)

    def preview_lobes(self, ctx):
        """The base's lobes times ``1 - c F_c(n_c.v)`` plus the coat's GGX lobe of albedo ``c F_c (A + B)`` about
        the coat's normal ``n_c`` (``fresnel="view"``; None for ``"half"`` or a base without lobes)."""
        if self.fresnel != "view":
            return None
        lobes = self.base.preview_lobes(ctx)
        if lobes is None:
            return None
        frame = self._coat_frame(ctx)
        n_c = ctx.ns if frame is None else ctx.to_world(frame[2])
        mu = _preview.view_cosine(ctx, n_c)
        cw = self.coat_weight(ctx.to_local(ctx.wo), ctx)
        alpha = np.broadcast_to(self._alpha(ctx), (ctx.n_hits,))
        coat = (cw * _preview.fresnel_free_albedo(mu, alpha, "smith_correlated"))[:, None]
        out = lobes.scaled(1.0 - cw)
        out.glossy.append(_preview.GlossyLobe(np.repeat(coat, 3, axis=1), alpha, None if frame is None else n_c))
        return out

    def albedo(self, ctx):
        """The base's albedo (the ambient term and the albedo AOV)."""
        return self.base.albedo(ctx)

    def emission(self, ctx):
        """The base's emission (on top of the coat: not attenuated)."""
        return self.base.emission(ctx)


@register("unlit")
class Unlit(Material):
    """A surface that shows its colour and nothing else [unlit] (``KHR_materials_unlit``).

    Emitted radiance ``color`` (W m^-2 sr^-1; the glTF base colour x texture x vertex colour), no reflection,
    no shadow-ray work: lights, shadows and the environment do not change it, so its pixels are exactly
    ``color`` (times the throughput of the rays that reach it). It is no light: other surfaces are not lit by it
    (pyrt samples only declared lights), though glossy rays do see it.

    Parameters
    ----------
    color : RGB or texture >= 0 (default 1)
    """

    has_diffuse = False
    emits = True
    ranges = {"color": ("color", 0.0, None, False)}

    def __init__(self, color=1.0, *, name=None):
        self.name = name
        self.color = check_color("color", color, self.label, lo=0.0)

    def compiled_record(self, pack_texture):
        """:func:`~pyrt.materials.gltf_record.unlit_record` (None where the kernel cannot read the colour)."""
        return _gltf.unlit_record(self, pack_texture)

    def albedo(self, ctx):
        """The colour (the albedo AOV)."""
        return np.array(self.param(self.color, ctx))

    def emission(self, ctx):
        """The colour, as emitted radiance."""
        return np.array(self.param(self.color, ctx))
