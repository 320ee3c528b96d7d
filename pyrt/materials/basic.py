"""The four basic materials: Lambert, energy-normalised Blinn-Phong, mirror, glass."""
from __future__ import annotations

import numpy as np

from pyrt.materials.base import IsotropicMaterial, Material, MaterialError, DeltaLobe, check_color, check_scalar, \
    is_texture, register
from pyrt.materials import compiled as _compiled
from pyrt.shaders import brdfs
from pyrt.shaders import fresnel
from pyrt.shaders import microfacet
from pyrt.shaders import sampling
from pyrt.shaders.vec import reflect, refract


@register("lambert")
class Lambert(IsotropicMaterial):
    """Lambertian diffuse: BRDF ``albedo / pi``; optional emitted radiance ``emission`` (W/m^2/sr).

    Parameters
    ----------
    albedo : RGB, float or Texture
        Diffuse reflectance rho in [0, 1].
    emission : RGB, float or Texture
        Emitted radiance (W m^-2 sr^-1), default 0.
    name : str, optional
    """

    lambertian = True

    def __init__(self, albedo=0.8, *, emission=0.0, name=None):
        self.name = name
        self.albedo_value, self.emission_value = albedo, emission
        self.validate()

    def validate(self):
        """``albedo`` in [0, 1] and ``emission`` >= 0 (RGB, grey or a texture)."""
        self.albedo_value = check_color("albedo", self.albedo_value, self.label, lo=0.0, hi=1.0)
        self.emission_value = check_color("emission", self.emission_value, self.label, lo=0.0)
        super().validate()

    @property
    def emits(self):
        """True unless the emission is a constant zero."""
        e = self.emission_value
        return is_texture(e) or bool(np.any(np.asarray(e) > 0))

    def compiled_record(self, pack_texture):
        """:data:`pyrt.materials.compiled.LAMBERT`: the albedo (constant or a texture the kernel reads), a constant
        emission."""
        albedo, vc = _compiled.vertex_slot(self.albedo_value, pack_texture, _compiled.pack_color_slot)
        if albedo is None or is_texture(self.emission_value):
            return None
        rec = _compiled.empty_record()
        rec[0:4] = albedo
        rec[_compiled.VERTEX_COLOR] = vc
        rec[4:7] = np.broadcast_to(self.emission_value, (3,))
        return _compiled.LAMBERT, rec

    def f_cos_cosines(self, q):
        """``rho / pi * cos(theta_i)`` (:func:`pyrt.shaders.brdfs.lambert_f_cos_cosines`)."""
        return brdfs.lambert_f_cos_cosines(q.cos_o, q.cos_i, q.param(self, self.albedo_value))

    def sample(self, wo, u, ctx):
        wi = sampling.square_to_cosine_hemisphere(u)
        pdf = sampling.cosine_hemisphere_pdf(wi)
        active = (wo[:, 2] > 0) & (pdf > 0)
        weight = np.where(active[:, None], self.param(self.albedo_value, ctx), 0.0)
        return wi, weight, pdf

    def albedo(self, ctx):
        return np.array(self.param(self.albedo_value, ctx))

    def emission(self, ctx):
        return np.array(self.param(self.emission_value, ctx))


