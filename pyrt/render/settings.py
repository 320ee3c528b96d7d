"""Render options grouped by what they configure: the integrator, the sampling, the output, the execution.

``pyrt.render(scene, spp=4)`` stays the one-line call; everything else is an object (or a dict of the same keys,
which is what scene files and :func:`pyrt.load_dict` give)::

    pyrt.render_full(scene, spp=16, seed=1,
                     integrator=pyrt.Glossy(samples=4, depth=2, max_depth=8),      # or {"type": "glossy", ...}
                     sampling=pyrt.Sampling(target_error=1e-3, max_spp=256),        # adaptive instead of spp
                     output=pyrt.Output(aovs=True),
                     execution=pyrt.Execution(threads=2, backend="numpy"))

Each integrator takes only its own parameters (Mitsuba 3's ``{"type": "path", "max_depth": 8}``, pbrt-v4's
``Integrator`` block): ``pyrt.Whitted(samples=4)`` is an error naming ``samples``, which is :class:`Glossy`'s. The
groups likewise refuse an option that their other settings leave unused: ``min_spp`` without an adaptive target,
``fill_budget`` without ``fill``, ``dask_workers`` without ``dask=True``.

:data:`LEGACY` maps the flat keywords ``render_full`` took before (``max_depth=``, ``aovs=``, ``threads=`` ...) to
the group and the name they have now: :func:`from_keywords` still accepts them, with a ``DeprecationWarning`` that
names the new spelling.
"""
from __future__ import annotations

from dataclasses import dataclass, fields
from typing import Any, ClassVar
import warnings

from pyrt.core import checks
from pyrt.core.errors import RenderError
from pyrt.integrators.whitted import DEFAULT_SPLIT_DEPTH

#: the flat keyword arguments of ``render_full`` before the groups -> (group, name in the group)
LEGACY = {
    "max_depth": ("integrator", "max_depth"), "throughput_cutoff": ("integrator", "throughput_cutoff"),
    "roulette": ("integrator", "roulette"),
    "offset": ("integrator", "offset"), "transparent_shadows": ("integrator", "transparent_shadows"),
    "split_depth": ("integrator", "split_depth"), "light_select_depth": ("integrator", "light_select_depth"),
    "batch_rays": ("integrator", "batch_rays"), "glossy_samples": ("integrator", "samples"),
    "glossy_depth": ("integrator", "depth"), "glossy_threshold": ("integrator", "threshold"),
    "glossy_clamp": ("integrator", "clamp"),
    "target_error": ("sampling", "target_error"), "time_budget": ("sampling", "time_budget"),
    "max_spp": ("sampling", "max_spp"), "min_spp": ("sampling", "min_spp"), "on_pass": ("sampling", "on_pass"),
    "sampler": ("sampling", "sampler"),
    "aovs": ("output", "aovs"), "nonfinite": ("output", "nonfinite"), "fill": ("output", "fill"),
    "fill_budget": ("output", "fill_budget"), "record_rays": ("output", "record_rays"),
    "threads": ("execution", "threads"), "backend": ("execution", "backend"), "parallel": ("execution", "parallel"),
    "dask": ("execution", "dask"), "dask_workers": ("execution", "dask_workers"), "cancel": ("execution", "cancel"),
    "progress": ("execution", "progress"), "prepared": ("execution", "prepared"),
    "chunk_samples": ("execution", "chunk_samples"),
}
#: the prefix of the DeprecationWarning of :func:`from_keywords` (a warnings filter can match it)
DEPRECATED = "deprecated render keywords"


def _optional_int(owner, name, value, lo):
    return None if value is None else checks.integer(owner, name, value, RenderError, lo=lo)


class _Options:
    """Base of the option classes: an unknown keyword is a :class:`RenderError` (a ``pyrt.Error``) that names it and,
    when it is another class's option, that class (``pyrt.Whitted(samples=4)``: ``samples`` is ``Glossy``'s)."""

    def __new__(cls, *args, **options):
        allowed = [f.name for f in fields(cls)]
        bad = [k for k in options if k not in allowed]
        if bad:
            hint = "; ".join(f"{k} is {_where(k)}" for k in bad if _where(k))
            raise RenderError(f"{cls.__name__}: no option {', '.join(map(repr, bad))}"
                              + (f" ({hint})" if hint else "") + f"; its options: {', '.join(allowed)}")
        return super().__new__(cls)


