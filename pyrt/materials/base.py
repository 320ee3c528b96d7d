"""The material interface, the registry and the per-hit parameter plumbing.

The interface (every model implements it; the integrators know nothing else)
----------------------------------------------------------------------------
All directions are in the *local shading frame* of the hit (z = shading normal, turned toward
the viewer), unit length, ``wo`` toward the viewer and ``wi`` toward the light.

``f_cos(wo, wi, ctx) -> (N, 3)``
    BRDF times cos(theta_i) of the non-delta lobes (zero for a pure mirror or glass).
``delta_lobes(wo, ctx, *, eta=None) -> list[DeltaLobe]``
    Perfectly specular lobes (mirror reflection, glass reflection and refraction): the
    direction ``wi`` (local frame) and the weight (N, 3) the traced radiance is multiplied by.
    ``eta`` (N,) is given to dielectrics whose indices a ray's interface stack decides.
``sample(wo, u, ctx) -> (wi, weight, pdf)``
    Sample a direction of the non-delta lobes from ``u`` (N, 2) in [0, 1)^2; ``weight`` is
    ``f_cos / pdf``. The base implementation samples the cosine-weighted hemisphere, which is
    unbiased for any BRDF; models override it with better strategies.
``pdf(wo, wi, ctx) -> (N,)``
    Solid-angle density of :meth:`sample`.
``albedo(ctx) -> (N, 3)``
    Diffuse-like reflectance used by the constant ambient term and the albedo AOV.
``emission(ctx) -> (N, 3)``
    Emitted radiance (W/m^2/sr), zero by default.

Isotropic models derive from :class:`IsotropicMaterial` and implement ``f_cos_cosines(q)`` only:
f * cos from ``n.wi``, ``n.wo`` and ``wo.wi``. Their ``f_cos`` is defined from it, so the
world-space fast path of :class:`pyrt.materials.dispatch.BSDFBatch` (no local frame per light) and the
local-frame ``f_cos`` are one formula by construction.

``ctx`` is a :class:`pyrt.geometry.SurfaceBatch` restricted to the hits that use this material
(``ctx.uv``, ``ctx.p``, ``ctx.front``, ...). A parameter may be a constant or a
:class:`pyrt.textures.Texture`; :meth:`Material.param` resolves either to an array.

Declared attributes the integrators read to model no more than the scene needs: ``has_diffuse``
(receives direct and ambient light), ``has_delta`` (spawns specular rays), ``is_dielectric`` with
``ior``, ``tint``, ``priority``, ``absorption`` and ``thin_walled`` (refraction, nested media), ``emits`` (may emit), ``lambertian``
(the environment preview's SH path), ``normal_map`` and ``uses_textures`` (ray differentials); the method
``glossy_alpha(ctx)`` (None: diffuse) tells the glossy integrator which lobes to trace.

Coverage (glTF ``alphaMode``, ``alphaCutoff``, ``doubleSided``; any material, any scene): ``alpha_mode``
(``"opaque"``, ``"mask"``: cut-outs where ``opacity < alpha_cutoff``, ``"blend"``: ``opacity`` x this surface
+ ``(1 - opacity)`` x what lies behind), ``opacity`` (the coverage alpha, a number or a 1-channel texture, read
by :meth:`coverage`; not ``alpha``, which names microfacet roughness in pyrt),
``alpha_cutoff`` and ``double_sided`` (False: back faces are invisible to camera and secondary rays); set them
with :meth:`Material.set_coverage`. :mod:`pyrt.integrators.coverage` honours them; scenes without such a
material pay nothing.

A new model is one kernel in :mod:`pyrt.shaders` and one class registered with
``@MATERIALS.register("name")``; the contract tests (tests/test_material_contracts.py) pick it up.
"""
from __future__ import annotations

from dataclasses import dataclass
import numbers

import numpy as np

from pyrt.core import checks
from pyrt.core.errors import Error
from pyrt.core.registry import Registry
from pyrt.geometry.memo import row_memo
from pyrt.shaders import sampling
from pyrt.shaders.vec import dot
from pyrt.textures import footprinted, is_texture


class MaterialError(Error, ValueError):
    """A material parameter is missing, unknown or out of range."""


@dataclass
class DeltaLobe:
    """One perfectly specular lobe: local direction ``wi`` (N, 3) and radiance weight (N, 3)."""

    wi: np.ndarray
    weight: np.ndarray
    kind: str  # "reflect" or "refract"
    eta: np.ndarray | None = None  # (N,) eta_t / eta_i for "refract" lobes (ray differentials)


