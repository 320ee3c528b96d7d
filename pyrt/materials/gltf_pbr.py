"""glTF's material extensions as pyrt materials: the extended metallic-roughness BSDF (``KHR_materials_specular``,
``_ior``, ``_transmission``, ``_volume``, ``_anisotropy``); the clear coat layer (``KHR_materials_clearcoat``) and unlit
surfaces (``KHR_materials_unlit``) are in :mod:`pyrt.materials.gltf_layers`. Scene-file ``type`` names in brackets;
built by :mod:`pyrt.io.assets.gltf`.

- :class:`GltfPBR` [gltf_pbr]: :class:`pyrt.materials.MetallicRoughness` with the dielectric F0 from ``ior`` times
  ``specular_color``, the specular weight ``specular`` (kernel :func:`pyrt.shaders.brdfs.gltf_pbr_f_cos`) and a
  transmission lobe of weight ``(1 - metallic) transmission``: a thin wall (straight through,
  :func:`pyrt.shaders.brdfs.thin_transmission_spec_cos` when rough) or the surface of a volume (refraction by ``ior``,
  :class:`pyrt.Glass` when smooth, :class:`pyrt.RoughDielectric`'s GGX BTDF when rough) with Beer-Lambert
  ``absorption`` inside; ``anisotropy`` stretches the reflection's GGX lobe along a tangent direction
  (``KHR_materials_anisotropy``).
"""
from __future__ import annotations

import numpy as np

from pyrt.core.checks import Fixed
from pyrt.materials import gltf_record as _gltf, preview as _preview
from pyrt.materials.base import DeltaLobe, MaterialError, check_color, check_scalar, is_texture, register
from pyrt.materials.layering import finish_sample, split_u
from pyrt.materials.library import MetallicRoughness
from pyrt.materials.tint import TransmittedTint, transmitted_tint
from pyrt.shaders import brdfs, fresnel
from pyrt.shaders import microfacet as _mf
from pyrt.shaders.textures import tangent_frame
from pyrt.shaders.vec import half_vector, reflect, refract, to_azimuth_frame

#: roughness at or below which a transmission lobe is perfectly specular (delta lobes, traced to ``max_depth`` by
#: every integrator); above it the lobe is a GGX BTDF sampled by the glossy integrator
SMOOTH_ROUGHNESS = 0.03
_FLIP_Z = np.array([1.0, 1.0, -1.0])