@dataclass(frozen=True, kw_only=True)
class Whitted(_Options):
    """The Whitted integrator (the default): light sampling at every hit, rays only along delta lobes (mirrors,
    glass); :mod:`pyrt.integrators.whitted`.

    Parameters
    ----------
    max_depth : int
        Bounces of mirror and glass rays (0: direct light only). Default 8.
    throughput_cutoff : float
        Rays whose throughput falls below this are dropped (or played by Russian roulette). Default 1e-4.
    roulette : bool
        Continue the rays below ``throughput_cutoff`` with probability ``throughput / throughput_cutoff``, weighted
        by its inverse (unbiased, a little noisier; :mod:`pyrt.integrators.roulette`). Default False.
    split_depth : int or None
        From this bounce on a dielectric hit follows one of its two delta lobes, chosen by weight and weighted by
        1 / probability (unbiased); None: both at every bounce (Whitted's full tree). Default 3.
    light_select_depth : int or None
        From this bounce on, camera hits and hits of BSDF-sampled rays are lit by one delta light chosen by its
        irradiance (unbiased, noisier); None (default): every light.
    offset : str, Strategy or callable, optional
        The ray-origin offset (:mod:`pyrt.geometry.offsets`); default ``"robust"``.
    transparent_shadows : bool
        Shadow rays pass through dielectrics, attenuated (an approximation; default False).
    batch_rays : int, optional
        Shade a bounce in slices of at most this many rays (bounds memory; NumPy path). Default: a bounce at once.
    """
    type: ClassVar[str] = "whitted"
    max_depth: int = 8
    throughput_cutoff: float = 1e-4
    roulette: bool = False
    split_depth: int | None = DEFAULT_SPLIT_DEPTH
    light_select_depth: int | None = None
    offset: Any = None
    transparent_shadows: bool = False
    batch_rays: int | None = None

    def __post_init__(self):
        owner = type(self).__name__
        checks.integer(owner, "max_depth", self.max_depth, RenderError, lo=0)
        checks.finite_number(owner, "throughput_cutoff", self.throughput_cutoff, RenderError, lo=0.0)
        _optional_int(owner, "split_depth", self.split_depth, 0)
        _optional_int(owner, "light_select_depth", self.light_select_depth, 0)
        _optional_int(owner, "batch_rays", self.batch_rays, 1)
        for name, value in (("transparent_shadows", self.transparent_shadows), ("roulette", self.roulette)):
            if not isinstance(value, bool):
                raise RenderError(f"{owner}: {name} must be True or False, got {value!r}")

    def keywords(self):
        """The integrator's options as the render implementation's keyword arguments."""
        return dict(integrator=self.type, max_depth=self.max_depth, throughput_cutoff=self.throughput_cutoff,
                    roulette=self.roulette, offset=self.offset, transparent_shadows=self.transparent_shadows, split_depth=self.split_depth,
                    light_select_depth=self.light_select_depth, batch_rays=self.batch_rays)


@dataclass(frozen=True, kw_only=True)
class Glossy(Whitted):
    """The glossy integrator: Whitted's, and glossy lobes also spawn BSDF-sampled rays, combined with light sampling
    by multiple importance sampling (:mod:`pyrt.integrators.glossy`). Takes every :class:`Whitted` parameter, and:

    Parameters
    ----------
    samples : int
        BSDF-sampled rays per glossy hit on the first bounce (1 deeper). Default 4.
    depth : int
        Bounces that spawn glossy rays. Default 2.
    threshold : float
        A lobe whose ``glossy_alpha`` is above this counts as diffuse (no rays). Default 0.4.
    clamp : float or None
        Clamp of the direct light at hits of glossy rays (biased, against fireflies); default None: no clamp.
    """
    type: ClassVar[str] = "glossy"
    samples: int = 4
    depth: int = 2
    threshold: float = 0.4
    clamp: float | None = None

    def __post_init__(self):
        super().__post_init__()
        checks.integer("Glossy", "samples", self.samples, RenderError, lo=1)
        checks.integer("Glossy", "depth", self.depth, RenderError, lo=0)
        checks.finite_number("Glossy", "threshold", self.threshold, RenderError, lo=0.0)
        if self.clamp is not None:
            checks.finite_number("Glossy", "clamp", self.clamp, RenderError, lo=0.0)

    def keywords(self):
        """The integrator's options as the render implementation's keyword arguments."""
        return dict(super().keywords(), glossy_samples=self.samples, glossy_depth=self.depth,
                    glossy_threshold=self.threshold, glossy_clamp=self.clamp)