@register("blinn_phong")
class BlinnPhong(IsotropicMaterial):
    """Energy-normalised Blinn-Phong: ``kd/pi + ks c(n) (n.h)^n`` (reciprocal), with the exact
    normalisation ``c(n) = (n+2)(n+4) / (8 pi (2^(-n/2) + n))`` (shaders.brdfs.blinn_phong_normalization).

    ``kd + ks <= 1`` per channel is required so that the model conserves energy.
    """


    def __init__(self, kd=0.5, ks=0.04, exponent=64.0, *, name=None):
        self.name = name
        self.kd, self.ks, self.exponent = kd, ks, exponent
        self.validate()

    def validate(self):
        """``kd``, ``ks`` in [0, 1] with ``kd + ks <= 1`` per channel, ``exponent`` >= 0."""
        owner = self.label
        self.kd = check_color("kd", self.kd, owner, lo=0.0, hi=1.0)
        self.ks = check_color("ks", self.ks, owner, lo=0.0, hi=1.0)
        self.exponent = check_scalar("exponent", self.exponent, owner, lo=0.0)
        if not is_texture(self.kd) and not is_texture(self.ks) and np.any(self.kd + self.ks > 1.0 + 1e-12):
            raise MaterialError(f"{owner}: kd + ks must be <= 1 per channel, got {(self.kd + self.ks).tolist()}")
        super().validate()

    def compiled_record(self, pack_texture):
        """:data:`pyrt.materials.compiled.BLINN_PHONG`: kd (constant or a texture the kernel reads), constant ks and
        exponent (fields 4-6, 7; 8-10 the emission of :meth:`compiled_record_extras`, zero here)."""
        kd, vc = _compiled.vertex_slot(self.kd, pack_texture, _compiled.pack_color_slot)
        if kd is None or is_texture(self.ks) or is_texture(self.exponent):
            return None
        rec = _compiled.empty_record()
        rec[0:4] = kd
        rec[_compiled.VERTEX_COLOR] = vc
        rec[4:7] = np.broadcast_to(self.ks, (3,))
        rec[7] = float(self.exponent)
        return _compiled.BLINN_PHONG, rec

    def compiled_record_extras(self, pack_texture, *, emission=0.0, occlusion=None, occlusion_strength=1.0):
        """:meth:`compiled_record` with a constant emission (OBJ/MTL ``Ke``: fields 8-10); None with occlusion or a
        textured emission."""
        out = BlinnPhong.compiled_record(self, pack_texture)      # (the extras' mixin overrides compiled_record)
        if out is None or occlusion is not None or is_texture(emission):
            return None
        out[1][8:11] = np.broadcast_to(np.asarray(emission, dtype=np.float64).reshape(-1), (3,))
        return out

    def f_cos_cosines(self, q):
        """:func:`pyrt.shaders.brdfs.blinn_phong_normalized_f_cos_cosines` (a constant exponent stays a float)."""
        return brdfs.blinn_phong_normalized_f_cos_cosines(q.cos_o, q.cos_i, q.cos_io(), q.param(self, self.kd),
                                                          q.param(self, self.ks), q.param(self, self.exponent, 1))

    def glossy_alpha(self, ctx):
        """``alpha = sqrt(2 / (n + 2))`` (:func:`pyrt.shaders.microfacet.alpha_from_blinn_exponent`)."""
        a = microfacet.alpha_from_blinn_exponent(self.param(self.exponent, ctx, 1))
        return np.broadcast_to(np.asarray(a, dtype=np.float64).reshape(-1), (ctx.n_hits,)).copy()

    def albedo(self, ctx):
        return np.array(self.param(self.kd, ctx))


@register("mirror")
class Mirror(Material):
    """Perfect mirror with reflectance ``reflectance`` (RGB): ``L = reflectance * L(reflect(wo))``."""

    has_diffuse = False
    has_delta = True

    def __init__(self, reflectance=1.0, *, name=None):
        self.name = name
        self.reflectance = reflectance
        self.validate()

    def validate(self):
        """``reflectance`` in [0, 1]."""
        self.reflectance = check_color("reflectance", self.reflectance, self.label, lo=0.0, hi=1.0)
        super().validate()

    def compiled_record(self, pack_texture):
        """:data:`pyrt.materials.compiled.MIRROR` with a constant reflectance."""
        if is_texture(self.reflectance):
            return None
        rec = _compiled.empty_record()
        rec[0:3] = np.broadcast_to(self.reflectance, (3,))
        return _compiled.MIRROR, rec

    def delta_lobes(self, wo, ctx, *, eta=None):
        """The mirror lobe: ``reflect(wo)`` weighted by the reflectance."""
        n = np.zeros_like(wo)
        n[:, 2] = 1.0
        return [DeltaLobe(reflect(wo, n), np.array(self.param(self.reflectance, ctx)), "reflect")]