class CosineQuery:
    """A BSDF query on lanes ``lanes`` of a material's group ``ctx`` (None: all lanes), in world space.

    ``cos_i = n_s . wi`` and ``cos_o = n_s . wo`` (K,) are given; ``cos_io()`` (``wo . wi``) is computed
    on demand; :meth:`param` resolves a material parameter for the K lanes (textures are read once per
    group, see :meth:`Material.param`, then gathered; constants stay (3,) or scalars).
    """

    __slots__ = ("ctx", "lanes", "wi", "cos_i", "cos_o")

    def __init__(self, ctx, lanes, wi, cos_i, cos_o):
        self.ctx, self.lanes, self.wi, self.cos_i, self.cos_o = ctx, lanes, wi, cos_i, cos_o

    def cos_io(self):
        """``wo . wi`` (K,) for the queried lanes."""
        wo = self.ctx.wo if self.lanes is None else np.take(self.ctx.wo, self.lanes, axis=0)
        return dot(self.wi, wo)

    def param(self, material, value, channels=3):
        """A parameter for the K lanes: (K, channels) / (K,) for textures, (3,) or a float for constants."""
        if not is_texture(value):
            return float(value) if channels == 1 else np.asarray(value, dtype=np.float64)
        out = material.param(value, self.ctx, channels)
        return out if self.lanes is None else np.take(out, self.lanes, axis=0)


class LocalCosineQuery:
    """The same query in the local shading frame (``wo``, ``wi`` (N, 3), z = shading normal).

    What :meth:`IsotropicMaterial.f_cos` hands to ``f_cos_cosines``: ``cos_o = wo_z``, ``cos_i = wi_z``,
    ``cos_io() = wo . wi``; colour parameters resolve per hit (N, 3), scalars stay floats.
    """

    __slots__ = ("ctx", "wo", "wi", "cos_i", "cos_o")

    def __init__(self, ctx, wo, wi):
        self.ctx, self.wo, self.wi = ctx, wo, wi
        self.cos_o, self.cos_i = wo[:, 2], wi[:, 2]

    def cos_io(self):
        """``wo . wi`` (N,)."""
        return dot(self.wo, self.wi)

    def param(self, material, value, channels=3):
        """(N, 3) colours (textures or broadcast constants); (N,) scalar textures or a float constant."""
        if channels == 1 and not is_texture(value):
            return float(value)
        return material.param(value, self.ctx, channels)


def check_color(name, value, owner, *, lo=0.0, hi=None):
    """Validate an RGB triple (or scalar grey) or a texture; return a float64 (3,) array or the texture."""
    if is_texture(value):
        return value
    arr = checks.numbers_array(owner, name, value, MaterialError)
    if arr.ndim == 0:
        arr = np.repeat(arr, 3)
    if arr.shape != (3,):
        raise MaterialError(f"{owner}: {name} must be a scalar or an RGB triple, got shape {arr.shape}")
    if not np.all(np.isfinite(arr)):
        raise MaterialError(f"{owner}: {name} must be finite, got {arr.tolist()}")
    if np.any(arr < lo) or (hi is not None and np.any(arr > hi)):
        rng = f"[{lo}, {hi}]" if hi is not None else f">= {lo}"
        raise MaterialError(f"{owner}: {name} must be in {rng}, got {arr.tolist()}")
    return arr


#: the values of :attr:`Material.alpha_mode`
ALPHA_MODES = ("opaque", "mask", "blend")


def check_scalar(name, value, owner, *, lo=None, hi=None, lo_open=False):
    """Validate a real scalar (or a texture) with an optional range."""
    if is_texture(value):
        return value
    if not isinstance(value, numbers.Real) or isinstance(value, bool) or not np.isfinite(value):
        raise MaterialError(f"{owner}: {name} must be a finite number, got {value!r}")
    v = float(value)
    if lo is not None and (v < lo or (lo_open and v == lo)):
        raise MaterialError(f"{owner}: {name} must be {'>' if lo_open else '>='} {lo}, got {v}")
    if hi is not None and v > hi:
        raise MaterialError(f"{owner}: {name} must be <= {hi}, got {v}")
    return v