#: integrator type names (``{"type": ...}``, ``integrator="glossy"``, scene files, ``--integrator``) -> class
INTEGRATOR_TYPES = {"whitted": Whitted, "glossy": Glossy}


@dataclass(frozen=True, kw_only=True)
class Sampling(_Options):
    """How many samples: a fixed ``spp`` (default: the camera's) or an adaptive target (:mod:`pyrt.render.adaptive`).

    Parameters
    ----------
    spp : int, optional
        Samples per pixel; excludes the adaptive options. ``render(scene, spp=...)`` is the short form.
    target_error, time_budget, max_spp : float, float, int, optional
        Adaptive passes until the estimated relMSE is at most ``target_error``, ``time_budget`` seconds have passed
        (from the call, the compiled kernel's load or first compile not counted), or every pixel that still needs
        samples has ``max_spp`` (default 65536); at least one of the first two.
    min_spp : int, optional
        The adaptive base pass (even; default 4). Only with an adaptive target.
    on_pass : callable, optional
        Called with a :class:`pyrt.render.adaptive.PassInfo` after every adaptive pass. Only with an adaptive target.
    sampler : {"padded", "independent"}
        The light and BSDF samples at camera hits: one stratified set per pixel and dimension pair (default), or
        independent draws.
    """
    spp: int | None = None
    target_error: float | None = None
    time_budget: float | None = None
    max_spp: int | None = None
    min_spp: int | None = None
    on_pass: Any = None
    sampler: str = "padded"

    @property
    def adaptive(self):
        """True when an adaptive option is set (``target_error``, ``time_budget`` or ``max_spp``)."""
        return self.target_error is not None or self.time_budget is not None or self.max_spp is not None

    def __post_init__(self):
        _optional_int("Sampling", "spp", self.spp, 1)
        if self.spp is not None and self.adaptive:
            raise RenderError("Sampling: spp (fixed samples per pixel) and target_error / time_budget / max_spp "
                              "(adaptive) exclude each other")
        for name, value in (("min_spp", self.min_spp), ("on_pass", self.on_pass)):
            if not self.adaptive and value is not None:
                raise RenderError(f"Sampling: {name} is an option of adaptive sampling, which needs target_error or "
                                  "time_budget; a fixed-spp render does not use it")

    def keywords(self):
        """The sampling options as the render implementation's keyword arguments (``spp`` apart)."""
        return dict(target_error=self.target_error, time_budget=self.time_budget, max_spp=self.max_spp,
                    min_spp=4 if self.min_spp is None else self.min_spp, on_pass=self.on_pass, sampler=self.sampler)


@dataclass(frozen=True, kw_only=True)
class Output(_Options):
    """What a render returns besides the image.

    Parameters
    ----------
    aovs : bool
        Also the first hit's depth, shading normal and albedo per pixel (``result.aovs``).
    nonfinite : {"zero", "raise"}
        Samples with non-finite radiance: zeroed, counted and warned about, or an error.
    fill : bool
        After a cancellation, give the pixels without a sample one sample each when that fits ``fill_budget``.
    fill_budget : float, optional
        Seconds the fill may take (default 2). Only with ``fill``.
    record_rays : bool
        Keep every traced ray in ``result.stats.recorded`` (benchmarks; NumPy path).
    """
    aovs: bool = False
    nonfinite: str = "zero"
    fill: bool = False
    fill_budget: float | None = None
    record_rays: bool = False

    def __post_init__(self):
        if self.fill_budget is not None:
            if not self.fill:
                raise RenderError("Output: fill_budget is the time of the fill after a cancellation: it needs "
                                  "fill=True")
            checks.finite_number("Output", "fill_budget", self.fill_budget, RenderError, lo=0.0)

    def keywords(self):
        """The output options as the render implementation's keyword arguments."""
        return dict(aovs=self.aovs, nonfinite=self.nonfinite, fill=self.fill,
                    fill_budget=2.0 if self.fill_budget is None else self.fill_budget, record_rays=self.record_rays)


