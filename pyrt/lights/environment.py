"""Environment lighting: constant, lat-long and cube-map environments, and image-based lighting.

An *environment* is radiance arriving from infinitely far away, ``L(d)`` for world directions ``d``
(W m^-2 sr^-1 per RGB channel). It is used twice:

1. **Seen directly**: rays that miss every mesh return ``scene.environment.radiance(d)``
   (camera rays, and mirror / glass rays of the Whitted recursion, which gives reflection and
   refraction mapping for free). With ``hide_background=True`` camera rays (depth 0) see the plain
   colour ``background`` instead, while reflections and lighting still use the map.
2. **As a light** (:class:`pyrt.lights.environment_light.EnvironmentLight`): at every non-specular hit the integral
   ``L_o = int f(wo, wi) L(wi) V(wi) cos theta_i dwi`` is estimated by Monte Carlo with shadow rays
   through Embree, using one of the strategies in :data:`STRATEGIES`, or approximated without
   shadows (``strategy="preview"``).

:func:`pyrt.lights.environment_light.set_environment` does both. Kernels: :mod:`shaders.envmap`.

Strategies (``EnvironmentLight(strategy=...)``), ``n_samples`` per hit, stratified in ``u``
--------------------------------------------------------------------------------------------
``uniform``   directions uniform on the sphere, pdf ``1 / (4 pi)``.
``cosine``    cosine-weighted hemisphere around the shading normal, pdf ``cos theta / pi``.
``map``       importance sampling of the environment (lat-long: in proportion to the bilinear luminance times
              ``sin theta``, :mod:`pyrt.lights.latlong_sampling`, or a texel table for ``filter="nearest"``; cube:
              per-texel table of luminance times the texels' solid angle; constant: uniform sphere).
``bsdf``      the material's own ``sample()`` (GGX visible normals etc. for glossy models).
``mis``       ``n_samples`` ``map`` samples and ``bsdf_samples`` BSDF samples, combined with the power
              (``heuristic="power"``, beta = 2) or balance heuristic with the sample counts (Veach
              1997); ``compensate=True`` draws the map samples from the MIS-compensated table
              (:meth:`Environment.sample_compensated`, see :mod:`pyrt.lights.environment_light`).
``preview``   *approximation, no shadows, no noise*: Lambertian materials get
              ``albedo / pi * E_SH(n)`` from a 9-coefficient SH projection of the environment
              (Ramamoorthi & Hanrahan 2001); any other material gets a filtered-importance-sampling
              estimate: ``preview_samples`` fixed Hammersley samples of its BSDF, each reading the
              roughness-indexed prefiltered map (GGX lobes, split-sum assumption ``n = v = r``) at
              the width ``alpha = sqrt(1 / (4 pi K pdf))`` that matches the sample's solid angle.
              Materials that declare their lobes (``preview_method="split_sum"``, the default:
              :meth:`pyrt.materials.Material.preview_lobes`) get the split sum instead (Karis 2013):
              per GGX lobe one lookup of the prefiltered map at the lobe's dominant direction (Lagarde &
              de Rousiers 2014) times its directional albedo ``F0 A + B`` from :mod:`shaders.dfg`'s
              tables, plus ``diffuse / pi * E_SH(n)``, times the material's occlusion (glTF).
              Errors are measured by ``tools/ibl_chart.py`` and the tests. Every estimator but ``preview`` is
              unbiased; for a given seed the result is bit-identical.
"""
from __future__ import annotations

import math
import numbers
import os

import numpy as np

from pyrt.shaders import envmap as K
from pyrt.shaders import sampling
from pyrt.shaders.distribution import compensated_weights

from pyrt.core import checks
from pyrt.core.image_io import read_exr, read_hdr
from pyrt.core.registry import Registry
from pyrt.core.transforms import SceneError, transform_matrix
from pyrt.lights.base import LightError
from pyrt.lights.irradiance import unshadowed_irradiance
from pyrt.lights.latlong_sampling import BilinearSampling

#: estimator names accepted by :class:`pyrt.lights.environment_light.EnvironmentLight`
STRATEGIES = ("uniform", "cosine", "map", "bsdf", "mis", "preview")
HEURISTICS = ("power", "balance")
FILTERS = ("nearest", "bilinear")

