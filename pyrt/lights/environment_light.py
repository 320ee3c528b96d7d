"""The environment as a light: :class:`EnvironmentLight` (the estimator's parameters) and :func:`set_environment`.

An :class:`EnvironmentLight` only samples and names its estimator; :func:`pyrt.integrators.direct.
environment_estimate` estimates ``L_o = int f(wo, wi) L(wi) V(wi) cos theta_i dwi`` at every non-specular hit
with the strategy it names (:data:`pyrt.lights.environment.STRATEGIES`, described in
:mod:`pyrt.lights.environment`).

Sample splitting and MIS compensation (``strategy="mis"``)
---------------------------------------------------------
``n_samples`` light samples and ``bsdf_samples`` BSDF samples per hit (default: as many as light samples),
each with its own shadow ray, amortise the camera ray, the hit's surface reconstruction and its material
parameters over several shadow rays. The two techniques are combined with the power (beta = 2) or balance
heuristic *with the sample counts* (Veach 1997): a direction of light density ``p_l`` and BSDF density
``p_b`` gets ``w_l = h(n_l p_l, n_b p_b)`` as a light sample and ``w_b = h(n_b p_b, n_l p_l)`` as a BSDF
sample, ``w_l + w_b = 1`` wherever ``p_l + p_b > 0``; each light sample contributes
``w_l f L / (n_l p_l)``, each BSDF sample ``w_b f L / (n_b p_b)``.

``compensate=True`` draws the light samples from the MIS-compensated table of the map (Karlik, Sik, Vevoda,
Skrivan & Krivanek 2019, "MIS compensation: optimizing sampling techniques in multiple importance sampling"):
``max(0, luminance - mean luminance)`` instead of the luminance (:meth:`pyrt.lights.environment.Environment.
sample_compensated`), the weights use its density on both sides (pbrt-v4's ``allowIncompletePDF``). Where
the compensated density is 0 (the map below its mean) the BSDF samples have weight 1, so the combination
stays unbiased; the compensated table is never used alone (``strategy="map"``, :meth:`sample_li`,
:meth:`pdf_li` and the glossy integrator's light sampling keep the full table).

Control variate (``control_variate=True``, every strategy but ``preview``)
-----------------------------------------------------------------------
At a hit of a Lambertian material (:attr:`pyrt.materials.Material.lambertian`, ``f = rho / pi``) on a flat face
(the shading normal is the geometric one ``n``: no interpolated vertex normals, no normal map, and ``n.wo > 0``)
every strategy's samples, with the visibility ``V`` replaced by 1, estimate ``rho / pi E(n)`` without bias, with
``E(n) = int L max(0, n.w) dw`` the unshadowed irradiance (the sampled domain ``n.w > 0`` is the whole support
of ``f cos``). So

    ``F_cv = rho / pi E(n) + sum_samples (V - 1) value``

has the expectation of the plain estimate ``sum V value`` (``E`` from :meth:`Environment.irradiance`, whose
quadrature error is the only bias, <= 5e-4 relative), and its variance comes only from the samples that occluders
block: zero on unoccluded ground. With transparent shadows ``V`` is a transmittance (k, 3) and ``V - 1`` is taken
per channel. Hits of other materials and of smooth-shaded faces are estimated as before, bit for bit; the
bookkeeping (which hits, ``E`` per distinct normal, at most :data:`pyrt.integrators.direct.CV_MAX_NORMALS` normals
per batch) is in :func:`pyrt.integrators.direct.environment_estimate`.

Off by default: it removes the noise of unoccluded light, but it also moves the noise of the samples that find
the sun from the lit ground (where the plain estimate had it) into the sun's shadows (where the plain estimate,
whose sun samples are blocked, had none), and relMSE weighs a shadow's error by ``1 / R^2``.
``python tools/control_variate_chart.py`` (320 x 240, 4 / 16 / 64 spp, threads = 1, 3 interleaved runs,
docs/environment.md): the benchmark's ``sky`` scene (a sun of radiance 400 in a 512 x 256 map, 4 + 4 samples) 0.79-0.80x
the relMSE at 1.02-1.03x the time, relMSE x time 0.81-0.82x (a win); ``tools/bench_kinds.py``'s ``env`` scene (a sun of
2000 in a 256 x 128 map, 1 + 1 samples) 2.8-3.0x the relMSE at 1.03-1.07x the time, relMSE x time 2.9-3.2x (a loss:
at 16 spp the lit ground's part of the relMSE falls 13x, the shadowed ground's rises 38x). The sun's own estimate is
that noisy because the importance table of a bilinear map is 3 x 3-dilated: a third (256 x 128 map) or a fifth
(512 x 256) of the sun's table mass lies on texels below half their dilated weight, and ``L / p`` of a sun sample
varies by 66 % / 47 % (relative standard deviation over the table's texels). Read with ``filter="nearest"`` (an
exact table) the plain relMSE of both scenes is lower (1.5x, 5.6x, each against its own reference) and the variate
nearly neutral (relMSE x time 0.95-0.96x and 1.02-1.06x).

Defaults (``n_samples = bsdf_samples =`` :data:`DEFAULT_SAMPLES` ``= 2``, ``compensate=True``, power heuristic)
were picked from ``tools/estimator_chart.py``: relMSE x render time at equal shadow rays per pixel against one
light and one BSDF sample per hit without compensation, with the padded camera-hit samples, 0.63x under a sky with a
sun and 0.85x under a smooth studio map (4 + 4: 0.99x and 1.02x; see :data:`DEFAULT_SAMPLES`); the balance
heuristic was no better (1.03-1.10x, measured with 4 + 4).
"""
from __future__ import annotations