#: the methods whose override changes what a material renders (a subclass overriding one is not compiled unless it
#: gives its own :meth:`Material.compiled_record`)
_SHADING_METHODS = ("f_cos", "f_cos_cosines", "delta_lobes", "sample", "sample_direction", "pdf", "albedo", "emission",
                    "coverage", "glossy_alpha", "param", "emits", "has_diffuse", "has_delta", "is_dielectric",
                    "transmits", "normal_map", "alpha_mode", "double_sided", "thin_walled")


class Material:
    """Base class of every material: the interface in the module docstring, with defaults.

    Subclasses set the flags and override the methods they need; every attribute the integrators
    read is declared here.
    """

    #: receives direct and ambient light (has a non-delta lobe)
    has_diffuse = True
    #: spawns perfectly specular rays (:meth:`delta_lobes`)
    has_delta = False
    #: refracts (glass): the integrators then build refraction batches and, with several dielectrics
    #: or absorption, per-ray interface stacks (:mod:`pyrt.integrators.media`)
    is_dielectric = False
    #: index of refraction of a dielectric (relative to vacuum), None for other materials
    ior = None
    #: nested-dielectric priority (higher wins where volumes overlap)
    priority = 0.0
    #: Beer-Lambert absorption coefficient sigma_a (RGB, per scene unit) of the enclosed medium
    absorption = 0.0
    #: colour filter (RGB or texture) of a dielectric's transmission per interface (refraction, transparent shadows)
    tint = 1.0
    #: may emit light (:meth:`emission` non-zero somewhere); derived for subclasses that override
    #: :meth:`emission` without declaring it (see ``__init_subclass__``)
    emits = False
    #: a plain Lambertian BRDF albedo / pi (the environment preview uses SH irradiance for it);
    #: not inherited: a subclass is Lambertian only if it says so
    lambertian = False
    #: registry name used by scene files: ``{"type": "lambert", ...}`` (set by :meth:`Registry.register`)
    type_name = None
    #: the user's name for the material (messages, scene files)
    name = None
    #: tangent-space normal map (a :class:`pyrt.NormalMap`) or None; applied to the shading normal before shading
    normal_map = None
    #: has a transmission lobe: ``f_cos``/``sample`` give directions below the local horizon (wi_z < 0);
    #: the strict Whitted integrator lights only the viewer's side (rough glass needs the glossy integrator)
    transmits = False
    #: transmits through its delta lobes alone (:attr:`transmits` without a BSDF lobe below the horizon anywhere:
    #: smooth glTF transmission); False for rough transmission and for materials that do not transmit
    smooth_transmission = False
    #: a dielectric without a volume (a thin wall: light crosses it and is outside again, glTF transmission
    #: without ``KHR_materials_volume``): it encloses no medium, so the nested-media stacks ignore it
    thin_walled = False
    #: f(wo, wi) = f(wi, wo) (Helmholtz reciprocity; the contract tests check it where declared)
    reciprocal = True
    #: ``{attribute: ("color" | "scalar", lo, hi, lo_open)}``: the ranges :meth:`validate` re-checks before every
    #: render (the constructor's checks, declared once for the classes that list them; None values skipped)
    ranges = {}
    #: coverage mode (one of :data:`ALPHA_MODES`): ``"opaque"`` (alpha ignored), ``"mask"`` (hits where
    #: :meth:`coverage` < :attr:`alpha_cutoff` do not exist: cut-outs, for every ray) or ``"blend"``
    #: (straight-through transparency: opacity x this surface + (1 - opacity) x what lies behind, shadows x
    #: (1 - opacity))
    alpha_mode = "opaque"
    #: coverage alpha in [0, 1]: a number or a 1-channel texture (glTF: baseColorFactor.a x texture a x vertex a);
    #: named ``opacity`` because ``alpha`` is microfacet roughness in pyrt
    opacity = 1.0
    #: ``"mask"`` threshold: a hit is kept where opacity >= alpha_cutoff (glTF default 0.5)
    alpha_cutoff = 0.5
    #: both sides are surfaces (shaded with the normal turned toward the viewer); False: back faces (the side
    #: opposite the winding normal) are culled for camera and secondary rays (they still cast shadows);
    #: ignored by dielectrics and transmitting materials, whose back faces are the way out of their volume
    double_sided = True

    @classmethod
    def example(cls):
        """A typical instance (default parameters) for the contract tests (tests/test_material_contracts.py)."""
        return cls()

    @property
    def label(self):
        """The material as messages name it: ``"Lambert(floor)"``."""
        return f"{type(self).__name__}({self.name or ''})"

    def validate(self):
        """Check the parameters as they are now; raise :class:`MaterialError` naming the material.

        :class:`pyrt.PreparedScene` calls it before every render, so a parameter assigned after
        construction (``mat.albedo_value = float("nan")``) is an error, not a silently wrong image. The
        base checks that every public numeric attribute is finite
        (:func:`pyrt.core.checks.finite_attributes`); a subclass whose constructor stores its parameters
        through ``validate()`` re-runs its range checks there (and may normalise: a scalar grey becomes
        an RGB triple), then calls ``super().validate()``.
        """
        checks.finite_attributes(self.label, self, MaterialError)
        self._validate_coverage()
        for attr, (kind, lo, hi, lo_open) in self.ranges.items():
            value = getattr(self, attr)
            if value is None:
                continue
            if kind == "color":
                check_color(attr, value, self.label, lo=lo, hi=hi)
            else:
                check_scalar(attr, value, self.label, lo=lo, hi=hi, lo_open=lo_open)

    def _validate_coverage(self):
        """Check :attr:`alpha_mode`, :attr:`opacity`, :attr:`alpha_cutoff` and :attr:`double_sided`."""
        if self.alpha_mode not in ALPHA_MODES:
            raise MaterialError(f"{self.label}: alpha_mode must be one of {ALPHA_MODES}, got {self.alpha_mode!r}")
        if is_texture(self.opacity):
            if self.opacity.channels != 1:
                raise MaterialError(f"{self.label}: an opacity texture must have 1 channel, got "
                                    f"{self.opacity.channels}")
        else:
            check_scalar("opacity", self.opacity, self.label, lo=0.0, hi=1.0)
        check_scalar("alpha_cutoff", self.alpha_cutoff, self.label, lo=0.0, hi=1.0)
        if not isinstance(self.double_sided, (bool, np.bool_)):
            raise MaterialError(f"{self.label}: double_sided must be True or False, got {self.double_sided!r}")

    def set_coverage(self, *, opacity=None, alpha_mode=None, alpha_cutoff=None, double_sided=None):
        """Set the coverage attributes given (the others keep their values); returns ``self``.

        Parameters
        ----------
        opacity : float or Texture, optional
            Coverage alpha in [0, 1] (a 1-channel texture, e.g. ``ImageTexture(rgba, select=3, srgb=False)``).
        alpha_mode : {"opaque", "mask", "blend"}, optional
        alpha_cutoff : float, optional
            In [0, 1]; ``"mask"`` keeps hits where opacity >= alpha_cutoff.
        double_sided : bool, optional
            False culls back faces for camera and secondary rays.

        Raises
        ------
        MaterialError
            Naming the material and the value out of range.
        """
        for attr, value in (("opacity", opacity), ("alpha_mode", alpha_mode), ("alpha_cutoff", alpha_cutoff),
                            ("double_sided", double_sided)):
            if value is not None:
                numeric = isinstance(value, numbers.Real) and not isinstance(value, bool)
                setattr(self, attr, float(value) if attr != "alpha_mode" and numeric else value)
        self._validate_coverage()
        return self

    @property
    def culls_back_faces(self):
        """True when camera and secondary rays skip this material's back faces: :attr:`double_sided` False, not a
        dielectric or transmitting material (whose back faces are the way out of their volume)."""
        return not self.double_sided and not self.is_dielectric and not self.transmits

    def coverage(self, ctx):
        """Coverage alpha (N,) in [0, 1] at the hits of ``ctx`` (:attr:`opacity` resolved, clipped)."""
        return np.clip(self.param(self.opacity, ctx, 1), 0.0, 1.0)

    def seen_fraction(self, ctx):
        """How much of the surface a ray sees at the hits of ``ctx`` (N,): 1 (opaque); ``"mask"`` 1 where the
        coverage is at least :attr:`alpha_cutoff`, else 0; ``"blend"`` the coverage. A shadow ray is let through by
        ``1 - seen_fraction`` (:meth:`pyrt.integrators.coverage.CoverageTable.shadow_factor`); an emitter's light is
        scaled by it (:class:`pyrt.EmissiveMeshLight`)."""
        if self.alpha_mode == "mask":
            return (self.coverage(ctx) >= self.alpha_cutoff).astype(np.float64)
        if self.alpha_mode == "blend":
            return self.coverage(ctx)
        return np.ones(ctx.n_hits)

    def __init_subclass__(cls, **kwargs):
        super().__init_subclass__(**kwargs)
        if "lambertian" not in cls.__dict__:
            cls.lambertian = False
        # a subclass that changes what the material computes but not its compiled record is not compiled (its
        # parent's record would render the parent): derived by construction, as the emits flag below
        if any(name in cls.__dict__ for name in _SHADING_METHODS):
            for name in ("compiled_record", "compiled_record_extras"):
                if name not in cls.__dict__:
                    setattr(cls, name, Material.__dict__[name])
        if "emits" not in cls.__dict__ and cls.emission is not Material.emission:
            # overrides emission() without saying when it is zero (no class from the one defining emission() on
            # declares emits, e.g. a mixin's property beside its emission()): assume it may emit
            mro = cls.__mro__
            owner = {name: next(i for i, c in enumerate(mro) if name in c.__dict__) for name in ("emits", "emission")}
            if owner["emits"] > owner["emission"]:
                cls.emits = True

    @property
    def uses_textures(self):
        """True when a parameter (or the normal map) is a texture."""
        return any(is_texture(v) for v in vars(self).values())

    @property
    def uses_footprints(self):
        """True when a parameter (or the normal map) is a texture that reads the hits' footprints
        (:attr:`pyrt.textures.Texture.needs_footprint`): the integrators then carry ray differentials. Vertex colours
        (the colours of merged materials included) and unfiltered image lookups do not; without such a texture
        the camera rays, glossy and delta rays are traced without differentials and the same values result."""
        return footprinted(*vars(self).values())

    def param(self, value, ctx, channels=3):
        """Resolve a constant or a texture to an ``(N, channels)`` array (``(N,)`` if channels == 1).

        Texture lookups are cached on ``ctx`` (keyed by the texture object), so a material evaluated
        for several lights on the same hits reads its textures once; and every view of one batch of hits
        (:meth:`pyrt.geometry.SurfaceBatch.subset`: the hits of a material, of a light's samples, of the glossy
        rays, hits repeated for several BSDF samples) shares one per-row memo of them
        (:func:`pyrt.geometry.memo.row_memo`): each hit is looked up once per batch, the other views gather.
        """
        n = ctx.n_hits
        if is_texture(value):
            cache = ctx.__dict__.setdefault("_param_cache", {})
            key = (value, channels)        # the texture itself (hashed by identity): kept alive, its id not reused
            out = cache.get(key)
            if out is None:
                out = cache[key] = row_memo(ctx, ("param",) + key, lambda c: _texture_values(value, c, channels))
            return out
        arr = np.asarray(value, dtype=np.float64)
        if channels == 1:
            return np.full(n, float(arr))
        return np.broadcast_to(arr, (n, 3))

    def compiled_record(self, pack_texture):
        """``(tag, record)``: this material as a row of the compiled kernel's material table
        (:mod:`pyrt.materials.compiled`), or None when the compiled kernel cannot shade it (the render then takes
        the NumPy path). ``pack_texture(texture)`` adds a texture to the texture table and returns its index, or
        None when the compiled kernel cannot read it. Default None."""
        return None

    def compiled_record_extras(self, pack_texture, *, emission=0.0, occlusion=None, occlusion_strength=1.0):
        """:meth:`compiled_record` with glTF's extras on top (:class:`pyrt.io.assets.materials.SurfaceExtras`):
        ``emission`` (a constant or a texture, emitted radiance) and ``occlusion`` (None or a 1-channel texture
        scaling :meth:`albedo` by ``1 + occlusion_strength (occ - 1)``); None (the default) where the compiled kernel
        has no place for them."""
        return None

    def f_cos(self, wo, wi, ctx):
        """BRDF times cos(theta_i) (N, 3) of the non-delta lobes for local ``wo``, ``wi`` (N, 3)."""
        return np.zeros_like(wi)

    def delta_lobes(self, wo, ctx, *, eta=None):
        """The perfectly specular lobes (list of :class:`DeltaLobe`) for local ``wo`` (N, 3).

        ``eta`` (N,) = eta_t / eta_i from the ray's interface stack (dielectrics only; others ignore it).
        """
        return []

    def sample(self, wo, u, ctx):
        """Sample the non-delta lobes: local ``wi`` (N, 3), ``weight = f_cos / pdf`` (N, 3), ``pdf`` (N,) (sr^-1)."""
        wi = sampling.square_to_cosine_hemisphere(u)
        pdf = sampling.cosine_hemisphere_pdf(wi)
        f = self.f_cos(wo, wi, ctx)
        weight = f / np.where(pdf > 0, pdf, 1.0)[:, None]
        return wi, weight, pdf

    def sample_direction(self, wo, u, ctx):
        """The local directions ``wi`` (N, 3) that :meth:`sample` draws for ``u``, without its weight and pdf (what
        a layered material needs of its base to mix strategies: :class:`pyrt.materials.Clearcoat`). Models whose
        ``sample`` evaluates the BSDF override it to skip that."""
        return self.sample(wo, u, ctx)[0]

    def pdf(self, wo, wi, ctx):
        """Solid-angle density (N,) of :meth:`sample` for local ``wo``, ``wi``."""
        return sampling.cosine_hemisphere_pdf(wi)

    def glossy_alpha(self, ctx):
        """How glossy the non-delta lobe is: a microfacet-equivalent roughness ``alpha`` (N,) per hit, or None
        for a diffuse-like lobe (the default). The glossy integrator (:mod:`pyrt.integrators.glossy`) spawns
        BSDF-sampled rays where ``alpha <= glossy_threshold``; elsewhere it uses direct light only."""
        return None

    def rough_transmission(self, ctx):
        """(N,) bool: the hit transmits light through a non-delta lobe (rough glass: :meth:`sample` gives directions
        below the surface there). The glossy integrator continues such hits by one BSDF-sampled ray at every bounce
        up to ``max_depth``, as delta lobes are, whatever ``glossy_depth`` and ``glossy_threshold`` say: a path
        through a rough volume crosses at least two surfaces, and one cut inside would end black. Default:
        :attr:`transmits` everywhere."""
        return np.full(ctx.n_hits, bool(self.transmits))

    def albedo(self, ctx):
        """Diffuse-like reflectance (N, 3): the ambient term and the albedo AOV."""
        return np.zeros((ctx.n_hits, 3))

    def preview_lobes(self, ctx):
        """The reflection as a Lambertian part and GGX lobes (:class:`pyrt.materials.preview.PreviewLobes`) for the
        split-sum environment preview, or None (the default): the preview then samples :meth:`sample`."""
        return None

    def emission(self, ctx):
        """Emitted radiance (N, 3), W m^-2 sr^-1, toward ``ctx.wo``."""
        return np.zeros((ctx.n_hits, 3))

    def __repr__(self):
        fields = ", ".join(f"{k}={v!r}" for k, v in vars(self).items())
        return f"{type(self).__name__}({fields})"