#: GGX widths of the roughness-indexed prefiltered maps (level 0 = the map itself)
PREFILTER_ALPHAS = (0.0, 0.05, 0.1, 0.2, 0.35, 0.5, 0.75, 1.0)


class EnvironmentMapError(LightError):
    """Invalid environment parameters (a :class:`pyrt.LightError`, hence a ``ValueError``)."""


def _rgb(owner, name, v):
    return checks.rgb(owner, name, v, EnvironmentMapError)


def _rotation_matrix(owner, rotate):
    """``rotate`` -> 3x3 ``world_from_env``: None, (angle_deg, axis), a list of those, or a 3x3 matrix."""
    if rotate is None:
        return np.eye(3)
    try:
        m = np.asarray(rotate, dtype=np.float64)
    except (ValueError, TypeError):
        m = None
    if m is not None and m.shape == (3, 3):
        if not np.allclose(m @ m.T, np.eye(3), atol=1e-6) or np.linalg.det(m) < 0:
            raise EnvironmentMapError(f"{owner}: rotate matrix must be a proper rotation (orthonormal, det +1)")
        return m
    try:
        return transform_matrix(rotate=rotate)[:3, :3]
    except (SceneError, TypeError, ValueError, IndexError) as e:
        raise EnvironmentMapError(f"{owner}: rotate must be (angle_degrees, [x, y, z]), a list of them or a "
                                  f"3x3 rotation matrix, got {rotate!r} ({e})") from None


def load_environment_image(path):
    """Read an HDR environment image (H, W, 3) float32: OpenEXR (:func:`pyrt.read_exr`) or Radiance ``.hdr`` /
    ``.pic`` / ``.rgbe`` (:func:`pyrt.core.image_io.read_hdr`, OpenCV from the ``[hdr]`` extra), by extension."""
    path = os.fspath(path)
    ext = os.path.splitext(path)[1].lower()
    if ext == ".exr":
        return read_exr(path)
    if ext in (".hdr", ".pic", ".rgbe"):
        return read_hdr(path)
    raise EnvironmentMapError(f"{path}: unsupported environment image type {ext!r}; use an OpenEXR (.exr) or "
                              "Radiance (.hdr) file")


def _image(owner, image):
    if isinstance(image, (str, os.PathLike)):
        image = load_environment_image(image)
    img = np.asarray(image)
    if img.ndim == 2:
        img = np.repeat(img[..., None], 3, axis=2)
    if img.ndim != 3 or img.shape[2] not in (3, 4):
        raise EnvironmentMapError(f"{owner}: image must have shape (H, W, 3), got {img.shape}")
    img = np.ascontiguousarray(img[..., :3], dtype=np.float32 if img.dtype != np.float64 else np.float64)
    if not np.all(np.isfinite(img)):
        raise EnvironmentMapError(f"{owner}: image has {int((~np.isfinite(img)).sum())} non-finite values")
    if np.any(img < 0):
        raise EnvironmentMapError(f"{owner}: image has {int((img < 0).sum())} negative values (radiance must be >= 0)")
    return img


def filtered_image(owner, image, filter):
    """``(filter, image)`` of an image-based environment: the filter name checked against :data:`FILTERS`, the
    image (a path or an array) as a finite non-negative (H, W, 3) array (:func:`_image`)."""
    if filter not in FILTERS:
        raise EnvironmentMapError(f"{owner}: filter must be one of {FILTERS}, got {filter!r}")
    return filter, _image(owner, image)


def latlong_row_measure(height):
    """Solid-angle weight ``sin theta`` of each row of a lat-long table, (H, 1) float64."""
    return np.sin(np.pi * (np.arange(height) + 0.5) / height)[:, None]


def incomplete_sample(sample, dist, u):
    """``sample(dist, u)`` of a table, or arbitrary unit directions of density 0 when ``dist`` is None (a
    compensated table without a positive weight)."""
    if dist is not None:
        return sample(dist, u)
    return sampling.square_to_uniform_sphere(np.asarray(u, dtype=np.float64)), np.zeros(u.shape[0])