import numbers

import numpy as np

from pyrt.shaders import sampling

from pyrt.lights import compiled as _compiled
from pyrt.lights import compiled_env as _compiled_env
from pyrt.lights.base import Light, LightSample
from pyrt.lights.environment import HEURISTICS, STRATEGIES, Environment, EnvironmentMapError

#: samples per hit of each technique by default (``n_samples``; ``bsdf_samples`` follows it), with
#: ``compensate=True``: measured by ``tools/estimator_chart.py`` (docs/environment.md). With padded camera-hit
#: samples (``sampler="padded"``) 2 + 2 has 0.63x (sun sky) and 0.85x (studio map) the relMSE x time of
#: one light + one BSDF sample without compensation, and 4 + 4 0.99x and 1.02x: a pixel's samples are stratified
#: over its spp now, so more samples per hit buy less (with independent draws 4 + 4 had been 1.5-2.4x better)
DEFAULT_SAMPLES = 2
#: the values of ``EnvironmentLight(preview_method=...)``
PREVIEW_METHODS = ("split_sum", "samples")


class EnvironmentLight(Light):
    """Image-based lighting from an :class:`Environment` at non-specular hits.

    Parameters
    ----------
    environment : Environment
    strategy : str
        One of :data:`STRATEGIES` (see :mod:`pyrt.lights.environment`). Default ``"mis"``.
    n_samples : int
        Light (or, for ``uniform``, ``cosine``, ``bsdf``, the strategy's) samples per hit. Default
        :data:`DEFAULT_SAMPLES` = 2.
    bsdf_samples : int or None
        BSDF samples per hit of ``strategy="mis"`` (None: ``n_samples``). Each sample of either kind traces
        one shadow ray.
    heuristic : {"power", "balance"}
        MIS weighting (power heuristic with beta = 2, or the balance heuristic), with the sample counts.
    compensate : bool
        ``mis`` draws its light samples from the MIS-compensated table (module docstring). Default True.
    preview_samples : int
        Fixed BSDF samples per hit of the ``preview`` approximation for materials it samples.
    preview_method : {"split_sum", "samples"}
        How ``preview`` lights non-Lambertian materials: ``"split_sum"`` (default) the materials that declare
        their lobes (:meth:`pyrt.materials.Material.preview_lobes`: metallic-roughness, glTF PBR without
        transmission, clear coats over them) by the split sum (prefiltered map x directional albedo, one lookup
        per lobe) and the others by ``preview_samples`` BSDF samples; ``"samples"`` every one of them by samples.
    control_variate : bool
        Every sampled strategy: at hits of Lambertian materials on flat faces add the unshadowed irradiance
        ``albedo / pi * E(n)`` (:meth:`pyrt.lights.environment.Environment.irradiance`) and let the samples
        estimate only what occluders take away, ``(V - 1)`` times their value (module docstring). Default False:
        it moves the sun samples' noise from lit ground into the sun's shadows, and loses 2.9-3.2x at equal time on
        ``tools/bench_kinds.py``'s ``env`` scene while it wins 1.22-1.24x on the benchmark's ``sky`` scene (module docstring).
    """

    delta = False

    def __init__(self, environment, *, strategy="mis", n_samples=DEFAULT_SAMPLES, bsdf_samples=None,
                 heuristic="power", compensate=True, preview_samples=16, preview_method="split_sum",
                 control_variate=False, name=None):
        owner = f"EnvironmentLight({name or ''})"
        if not isinstance(environment, Environment):
            raise EnvironmentMapError(f"{owner}: environment must be a pyrt Environment, got "
                                      f"{type(environment).__name__}")
        if strategy not in STRATEGIES:
            raise EnvironmentMapError(f"{owner}: strategy must be one of {STRATEGIES}, got {strategy!r}")
        if heuristic not in HEURISTICS:
            raise EnvironmentMapError(f"{owner}: heuristic must be one of {HEURISTICS}, got {heuristic!r}")
        if bsdf_samples is None:
            bsdf_samples = n_samples
        for nm, v in (("n_samples", n_samples), ("bsdf_samples", bsdf_samples), ("preview_samples", preview_samples)):
            if not isinstance(v, numbers.Integral) or isinstance(v, bool) or v < 1:
                raise EnvironmentMapError(f"{owner}: {nm} must be a positive integer, got {v!r}")
        for nm, v in (("compensate", compensate), ("control_variate", control_variate)):
            if not isinstance(v, (bool, np.bool_)):
                raise EnvironmentMapError(f"{owner}: {nm} must be true or false, got {v!r}")
        if preview_method not in PREVIEW_METHODS:
            raise EnvironmentMapError(f"{owner}: preview_method must be one of {PREVIEW_METHODS}, got "
                                      f"{preview_method!r}")
        self.environment = environment
        self.strategy = strategy
        self.n_samples = int(n_samples)
        self.bsdf_samples = int(bsdf_samples)
        self.heuristic = heuristic
        self.compensate = bool(compensate)
        self.preview_samples = int(preview_samples)
        self.preview_method = preview_method
        self.control_variate = bool(control_variate)
        self.name = name

    def validate(self):
        """The base checks, and ``compensate`` and ``control_variate`` still true or false."""
        super().validate()
        for nm, v in (("compensate", self.compensate), ("control_variate", self.control_variate)):
            if not isinstance(v, (bool, np.bool_)):
                raise EnvironmentMapError(f"{self.label}: {nm} must be true or false, got {v!r}")

    def compiled_record(self):
        """:data:`pyrt.lights.compiled.ENV` for ``strategy="mis"`` without the control variate and for
        ``strategy="preview"`` (either method; the control variate does not apply to it), over an environment the
        kernel can read (:func:`pyrt.lights.compiled_env.pack_environment`; the preview's tables:
        :mod:`pyrt.lights.compiled_env_preview`); None otherwise."""
        mis = self.strategy == "mis" and not self.control_variate
        if not (mis or self.strategy == "preview") or not _compiled_env.packable(self.environment):
            return None
        rec = np.zeros(_compiled.RECORD)
        rec[0], rec[1] = self.n_samples, self.bsdf_samples
        rec[2] = 1.0 if mis else 0.0     # the glossy integrator samples the map at glossy hits (not the preview's)
        return _compiled.ENV, rec

    def sample(self, p, u):
        """Environment importance sample as a plain light sample (``E = L / pdf``, ``dist = inf``)."""
        wi, pdf = self.environment.sample(u)
        L = self.environment.radiance(wi)
        E = np.where((pdf > 0)[:, None], L / np.where(pdf > 0, pdf, 1.0)[:, None], 0.0)
        return wi, np.full(wi.shape[0], np.inf), E

    def sample_li(self, p, u):
        """Environment importance samples as a :class:`LightSample` (``E = L / pdf``, ``dist = inf``)."""
        wi, dist, E = self.sample(p, u)
        return LightSample(wi, dist, E)

    def pdf_li(self, p, wi):
        """Solid-angle density (N,) of :meth:`sample_li` (the environment's importance sampling)."""
        return self.environment.pdf(wi)

    def radiance(self, d):
        """Radiance (N, 3) arriving from world directions ``d`` (N, 3)."""
        return self.environment.radiance(d)

    def mis_sample(self, u):
        """The light-sampling technique of ``strategy="mis"``: ``(wi (N, 3), pdf (N,))`` from the compensated
        table if :attr:`compensate`, else from the full one."""
        if self.compensate:
            return self.environment.sample_compensated(u)
        return self.environment.sample(u)

    def mis_pdf(self, wi):
        """Density (N,) of :meth:`mis_sample` at world directions ``wi`` (what the MIS weights use)."""
        if self.compensate:
            return self.environment.pdf_compensated(wi)
        return self.environment.pdf(wi)

    def mis_weights(self, pdf_light, pdf_bsdf):
        """``(w_light, w_bsdf)`` (N,) of directions with light density ``pdf_light`` (:meth:`mis_pdf`) and BSDF
        density ``pdf_bsdf``: :attr:`heuristic` with the counts ``n_samples``, ``bsdf_samples``. They sum to 1
        where either density is positive, both 0 where both are."""
        beta = 2.0 if self.heuristic == "power" else 1.0
        nl, nb = (1, 1) if self.n_samples == self.bsdf_samples else (self.n_samples, self.bsdf_samples)
        return (sampling.power_heuristic(pdf_light, pdf_bsdf, beta, nl, nb),
                sampling.power_heuristic(pdf_bsdf, pdf_light, beta, nb, nl))


def set_environment(scene, environment, *, lighting="mis", n_samples=DEFAULT_SAMPLES, bsdf_samples=None,
                    heuristic="power", compensate=True, preview_samples=16, preview_method="split_sum",
                    control_variate=False):
    """Use ``environment`` in ``scene``: seen where rays miss, and (unless ``lighting`` is None/False) as a
    light with the named strategy (the other keywords: :class:`EnvironmentLight`). Replaces a previous
    :class:`EnvironmentLight`. Returns the light or None.
    """
    if environment is not None and not isinstance(environment, Environment):
        raise EnvironmentMapError(f"set_environment: expected a pyrt Environment, got {type(environment).__name__}")
    scene.environment = environment
    scene.lights[:] = [lt for lt in scene.lights if not isinstance(lt, EnvironmentLight)]
    if environment is None or lighting in (None, False):
        return None
    light = EnvironmentLight(environment, strategy=lighting, n_samples=n_samples, bsdf_samples=bsdf_samples,
                             heuristic=heuristic, compensate=compensate, preview_samples=preview_samples,
                             preview_method=preview_method, control_variate=control_variate)
    scene.add_light(light)
    return light