@register("glass")
class Glass(Material):
    """Smooth dielectric with index of refraction ``ior`` (relative to the surrounding medium, vacuum = 1).

    Exact unpolarised Fresnel reflectance R splits the ray: reflection weighted R, refraction
    weighted (1 - R) / eta^2 with ``eta = eta_t / eta_i`` (``tint`` multiplies both); total internal
    reflection gives R = 1. The 1/eta^2 factor is the radiance compression across the interface
    (radiance / eta^2 is invariant along a ray), as in pbrt-v4 and Mitsuba 3 in radiance mode; through
    a closed object the factors of entering and leaving cancel. Energy: R + (1 - R) = 1 (tested).

    Nested dielectrics (:mod:`pyrt.integrators.media`, Schmidt & Budge 2002): ``priority`` decides which
    volume wins where volumes overlap (higher wins; surfaces inside a higher-priority volume are
    ignored) and ``absorption`` is the Beer-Lambert coefficient sigma_a (RGB, per scene unit) of the
    medium the glass encloses (``pyrt.integrators.media.absorption_from_transmittance`` converts a colour
    at a distance). With the defaults (priority 0, no absorption) and a single dielectric in the
    scene nothing changes; otherwise the integrator passes ``eta`` (eta_t / eta_i from the ray's
    interface stack) to :meth:`delta_lobes`.
    """

    has_diffuse = False
    has_delta = True
    is_dielectric = True

    def __init__(self, ior=1.5, *, tint=1.0, priority=0, absorption=0.0, name=None):
        self.name = name
        self.ior, self.tint, self.priority, self.absorption = ior, tint, priority, absorption
        self.validate()

    def validate(self):
        """``ior`` > 0, ``tint`` in [0, 1], ``absorption`` >= 0, a finite ``priority``; the last two constants."""
        owner = self.label
        self.ior = check_scalar("ior", self.ior, owner, lo=0.0, lo_open=True)
        self.tint = check_color("tint", self.tint, owner, lo=0.0, hi=1.0)
        self.priority = check_scalar("priority", self.priority, owner)
        self.absorption = check_color("absorption", self.absorption, owner, lo=0.0)
        if is_texture(self.absorption) or is_texture(self.priority):
            raise MaterialError(f"{owner}: priority and absorption must be constants, not textures")
        super().validate()

    def compiled_record(self, pack_texture):
        """:data:`pyrt.materials.compiled.GLASS` with a constant tint (a scene whose dielectrics need interface
        stacks, :mod:`pyrt.integrators.media`, is not compiled at all); None for a glass whose flags were changed
        (``is_dielectric`` off: the mirror rule, which the kernel applies to mirrors only)."""
        if is_texture(self.tint) or not self.is_dielectric:
            return None
        rec = _compiled.empty_record()
        rec[0] = float(self.ior)
        rec[1:4] = np.broadcast_to(self.tint, (3,))
        return _compiled.GLASS, rec

    def delta_lobes(self, wo, ctx, *, eta=None):
        """Reflection and refraction lobes; ``eta`` (N,) = eta_t / eta_i overrides the single-interface
        ``ior`` (front) / ``1 / ior`` (back) when the ray's interface stack decides the indices."""
        if eta is None:
            eta = np.where(ctx.front, self.ior, 1.0 / self.ior)  # eta_t / eta_i
        cos_o = wo[:, 2]
        R = fresnel.fr_dielectric(cos_o, eta)
        nz = np.zeros_like(wo)
        nz[:, 2] = 1.0
        tint = np.array(self.param(self.tint, ctx))
        wr = reflect(wo, nz)
        wt, tir = refract(wo, nz, eta)
        R = np.where(tir, 1.0, R)
        lobes = [DeltaLobe(wr, tint * R[:, None], "reflect")]
        T = 1.0 - R
        if np.any(T > 0):
            lobes.append(DeltaLobe(wt, tint * (T / (eta * eta))[:, None], "refract", eta))
        return lobes