def incomplete_pdf(pdf, dist, d):
    """``pdf(dist, d)`` of a table, or 0 on every lane when ``dist`` is None (see :func:`incomplete_sample`)."""
    return pdf(dist, d) if dist is not None else np.zeros(d.shape[0])


class Environment:
    """Base class of the environments: radiance arriving from infinitely far away.

    Subclasses implement ``_radiance_local(d)`` (and, for importance sampling, ``_sample_local(u)`` /
    ``_pdf_local(d)``; for the preview, ``_sh9_local()`` / ``_build_prefiltered()``) in the environment's own
    frame; the public methods below rotate world directions into it.

    Methods
    -------
    radiance(d) -> (N, 3) float64
        Radiance (W m^-2 sr^-1) arriving from unit world directions ``d`` (N, 3).
    sample(u) -> (d (N, 3), pdf (N,))
        Importance-sampled directions for ``u`` (N, 2) in [0, 1)^2 and their solid-angle density (sr^-1).
    pdf(d) -> (N,) float64
        The density of :meth:`sample`.
    irradiance_sh(n), prefiltered(d, alpha)
        The noise-free preview's lookups (unshadowed SH irradiance; GGX-prefiltered radiance).

    Parameters (shared)
    -------------------
    intensity : float
        Scale applied to the radiance (default 1).
    rotate : (angle_deg, axis), list of them, or 3x3 matrix
        ``world_from_env`` rotation: ``L_world(d) = intensity * L_map(R^T d)``.
    hide_background : bool
        Camera rays that miss see ``background`` instead of the map (reflections and lighting do not change).
    background : RGB
        Radiance seen by camera rays when ``hide_background`` is set (default black).
    """

    type_name = None
    #: camera rays that miss see :attr:`background` instead of the map
    hide_background = False
    #: radiance (3,) seen by camera rays when :attr:`hide_background` is set
    background = np.zeros(3)
    #: lat-long (H, W) texels that resolve the radiance (:meth:`irradiance`'s quadrature); None: it is constant
    radiance_resolution = (128, 256)
    #: how the compiled kernel reads the class (:func:`pyrt.lights.compiled_env.packable`): "constant", "latlong" or
    #: None. Not inherited (a subclass that changes what the kernel reads must not pass for its base): declare it
    compiled_kind = None

    def __init_subclass__(cls, **kwargs):
        super().__init_subclass__(**kwargs)
        cls.compiled_kind = cls.__dict__.get("compiled_kind")

    @classmethod
    def example(cls):
        """A typical instance for the contract tests (tests/test_light_contracts.py)."""
        return cls()

    def __init__(self, *, intensity=1.0, rotate=None, hide_background=False, background=0.0, name=None):
        owner = f"{type(self).__name__}({name or ''})"
        self.name = name
        if not isinstance(intensity, numbers.Real) or isinstance(intensity, bool) or not math.isfinite(intensity) \
                or intensity < 0:
            raise EnvironmentMapError(f"{owner}: intensity must be a finite number >= 0, got {intensity!r}")
        self.intensity = float(intensity)
        self.rotation = _rotation_matrix(owner, rotate)
        self.hide_background = bool(hide_background)
        self.background = _rgb(owner, "background", background)
        self._sh = None
        self._prefiltered = None
        self._cdist = None       # (compensated table or None,), built on first use

    def validate(self):
        """Check the parameters as they are now (:class:`pyrt.PreparedScene` calls it before every render).

        ``intensity`` a finite number >= 0, ``background`` a non-negative RGB triple and every public numeric
        attribute (the rotation, the map's texels) finite; else an :class:`EnvironmentMapError` naming it.
        """
        owner = f"{type(self).__name__}({self.name or ''})"
        checks.finite_attributes(owner, self, EnvironmentMapError)
        if not isinstance(self.intensity, numbers.Real) or isinstance(self.intensity, bool) or not self.intensity >= 0:
            raise EnvironmentMapError(f"{owner}: intensity must be a finite number >= 0, got {self.intensity!r}")
        _rgb(owner, "background", self.background)

    # -- frames ------------------------------------------------------------------------------
    def to_local(self, d):
        """World directions (N, 3) -> the environment's own frame (``R^T d``)."""
        return np.asarray(d, dtype=np.float64) @ self.rotation      # R^T d for row vectors

    def to_world(self, d):
        """Directions (N, 3) in the environment's frame -> world (``R d``)."""
        return d @ self.rotation.T

    # -- public API (world directions) -----------------------------------------------------
    def radiance(self, d):
        """Radiance ``(N, 3)`` float64 arriving from world directions ``d`` (N, 3)."""
        return self.intensity * np.asarray(self._radiance_local(self.to_local(d)), dtype=np.float64)

    def sample(self, u):
        """Importance-sample world directions: ``(d (N, 3), pdf (N,))`` (solid angle)."""
        d, pdf = self._sample_local(np.asarray(u, dtype=np.float64))
        return self.to_world(d), pdf

    def pdf(self, d):
        """Solid-angle density of :meth:`sample` for world directions ``d``."""
        return self._pdf_local(self.to_local(d))

    def sample_compensated(self, u):
        """Directions and densities ``(d (N, 3), pdf (N,))`` of the MIS-compensated table (Karlik et al. 2019).

        The table of ``max(0, luminance - mean luminance)`` (:func:`shaders.distribution.compensated_weights`)
        where the environment has one, else :meth:`sample`. The density is *incomplete*: 0 wherever the map is
        below its mean (``pdf = 0`` on every lane of a constant map), so it is only an unbiased light-sampling
        half of MIS with BSDF sampling, weighted with :meth:`pdf_compensated` (pbrt-v4's
        ``allowIncompletePDF``); pure light sampling uses :meth:`sample`.
        """
        d, pdf = self._sample_compensated_local(np.asarray(u, dtype=np.float64))
        return self.to_world(d), pdf

    def pdf_compensated(self, d):
        """Solid-angle density (N,) of :meth:`sample_compensated` at world directions ``d``."""
        return self._pdf_compensated_local(self.to_local(d))

    def sh9(self):
        """Nine SH coefficients (9, 3) of the radiance in the environment frame (the current intensity included)."""
        if self._sh is None:          # the map's own coefficients, once; intensity applied per call
            self._sh = self._sh9_local()
        return self.intensity * self._sh

    def irradiance_sh(self, n):
        """Unshadowed irradiance (N, 3) from the 9-term SH approximation at world normals ``n``."""
        return K.sh9_irradiance(self.sh9(), self.to_local(n))

    def irradiance(self, n):
        """Unshadowed irradiance ``int L max(0, n.w) dw`` (N, 3), W m^-2, at unit world normals ``n`` (N, 3): the
        cached quadrature of :mod:`pyrt.lights.irradiance` (<= 5e-4 relative; constant radiance: ``pi L`` exactly)."""
        return unshadowed_irradiance(self, n)

    def prefiltered_maps(self):
        """:meth:`prefiltered`'s stack, one (H_k, W_k, 3) float64 map per :data:`PREFILTER_ALPHAS` (built once)."""
        if self._prefiltered is None:
            self._prefiltered = self._build_prefiltered()
        return self._prefiltered

    def prefiltered(self, d, alpha):
        """Radiance prefiltered with a GGX lobe of width ``alpha`` (N,) around world directions ``d``."""
        return self.intensity * K.roughness_map_lookup(self.prefiltered_maps(), PREFILTER_ALPHAS, self.to_local(d),
                                                       alpha)

    def mean_radiance(self):
        """Average radiance over the sphere (3,) (= SH band 0 / sqrt(4 pi) * ...)."""
        return self.sh9()[0] * K._SH_C0

    # -- subclass hooks ----------------------------------------------------------------------
    def _radiance_local(self, d):
        raise NotImplementedError

    def _sample_local(self, u):
        d = sampling.square_to_uniform_sphere(u)
        return d, sampling.uniform_sphere_pdf(d)

    def _pdf_local(self, d):
        return sampling.uniform_sphere_pdf(d)

    def _sample_compensated_local(self, u):      # no table to compensate: the full density
        return self._sample_local(u)

    def _pdf_compensated_local(self, d):
        return self._pdf_local(d)

    def _compensated_table(self, dist, measure):
        """``Distribution2D`` of :func:`shaders.distribution.compensated_weights` of the table ``dist``, or
        None when every weight is 0 (a constant map: the light-sampling half of MIS has nothing to add)."""
        w = compensated_weights(dist.func, measure)
        return K.distribution2d_build(w) if w.max() > 0 else None

    def _sh9_local(self):
        raise NotImplementedError

    def _build_prefiltered(self):
        raise NotImplementedError

    def __repr__(self):
        return f"{type(self).__name__}(intensity={self.intensity}, name={self.name!r})"