class IsotropicMaterial(Material):
    """A material whose ``f_cos`` depends only on ``n.wi``, ``n.wo`` and ``wo.wi``.

    Subclasses implement :meth:`f_cos_cosines`; :meth:`f_cos` is defined from it, so the dispatcher's
    world-space fast path and the local-frame evaluation are the same formula by construction. A
    subclass may not override ``f_cos`` (it would make the two disagree): override ``f_cos_cosines``.
    """

    def __init_subclass__(cls, **kwargs):
        super().__init_subclass__(**kwargs)
        if "f_cos" in cls.__dict__:
            raise TypeError(f"{cls.__name__}: an IsotropicMaterial defines f_cos_cosines, not f_cos "
                            "(derive from Material for a model that needs the local frame)")

    def f_cos_cosines(self, q):
        """f * cos(theta_i) (K, 3) for a :class:`CosineQuery` or :class:`LocalCosineQuery` ``q``."""
        raise NotImplementedError

    def f_cos(self, wo, wi, ctx):
        """BRDF times cos(theta_i) from :meth:`f_cos_cosines` in the local frame."""
        return self.f_cos_cosines(LocalCosineQuery(ctx, wo, wi))


#: scene-file ``type`` -> material class (one registry per family, :class:`pyrt.core.registry.Registry`)
MATERIALS = Registry("material", Material)
#: ``register(cls)`` or ``@register("name")``: add a material type to :data:`MATERIALS`
register = MATERIALS.register


def _texture_values(value, ctx, channels):
    """``value.evaluate(ctx)`` as float64 ``(N, channels)`` (``(N,)`` for one channel; grey repeated to RGB)."""
    n = ctx.n_hits
    out = np.asarray(value.evaluate(ctx), dtype=np.float64)
    if channels == 1:
        return out.reshape(n, -1)[:, 0]
    if out.ndim == 1 or out.shape[1] == 1:
        return np.repeat(out.reshape(n, 1), 3, axis=1)
    return out[:, :3]