@register("gltf_pbr")
class GltfPBR(MetallicRoughness):
    """glTF metallic-roughness with ``KHR_materials_specular``, ``_ior``, ``_transmission`` and ``_volume`` [gltf_pbr].

    Reflection (:func:`pyrt.shaders.brdfs.gltf_pbr_f_cos`): the dielectric F0 is
    ``min(((ior - 1) / (ior + 1))^2 specular_color, 1)`` and ``specular`` weighs the specular layer (the
    diffuse keeps ``1 - specular max(F)``), as ``KHR_materials_specular`` defines them; metals use the base
    colour. The transmission lobe has weight ``(1 - metallic) transmission`` and is tinted by the base colour
    (glTF: ``mix(diffuse, specular_btdf * baseColor, transmission)`` under the same specular layer):

    - ``thin=True`` (no ``KHR_materials_volume``, or thicknessFactor 0): a thin wall; light goes straight through,
      weighted ``1 - specular max(F)`` (the same F as the reflection, so the two sum to one), spread by the
      roughness as the reflection is (the GGX lobe mirrored through the surface plane);
    - ``thin=False``: the boundary of a volume of index ``ior`` (Snell, exact Fresnel ``1 - R`` and the ``1 / eta^2``
      radiance compression as :class:`pyrt.Glass`; GGX BTDF of :class:`pyrt.RoughDielectric` when rough) whose
      medium absorbs ``exp(-absorption d)`` along a path of length ``d`` (``absorption = -ln(attenuationColor) /
      attenuationDistance``; nested media and absorption: :mod:`pyrt.integrators.media`).

    Up to :data:`SMOOTH_ROUGHNESS` the transmissive share ``w`` is a smooth interface given as delta lobes, traced to
    ``max_depth`` by every integrator: an untinted mirror reflection ``w R`` and the tinted transmission ``w (1 - R)``
    (``R`` the exact Fresnel of a volume, with total internal reflection, as :class:`pyrt.Glass`; ``R = specular F``
    with the reflection's Schlick F for a thin wall); the opaque share ``1 - w`` keeps the GGX lobes. Above it the
    transmission is a BTDF that the glossy integrator samples at every bounce (:meth:`rough_transmission`) and the
    reflection the base model's GGX lobe. Not modelled: ``specular`` on the transmitted weight of a volume, total
    internal reflection of a rough volume beyond its BTDF's.

    Anisotropy (``KHR_materials_anisotropy``): with ``anisotropy`` (the strength) > 0 the reflection's GGX lobe (metal
    and dielectric) has the width ``alpha_t = mix(alpha, 1, strength^2)`` along the direction ``t`` and ``alpha_b =
    alpha`` across it, ``b = n x t`` (the extension's ``D``, and its height-correlated visibility with
    ``geometry="smith_correlated"``; the separable product of the same anisotropic ``G1`` with the default
    ``"smith_separable"``), sampled by anisotropic visible normals (Heitz 2018). ``t`` is
    ``normalize((cos r, sin r) rotated (x, y))`` in the tangent frame ``(T, B)`` of the normal maps
    (:func:`pyrt.shaders.textures.tangent_frame` of :meth:`pyrt.geometry.SurfaceBatch.shading_tangents`: the mesh's
    vertex tangents, glTF ``TANGENT``, else ``dpdu``, ``dpdv`` of the texture's UV set; around the shading normal),
    ``r = anisotropy_rotation`` (radians, counter-clockwise from ``T`` toward ``B``), ``(x, y) = 2 RG - 1`` of
    ``anisotropy_texture`` (``(1, 0)`` without one, or where it is ``(0, 0)``), and the strength is ``anisotropy x``
    its B. Approximations: the transmission lobe and the smooth transmissive share stay isotropic
    (the extension's lobe is the specular BRDF); :meth:`glossy_alpha` is ``alpha_b = alpha``, the smaller width (a
    lobe that is sharp across ``t`` shows sharp reflections, so the glossy integrator traces them as it would for
    the isotropic lobe of that roughness); the preview's split sum lights one isotropic lobe of the geometric mean
    ``sqrt(alpha_t alpha_b)`` (the width whose lobe covers about the same solid angle), so its highlight is not
    stretched.

    Parameters (keyword-only)
    -------------------------
    base_color, metallic, roughness, geometry : as :class:`pyrt.materials.MetallicRoughness`
    specular : float or scalar texture in [0, 1] (default 1)
    specular_color : RGB or texture >= 0 (default 1)
    ior : float >= 1 (default 1.5): the dielectric F0 and, with transmission, the refraction index
    transmission : float or scalar texture in [0, 1] (default 0: opaque)
    thin : bool (default True), absorption : constant RGB >= 0 per scene unit (volumes only)
    anisotropy : float in [0, 1] (default 0: isotropic), anisotropy_rotation : float (radians, default 0)
    anisotropy_texture : 3-channel texture, optional: ``anisotropyTexture`` (linear; RG the direction, B the strength)
    """

    transmission, thin, ior_value = Fixed("its lobes derive from it"), Fixed("its lobes too"), Fixed("ior too")
    ranges = {**MetallicRoughness.ranges, "specular": ("scalar", 0.0, 1.0, False),
              "specular_color": ("color", 0.0, None, False), "ior_value": ("scalar", 1.0, None, False),
              "transmission": ("scalar", 0.0, 1.0, False), "anisotropy": ("scalar", 0.0, 1.0, False)}

    def __init__(self, *, base_color=0.8, metallic=0.0, roughness=0.5, specular=1.0, specular_color=1.0, ior=1.5,
                 transmission=0.0, thin=True, absorption=0.0, geometry="smith_separable", anisotropy=0.0,
                 anisotropy_rotation=0.0, anisotropy_texture=None, name=None):
        super().__init__(base_color=base_color, metallic=metallic, roughness=roughness, geometry=geometry, name=name)
        owner = self.label
        self.anisotropy = check_scalar("anisotropy", anisotropy, owner, lo=0.0, hi=1.0)
        self.anisotropy_rotation = check_scalar("anisotropy_rotation", anisotropy_rotation, owner)
        if is_texture(self.anisotropy) or is_texture(self.anisotropy_rotation):
            raise MaterialError(f"{owner}: anisotropy and anisotropy_rotation must be constants "
                                "(the strength and direction vary through anisotropy_texture)")
        if anisotropy_texture is not None and (not is_texture(anisotropy_texture) or anisotropy_texture.channels != 3):
            raise MaterialError(f"{owner}: anisotropy_texture must be a 3-channel texture (RG direction, B strength)")
        self.anisotropy_texture = anisotropy_texture
        self.specular = check_scalar("specular", specular, owner, lo=0.0, hi=1.0)
        self.specular_color = check_color("specular_color", specular_color, owner, lo=0.0)
        #: the index of refraction of the dielectric part (``ior`` proper is set only when the material transmits)
        self.ior_value = check_scalar("ior", ior, owner, lo=1.0)
        if is_texture(self.ior_value):
            raise MaterialError(f"{owner}: ior must be a constant")
        self.transmission = check_scalar("transmission", transmission, owner, lo=0.0, hi=1.0)
        self.thin = bool(thin)
        sigma = check_color("absorption", absorption, owner, lo=0.0)
        if is_texture(sigma):
            raise MaterialError(f"{owner}: absorption must be a constant RGB")
        if is_texture(self.transmission) or self.transmission > 0:
            self.is_dielectric = self.transmits = self.has_delta = True
            self.thin_walled = self.thin
            self.ior = self.ior_value
            self._tint = TransmittedTint(self)
            if not self.thin:
                self.absorption = sigma
        elif np.any(sigma > 0):
            raise MaterialError(f"{owner}: absorption needs transmission > 0 (an opaque surface encloses no medium)")
        if self.thin and np.any(sigma > 0):
            raise MaterialError(f"{owner}: a thin wall (thin=True) encloses no medium to absorb in; use thin=False")

    def compiled_record(self, pack_texture):
        """:meth:`compiled_record_extras` without extras."""
        return self.compiled_record_extras(pack_texture)

    def compiled_record_extras(self, pack_texture, *, emission=0.0, occlusion=None, occlusion_strength=1.0):
        """:func:`~pyrt.materials.gltf_record.gltf_pbr_record` (None where the kernel cannot read the material)."""
        return _gltf.gltf_pbr_record(self, pack_texture, emission=emission, occlusion=occlusion,
                                     occlusion_strength=occlusion_strength)

    @property
    def smooth_transmission(self):
        """Transmits through delta lobes alone: a constant ``roughness`` at most :data:`SMOOTH_ROUGHNESS`."""
        return self.transmits and not is_texture(self.roughness) and float(self.roughness) <= SMOOTH_ROUGHNESS

    @property
    def tint(self):
        """The transmission's colour per interface, ``base_color (1 - metallic) transmission`` from the parameters as
        they are now (:func:`pyrt.materials.tint.transmitted_tint`); 1 when the material does not transmit."""
        return transmitted_tint(self, self._tint) if self.transmits else 1.0

    @classmethod
    def example(cls):
        """An opaque instance with the specular extension (transmission has its own tests)."""
        return cls(base_color=(0.8, 0.5, 0.3), roughness=0.4, specular=0.7, specular_color=(1.0, 0.8, 0.6), ior=1.7)

    # -- per-hit parameters ------------------------------------------------------------------
    @property
    def anisotropic(self):
        """The reflection lobe is anisotropic (``anisotropy > 0``)."""
        return self.anisotropy > 0

    def _anisotropy(self, ctx):
        """``(t, strength)``: the anisotropy direction ``t`` (N, 2), a unit vector in the local tangent plane (the
        local frame's x, y), and the strength (N,) (the class docstring); None when :attr:`anisotropic` is False.
        Cached on ``ctx``."""
        if not self.anisotropic:
            return None
        cache = ctx.__dict__.setdefault("_param_cache", {})
        key = (self, "anisotropy")
        if key not in cache:
            n = ctx.n_hits
            c, s = np.cos(self.anisotropy_rotation), np.sin(self.anisotropy_rotation)
            strength = np.full(n, float(self.anisotropy))
            tex = self.anisotropy_texture
            d = np.tile([c, s], (n, 1))
            if tex is not None:
                rgb = np.asarray(self.param(tex, ctx), dtype=np.float64)
                strength = strength * rgb[:, 2]
                x, y = 2.0 * rgb[:, 0] - 1.0, 2.0 * rgb[:, 1] - 1.0
                given = (x != 0) | (y != 0)          # (0, 0) has no direction: the rotated T, as without a texture
                d = np.where(given[:, None], np.stack([c * x - s * y, s * x + c * y], axis=1), d)
            k = 0 if tex is None else tex.texcoord
            dpdu, dpdv = ctx.shading_tangents(k)
            ns = np.asarray(ctx.ns, dtype=np.float64)
            tw, bw = tangent_frame(ns, np.asarray(dpdu, dtype=np.float64), np.asarray(dpdv, dtype=np.float64))
            t = np.asarray(ctx.to_local(d[:, :1] * tw + d[:, 1:2] * bw), dtype=np.float64)[:, :2]
            length = np.hypot(t[:, 0], t[:, 1])
            ok = length > 0
            t = np.where(ok[:, None], t / np.where(ok, length, 1.0)[:, None], np.array([1.0, 0.0]))
            cache[key] = (t, strength)
        return cache[key]

    def _preview_alpha(self, ctx):
        """The isotropic width (N,) the preview lights: ``alpha``, or ``sqrt(alpha_t alpha_b)`` when anisotropic."""
        alpha = np.broadcast_to(self._alpha(ctx), (ctx.n_hits,))
        aniso = self._anisotropy(ctx)
        if aniso is None:
            return alpha
        return np.sqrt(_mf.gltf_anisotropic_alpha(alpha, aniso[1]) * alpha)

    def _f0_dielectric(self, ctx):
        """``min(f0(ior) * specular_color, 1)``: (3,) or (N, 3)."""
        sc = self.param(self.specular_color, ctx) if is_texture(self.specular_color) else self.specular_color
        return np.minimum(fresnel.f0_from_ior(self.ior_value) * np.asarray(sc, dtype=np.float64), 1.0)

    def _transmission_weights(self, ctx):
        """``(w_rough, w_smooth)`` (N,): ``(1 - metallic) transmission`` on hits above / at most
        :data:`SMOOTH_ROUGHNESS`."""
        if not self.transmits:
            z = np.zeros(ctx.n_hits)
            return z, z
        w = (1.0 - self.param(self.metallic, ctx, 1)) * self.param(self.transmission, ctx, 1)
        smooth = self.param(self.roughness, ctx, 1) <= SMOOTH_ROUGHNESS
        return np.where(smooth, 0.0, w), np.where(smooth, w, 0.0)

    def _transmission_choice(self, wo, ctx, w_rough):
        """The probability (N,) that :meth:`sample` draws the rough transmission lobe: ``w_rough (1 - specular
        F(cos_o))``, ``F`` Schlick of the dielectric F0's largest channel at the view's cosine (an estimate of the
        share of the specular reflection, which stays on top of a fully transmitting surface: with ``w_rough``
        alone, ``transmission = 1`` and ``metallic = 0`` never drew a reflected direction, and the glossy rays and
        the environment's BSDF samples missed its highlight). Below 1 wherever the reflection is not zero."""
        f0 = np.max(np.broadcast_to(self._f0_dielectric(ctx), (wo.shape[0], 3)), axis=1)
        # (N, 1): fr_schlick reads an (N,) f0 of three hits as RGB (a 3 x 3 table)
        f = fresnel.fr_schlick(np.clip(wo[:, 2], 0.0, 1.0), f0[:, None])[:, 0]
        return w_rough * (1.0 - self.param(self.specular, ctx, 1) * f)

    def _eta(self, ctx):
        """``eta_t / eta_i`` of the single interface: ``ior`` from the front, ``1 / ior`` from inside."""
        return np.where(ctx.front, self.ior_value, 1.0 / self.ior_value)

    # -- the BSDF ----------------------------------------------------------------------------
    def _reflection(self, wo, wi, ctx):
        tr, share = 0.0, 1.0
        if self.transmits:
            tr = self.param(self.transmission, ctx, 1)
            share = np.where(self.param(self.roughness, ctx, 1) <= SMOOTH_ROUGHNESS, 1.0 - tr, 1.0)
        aniso = self._anisotropy(ctx)
        strength = 0.0
        if aniso is not None:     # the lobe's frame: x along the anisotropy direction (the rest is azimuth-free)
            wo, wi, strength = to_azimuth_frame(wo, aniso[0]), to_azimuth_frame(wi, aniso[0]), aniso[1]
        return brdfs.gltf_pbr_f_cos(wo, wi, self.param(self.base_color, ctx), self.param(self.metallic, ctx, 1),
                                    self.param(self.roughness, ctx, 1), f0_dielectric=self._f0_dielectric(ctx),
                                    specular=self.param(self.specular, ctx, 1), transmission=tr,
                                    specular_share=share, geometry=self.geometry, anisotropy=strength)

    def _btdf(self, wo, wi, ctx):
        """The transmission lobe without its weight (N,): thin (mirrored GGX times ``1 - specular max F``) or
        the volume's GGX BTDF (Walter 2007, below the horizon only)."""
        alpha = self._alpha(ctx)
        if self.thin:
            spec, cos_oh = brdfs.thin_transmission_spec_cos(wo, wi, alpha)
            F = fresnel.fr_schlick(cos_oh, np.broadcast_to(self._f0_dielectric(ctx), (wo.shape[0], 3)))
            return spec * (1.0 - self.param(self.specular, ctx, 1) * F.max(axis=1))
        ft = brdfs.rough_dielectric_f_cos(wo, wi, alpha, self._eta(ctx))
        return np.where(wi[:, 2] < 0, ft, 0.0)

    def f_cos(self, wo, wi, ctx):
        """Reflection above the horizon; the rough transmission lobe below it (tinted by the base colour)."""
        out = self._reflection(wo, wi, ctx)
        w_rough, _ = self._transmission_weights(ctx)
        if np.any(w_rough > 0):
            out = out + (w_rough * self._btdf(wo, wi, ctx))[:, None] * self.param(self.base_color, ctx)
        return out

    def _btdf_pdf(self, wo, wi, ctx):
        alpha = self._alpha(ctx)
        if self.thin:
            flipped = wi * _FLIP_Z
            h, _ = half_vector(wo, flipped)
            pdf = _mf.reflect_pdf(_mf.ggx_vndf_pdf(wo, h, alpha), wo, h)
            return np.where((wi[:, 2] < 0) & (wo[:, 2] > 0), pdf, 0.0)
        return brdfs.rough_dielectric_pdf(wo, wi, alpha, self._eta(ctx))

    def pdf(self, wo, wi, ctx):
        """Mixture of the reflection strategies (weight ``1 - c``) and the transmission lobe's (``c``,
        :meth:`_transmission_choice`)."""
        w_rough, _ = self._transmission_weights(ctx)
        p = super().pdf(wo, wi, ctx)
        if not np.any(w_rough > 0):
            return p
        p = np.where(wi[:, 2] > 0, p, 0.0)
        c = self._transmission_choice(wo, ctx, w_rough)
        return (1.0 - c) * p + c * self._btdf_pdf(wo, wi, ctx)

    def sample(self, wo, u, ctx):
        """The reflection strategies, or with probability :meth:`_transmission_choice` the transmission lobe (visible
        GGX normals)."""
        w_rough, _ = self._transmission_weights(ctx)
        if not np.any(w_rough > 0):
            return super().sample(wo, u, ctx)
        wi, valid = self._mixture_direction(wo, u, ctx, w_rough)
        return finish_sample(self, wo, wi, valid, ctx)

    def sample_direction(self, wo, u, ctx):
        """The direction :meth:`sample` draws (zero where it is invalid, as there), without its weight and pdf."""
        w_rough, _ = self._transmission_weights(ctx)
        if not np.any(w_rough > 0):
            return super().sample_direction(wo, u, ctx)
        wi, valid = self._mixture_direction(wo, u, ctx, w_rough)
        return np.where(valid[:, None], wi, 0.0)

    def _mixture_direction(self, wo, u, ctx, w_rough):
        """``(wi, valid)``: the reflection strategies' direction, or with probability :meth:`_transmission_choice`
        the transmission lobe's."""
        take, uu = split_u(u, self._transmission_choice(wo, ctx, w_rough))
        wi = super().sample_direction(wo, uu, ctx)
        alpha = self._alpha(ctx)
        if self.thin:
            wt = reflect(wo, _mf.sample_ggx_vndf(wo, uu, alpha)) * _FLIP_Z
            ok = wt[:, 2] < 0
        else:
            wt, ok = brdfs.sample_rough_dielectric(wo, uu, alpha, self._eta(ctx))
        valid = np.where(take, ok, wi[:, 2] > 0) & (wo[:, 2] > 0)
        return np.where(take[:, None], wt, wi), valid

    def delta_lobes(self, wo, ctx, *, eta=None):
        """The smooth transmissive share ``w``: its mirror reflection, and the light straight through a thin wall
        or refracted into / out of the volume (``eta`` from the ray's interface stack when the integrator gives
        it; total internal reflection: R = 1)."""
        _, w = self._transmission_weights(ctx)
        if not np.any(w > 0):
            return []
        tint = self.param(self.base_color, ctx)
        cos_o = wo[:, 2]
        nz = np.zeros_like(wo)
        nz[:, 2] = 1.0
        wr = reflect(wo, nz)
        if self.thin:
            s = self.param(self.specular, ctx, 1)
            F = s[:, None] * fresnel.fr_schlick(cos_o, np.broadcast_to(self._f0_dielectric(ctx), (wo.shape[0], 3)))
            t = w * (1.0 - F.max(axis=1))
            return [DeltaLobe(wr, w[:, None] * F, "reflect"),
                    DeltaLobe(-wo, tint * t[:, None], "refract", np.ones(wo.shape[0]))]
        if eta is None:
            eta = self._eta(ctx)
        wt, tir = refract(wo, nz, eta)
        R = np.where(tir, 1.0, fresnel.fr_dielectric(cos_o, eta))
        lobes = [DeltaLobe(wr, np.repeat((w * R)[:, None], 3, axis=1), "reflect")]
        if np.any((w > 0) & ~tir):
            lobes.append(DeltaLobe(wt, tint * (w * (1.0 - R) / (eta * eta))[:, None], "refract", eta))
        return lobes

    def rough_transmission(self, ctx):
        """Hits with a rough transmissive share (roughness above :data:`SMOOTH_ROUGHNESS`: the GGX BTDF)."""
        return self._transmission_weights(ctx)[0] > 0

    def preview_lobes(self, ctx):
        """Split-sum lobes of the reflection half (None where the batch has rough transmission: the preview samples
        it): diffuse ``(1 - m)(1 - t) base (1 - s (F0m + (1 - F0m) E5))`` (``F0m`` the largest channel of the
        dielectric F0, as the BRDF's ``max(F)``; ``t`` the transmission), one GGX lobe of albedo
        ``(1 - m) s k (F0_d A + B) + m (base A + B)`` with ``k = 1 - t`` on smooth transmitting hits, whose
        mirror share is a delta lobe traced as a ray (:meth:`delta_lobes`), else 1; an anisotropic lobe is lit as the
        isotropic one of width ``sqrt(alpha_t alpha_b)`` (the class docstring)."""
        tr = share = 0.0
        if self.transmits:
            w_rough, _ = self._transmission_weights(ctx)
            if np.any(w_rough > 0):
                return None
            tr = self.param(self.transmission, ctx, 1)[:, None]
            share = np.where(self.param(self.roughness, ctx, 1) <= SMOOTH_ROUGHNESS, 1.0 - tr[:, 0], 1.0)[:, None]
        base = np.asarray(self.param(self.base_color, ctx))
        m = self.param(self.metallic, ctx, 1)[:, None]
        s = self.param(self.specular, ctx, 1)[:, None]
        alpha = self._preview_alpha(ctx)
        mu = _preview.view_cosine(ctx)
        f0d = np.broadcast_to(self._f0_dielectric(ctx), base.shape)
        f0m = f0d.max(axis=1, keepdims=True)
        diffuse = (1.0 - m) * (1.0 - s * (f0m + (1.0 - f0m) * _preview.schlick_diffuse_loss(mu))) * base
        s_d = s
        if self.transmits:
            diffuse = diffuse * (1.0 - tr)
            s_d = s * share
        spec = ((1.0 - m) * s_d * _preview.schlick_albedo(f0d, mu, alpha, self.geometry)
                + m * _preview.schlick_albedo(base, mu, alpha, self.geometry))
        return _preview.PreviewLobes(diffuse, [_preview.GlossyLobe(spec, alpha)])

    def albedo(self, ctx):
        """The base colour times the opaque share ``1 - (1 - metallic) transmission``."""
        a = np.array(self.param(self.base_color, ctx))
        if not self.transmits:
            return a
        w = (1.0 - self.param(self.metallic, ctx, 1)) * self.param(self.transmission, ctx, 1)
        return a * (1.0 - w)[:, None]