#: scene-file ``[environment] type`` -> environment class
ENVIRONMENTS = Registry("environment", Environment)


@ENVIRONMENTS.register("constant")
class ConstantEnvironment(Environment):
    """Uniform radiance ``color * intensity`` from every direction (the white-furnace environment)."""

    compiled_kind = "constant"

    color = checks.Fixed('the cached irradiance coefficients derive from it')
    def __init__(self, color=1.0, *, intensity=1.0, rotate=None, hide_background=False, background=0.0, name=None):
        super().__init__(intensity=intensity, rotate=rotate, hide_background=hide_background,
                         background=background, name=name)
        self.color = _rgb(f"ConstantEnvironment({name or ''})", "color", color)

    radiance_resolution = None      # constant: E(n) = pi L exactly

    def _radiance_local(self, d):
        return np.broadcast_to(self.color, (d.shape[0], 3))

    def _sh9_local(self):
        c = np.zeros((9, 3))
        c[0] = self.color * K._SH_C0 * 4.0 * np.pi
        return c

    def prefiltered(self, d, alpha):
        return np.broadcast_to(self.intensity * self.color, (np.asarray(d).shape[0], 3)).copy()

    def _sample_compensated_local(self, u):     # L - mean L = 0 everywhere: no light samples under MIS
        d, _ = self._sample_local(u)
        return d, np.zeros(d.shape[0])

    def _pdf_compensated_local(self, d):
        return np.zeros(d.shape[0])