@dataclass(frozen=True, kw_only=True)
class Execution(_Options):
    """Where and how a render runs; none of these changes the image (``chunk_samples`` changes the noise only).

    Parameters
    ----------
    threads : int, optional
        Workers (default: all cores).
    backend : {"auto", "compiled", "numpy"}
        The compiled tile kernel where it covers the scene (``"auto"``), always (``"compiled"``, an error where it
        does not) or the NumPy reference path.
    parallel : {"auto", "threads", "processes"}
        NumPy path: forked worker processes or threads.
    dask : distributed.Client, str or True, optional
        Render the chunks as tasks on Dask workers (a client, a scheduler address, or True: a local cluster).
    dask_workers : int, optional
        Processes of the local cluster of ``dask=True`` (default 2). Only with ``dask=True``.
    cancel : threading.Event, optional
        Once set, no new chunk starts (``result.complete`` is then False).
    progress : bool, optional
        A progress bar (default: only on a terminal; ``tqdm.auto`` in Jupyter).
    prepared : PreparedScene, optional
        A scene prepared earlier (BVH built once for several renders); the caller closes it.
    chunk_samples : int
        Camera samples per chunk (bounds memory at any spp). Default 32768.
    """
    threads: int | None = None
    backend: str = "auto"
    parallel: str = "auto"
    dask: Any = None
    dask_workers: int | None = None
    cancel: Any = None
    progress: bool | None = None
    prepared: Any = None
    chunk_samples: int = 1 << 15

    def __post_init__(self):
        _optional_int("Execution", "threads", self.threads, 1)
        checks.integer("Execution", "chunk_samples", self.chunk_samples, RenderError)
        if self.dask_workers is not None:
            if self.dask is not True:
                raise RenderError("Execution: dask_workers sizes the local cluster of dask=True; with "
                                  f"dask={self.dask!r} it is unused")
            checks.integer("Execution", "dask_workers", self.dask_workers, RenderError)

    def keywords(self):
        """The execution options as the render implementation's keyword arguments."""
        return dict(threads=self.threads, backend=self.backend, parallel=self.parallel, dask=self.dask,
                    dask_workers=2 if self.dask_workers is None else self.dask_workers, cancel=self.cancel,
                    progress=self.progress, prepared=self.prepared, chunk_samples=self.chunk_samples)


GROUPS = {"sampling": Sampling, "output": Output, "execution": Execution}


def _where(name):
    """How to spell option ``name`` in the group it belongs to, for error messages; None when it is no option."""
    if name in {f.name for f in fields(Whitted)}:
        return f"integrator=pyrt.Whitted({name}=...) (or Glossy)"
    if name in {f.name for f in fields(Glossy)}:
        return f"integrator=pyrt.Glossy({name}=...)"
    for group, cls in GROUPS.items():
        if name in {f.name for f in fields(cls)}:
            return f"{group}=pyrt.{cls.__name__}({name}=...)"
    return None


def _construct(cls, options, what):
    try:
        return cls(**options)
    except TypeError:
        allowed = [f.name for f in fields(cls)]
        bad = [k for k in options if k not in allowed]
        hint = "; ".join(f"{k} is {_where(k)}" for k in bad if _where(k))
        raise RenderError(f"{what}: no option {', '.join(map(repr, bad))}" + (f" ({hint})" if hint else "")
                          + f"; its options: {', '.join(allowed)}") from None


def integrator_from(value):
    """An integrator object from ``value``: a :class:`Whitted` / :class:`Glossy`, a type name (``"glossy"``) or a
    dict ``{"type": name, option: value, ...}``; a :class:`RenderError` naming what is wrong otherwise."""
    if isinstance(value, Whitted):
        return value
    if isinstance(value, str):
        value = {"type": value}
    if not isinstance(value, dict):
        raise RenderError(f"render: integrator must be pyrt.Whitted(...), pyrt.Glossy(...), a type name or a "
                          f"{{'type': ...}} dict, got {value!r}")
    kind = value.get("type", "whitted")
    if kind not in INTEGRATOR_TYPES:
        raise RenderError(f"render: integrator must be one of {sorted(INTEGRATOR_TYPES)}, got {kind!r}")
    cls = INTEGRATOR_TYPES[kind]
    return _construct(cls, {k: v for k, v in value.items() if k != "type"}, f"integrator {kind!r} ({cls.__name__})")