def _prefilter_stack(image):
    """:func:`pyrt.shaders.envmap.prefilter_stack` of ``image`` for :data:`PREFILTER_ALPHAS` (128 samples a texel)."""
    return K.prefilter_stack(image, PREFILTER_ALPHAS)


class LatLongTable(Environment):
    """An environment importance-sampled through a table over a lat-long grid (``self.distribution``, a
    :func:`pyrt.shaders.envmap.distribution2d_build` table whose rows are the grid's latitudes): light
    sampling, its pdf and the MIS-compensated table, shared by :class:`LatLongEnvironment` and the light
    probes (which resample to such a grid)."""

    def _sample_local(self, u):
        return K.latlong_sample(self.distribution, u)

    def _pdf_local(self, d):
        return K.latlong_pdf(self.distribution, d)

    @property
    def compensated_distribution(self):
        """The MIS-compensated table over the grid (:meth:`Environment.sample_compensated`; None for a
        constant map)."""
        if self._cdist is None:
            h = self.distribution.func.shape[0]
            self._cdist = (self._compensated_table(self.distribution, latlong_row_measure(h)),)
        return self._cdist[0]

    def _sample_compensated_local(self, u):
        return incomplete_sample(K.latlong_sample, self.compensated_distribution, u)

    def _pdf_compensated_local(self, d):
        return incomplete_pdf(K.latlong_pdf, self.compensated_distribution, d)


@ENVIRONMENTS.register("latlong")
class LatLongEnvironment(BilinearSampling, LatLongTable):
    """Lat-long (equirectangular) environment map.

    Parameters
    ----------
    image : (H, W, 3) array or path to an OpenEXR or Radiance .hdr file
        Linear radiance, row 0 = straight up (+y), ``u = atan2(x, -z) / 2 pi`` (Mitsuba 3's mapping;
        see :mod:`shaders.envmap`).
    filter : {"bilinear", "nearest"}
        Reconstruction of ``radiance()``. Light samples follow its luminance: a texel table for ``nearest``,
        the bilinear luminance for ``bilinear`` (:mod:`pyrt.lights.latlong_sampling`).
    """

    image, filter = checks.Fixed("the sampling tables derive from it"), checks.Fixed("the sampling table too")
    compiled_kind = "latlong"

    @classmethod
    def example(cls):
        """A small procedural sky with a sun (64 x 32)."""
        return cls(procedural_sky(64, 32))

    def __init__(self, image, *, intensity=1.0, rotate=None, filter="bilinear", hide_background=False,
                 background=0.0, name=None):
        super().__init__(intensity=intensity, rotate=rotate, hide_background=hide_background,
                         background=background, name=name)
        owner = f"LatLongEnvironment({name or ''})"
        self.filter, self.image = filtered_image(owner, image, filter)
        if self.image.shape[0] < 2 or self.image.shape[1] < 2:
            raise EnvironmentMapError(f"{owner}: image must be at least 2x2 texels, got {self.image.shape[:2]}")
        self._dist = None

    @property
    def distribution(self):
        """The importance-sampling table (built once, on first use; bilinear maps: the dual cells')."""
        if self.filter == "bilinear":
            return self.bilinear_table.dist
        if self._dist is None:
            self._dist = K.distribution2d_build(K.latlong_sampling_weights(self.image, self.filter))
        return self._dist

    def _radiance_local(self, d):
        return K.latlong_lookup(self.image, d, self.filter)

    @property
    def radiance_resolution(self):
        """The map's (H, W): what :meth:`irradiance`'s quadrature refines."""
        return self.image.shape[:2]

    def _sh9_local(self):
        return K.sh9_project_latlong(self.image)

    def _build_prefiltered(self):
        return _prefilter_stack(self.image)


@ENVIRONMENTS.register("cube")
class CubeMapEnvironment(Environment):
    """Cube-map environment (OpenGL face convention, see :mod:`shaders.envmap`).

    Parameters
    ----------
    faces : (6, S, S, 3) array, a cross image (H, W, 3) / path, or a list of six face images / paths
        Faces in the order ``+x, -x, +y, -y, +z, -z``; a 4:3 or 3:4 cross is split by
        :func:`shaders.envmap.split_cross`.
    """

    faces, filter = checks.Fixed("the sampling tables derive from them"), checks.Fixed("the sampling table too")

    @classmethod
    def example(cls):
        """The small procedural sky as six 16 x 16 faces."""
        return cls(K.latlong_to_cube(procedural_sky(64, 32), 16))

    def __init__(self, faces, *, intensity=1.0, rotate=None, filter="bilinear", hide_background=False,
                 background=0.0, name=None):
        super().__init__(intensity=intensity, rotate=rotate, hide_background=hide_background,
                         background=background, name=name)
        owner = f"CubeMapEnvironment({name or ''})"
        if filter not in FILTERS:
            raise EnvironmentMapError(f"{owner}: filter must be one of {FILTERS}, got {filter!r}")
        self.filter = filter
        if isinstance(faces, (list, tuple)) and len(faces) == 6:
            fs = [_image(owner, f) for f in faces]
            if any(f.shape != fs[0].shape or f.shape[0] != f.shape[1] for f in fs):
                raise EnvironmentMapError(f"{owner}: the six faces must be square and of equal size, got "
                                          f"{[f.shape[:2] for f in fs]}")
            arr = np.stack(fs)
        else:
            a = np.asarray(faces) if not isinstance(faces, (str, os.PathLike)) else None
            if a is not None and a.ndim == 4:
                if a.shape[0] != 6 or a.shape[1] != a.shape[2]:
                    raise EnvironmentMapError(f"{owner}: faces must have shape (6, S, S, 3), got {a.shape}")
                arr = np.stack([_image(owner, f) for f in a])
            else:
                img = _image(owner, faces)
                try:
                    arr = K.split_cross(img)
                except ValueError as e:
                    raise EnvironmentMapError(f"{owner}: {e}") from None
        self.faces = np.ascontiguousarray(arr)
        self._dist = None

    @property
    def distribution(self):
        """The importance-sampling table (built on first use, float64)."""
        if self._dist is None:
            self._dist = K.distribution2d_build(K.cube_sampling_weights(self.faces, self.filter))
        return self._dist

    def _radiance_local(self, d):
        return K.cube_lookup(self.faces, d, self.filter)

    @property
    def radiance_resolution(self):
        """(2S, 4S): a lat-long map of that size resolves S x S faces (what :meth:`irradiance` refines)."""
        return 2 * self.faces.shape[1], 4 * self.faces.shape[1]

    def _sample_local(self, u):
        return K.cube_sample(self.distribution, u)

    def _pdf_local(self, d):
        return K.cube_pdf(self.distribution, d)

    @property
    def compensated_distribution(self):
        """The MIS-compensated table (:meth:`Environment.sample_compensated`; None for a constant map)."""
        if self._cdist is None:
            jac = np.tile(K.cube_texel_jacobian(self.faces.shape[1]), (6, 1))
            self._cdist = (self._compensated_table(self.distribution, jac),)
        return self._cdist[0]

    def _sample_compensated_local(self, u):
        return incomplete_sample(K.cube_sample, self.compensated_distribution, u)

    def _pdf_compensated_local(self, d):
        return incomplete_pdf(K.cube_pdf, self.compensated_distribution, d)

    def _sh9_local(self):
        s = self.faces.shape[1]
        d = K.cube_texel_directions(s).reshape(-1, 3)
        dw = np.tile(K.cube_texel_solid_angle(s).ravel(), 6)
        return K.sh9_project(d, self.faces.reshape(-1, 3), dw)

    def _build_prefiltered(self):
        s = self.faces.shape[1]
        return _prefilter_stack(K.cube_to_latlong(self.faces, 2 * s, 4 * s, self.filter))