def group_from(name, value):
    """The options object of group ``name`` ("sampling", "output", "execution") from ``value``: the object, a dict
    of its options, or None (the defaults)."""
    cls = GROUPS[name]
    if value is None:
        return cls()
    if isinstance(value, cls):
        return value
    if not isinstance(value, dict):
        raise RenderError(f"render: {name} must be pyrt.{cls.__name__}(...) or a dict, got {value!r}")
    return _construct(cls, value, f"{name} ({cls.__name__})")


def _spell(group, options):
    if group == "integrator":
        cls = "Glossy" if options.get("type") == "glossy" else "Whitted"
        options = {k: v for k, v in options.items() if k != "type"}
    else:
        cls = GROUPS[group].__name__
    return f"{group}=pyrt.{cls}({', '.join(f'{k}={v!r}' for k, v in options.items())})"


def from_keywords(integrator, sampling, output, execution, legacy, *, stacklevel):
    """The four option objects of a render from its new-style arguments and the flat ``legacy`` keywords of
    :data:`LEGACY` (each moved into its group, with one ``DeprecationWarning`` naming the new spelling). A keyword
    that is not one of them is a :class:`RenderError` naming it; a legacy keyword beside the object of its group,
    too (give it in one place)."""
    unknown = [k for k in legacy if k not in LEGACY]
    if unknown:
        hint = "; ".join(f"{k} is {_where(k)}" for k in unknown if _where(k))
        raise RenderError(f"render: unknown option {', '.join(map(repr, unknown))}" + (f" ({hint})" if hint else "")
                          + "; the keywords are spp, seed, integrator, sampling, output, execution")
    given = {"integrator": integrator, "sampling": sampling, "output": output, "execution": execution}
    moved = {}
    for key, value in legacy.items():
        group, name = LEGACY[key]
        moved.setdefault(group, {})[name] = value
    ignored = []
    for group, options in moved.items():
        current = given[group]
        if group == "integrator" and isinstance(current, str):
            current = {"type": current}
            if current["type"] == "whitted":          # the glossy options were accepted (and checked) unused
                extra = {k: options.pop(k) for k in ("samples", "depth", "threshold", "clamp") if k in options}
                if extra:
                    ignored = [f"glossy_{k}" for k in extra]
                    try:
                        _construct(Glossy, extra, "render")
                    except RenderError as e:
                        raise RenderError(f"{e} (from the keywords {', '.join(ignored)})") from None
        if current is not None and not isinstance(current, dict):
            raise RenderError(f"render: {', '.join(k for k in legacy if LEGACY[k][0] == group)} given beside "
                              f"{group}={type(current).__name__}(...): give them in the {group} object")
        given[group] = {**(current or {}), **options}
    if legacy:
        spelled = {g: {LEGACY[k][1]: v for k, v in legacy.items() if LEGACY[k][0] == g and k not in ignored}
                   for g in moved}
        new = [_spell(g, dict(options, type=given["integrator"].get("type", "whitted")) if g == "integrator"
                      else options) for g, options in spelled.items() if options]
        warnings.warn(f"{DEPRECATED} {', '.join(legacy)}: " + (f"spell them {', '.join(new)}" if new else "drop them")
                      + (f" ({', '.join(ignored)}: options of integrator='glossy', unused by 'whitted')"
                         if ignored else "") + "; the flat keywords go in the next release",
                      DeprecationWarning, stacklevel=stacklevel + 1)
    try:
        integ = integrator_from(given["integrator"])
        groups = {g: group_from(g, given[g]) for g in GROUPS}
    except RenderError as e:
        if legacy:      # say which of the caller's (old) keywords it was
            raise RenderError(f"{e} (from the keywords {', '.join(legacy)})") from None
        raise
    return integ, groups["sampling"], groups["output"], groups["execution"]