# ----------------------------------------------------------------------------- procedural sky


def procedural_sky(width=256, height=128, *, sun_direction=(0.4, 0.5, -0.3), sun_angle=3.0,
                   sun_radiance=(2000.0, 1800.0, 1500.0), zenith=(0.15, 0.3, 0.8), horizon=(0.9, 0.95, 1.0),
                   ground=(0.25, 0.22, 0.2), supersample=4):
    """A small HDR lat-long sky: zenith-to-horizon gradient, a dark ground and a bright sun disc.

    Parameters
    ----------
    sun_direction : 3 floats
        Direction *toward* the sun (normalised here).
    sun_angle : float
        Angular **radius** of the sun disc in degrees (the real sun: 0.27).
    sun_radiance, zenith, horizon, ground : RGB radiance (W m^-2 sr^-1).
    supersample : int
        Sun coverage is integrated with ``supersample^2`` points per texel (anti-aliased disc).

    Returns
    -------
    (height, width, 3) float32
        Sky radiance ``horizon + (zenith - horizon) * sqrt(y)`` above the horizon, ``ground`` below,
        plus the sun (``sun_radiance`` times the fraction of the texel it covers).
    """
    sd = checks.numbers_array("procedural_sky", "sun_direction", sun_direction, EnvironmentMapError)
    if sd.shape != (3,) or not np.all(np.isfinite(sd)) or not np.linalg.norm(sd) > 0:
        raise EnvironmentMapError(f"procedural_sky: sun_direction must be a finite non-zero 3-vector, got {sun_direction!r}")
    sd = sd / np.linalg.norm(sd)
    dirs = K.latlong_texel_directions(height, width)
    y = dirs[..., 1:2]
    t = np.sqrt(np.clip(y, 0.0, 1.0))
    sky = np.where(y > 0, np.asarray(horizon) + (np.asarray(zenith) - np.asarray(horizon)) * t,
                   np.asarray(ground, dtype=np.float64))
    cos_sun = math.cos(math.radians(sun_angle))
    # supersample only the texels near the sun
    near = (dirs.reshape(-1, 3) @ sd) > math.cos(math.radians(sun_angle) + 4.0 * math.pi / height)
    idx = np.flatnonzero(near)
    cover = np.zeros(height * width)
    if idx.size:
        jj, ii = np.divmod(idx, width)
        o = (np.arange(supersample) + 0.5) / supersample
        ou, ov = np.meshgrid(o, o)
        uu = ((ii[:, None] + ou.ravel()[None]) / width).ravel()
        vv = ((jj[:, None] + ov.ravel()[None]) / height).ravel()
        dd = K.latlong_uv_to_dir(np.stack([uu, vv], axis=1))
        inside = (dd @ sd) >= cos_sun
        cover[idx] = inside.reshape(idx.size, -1).mean(axis=1)
    sky = sky + cover.reshape(height, width, 1) * np.asarray(sun_radiance, dtype=np.float64)
    return sky.astype(np.float32)
