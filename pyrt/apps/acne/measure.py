"""Running the matrix: render each case with each offset strategy, count acne and leak pixels against the
truth, time the shadow rays, and summarise."""
from __future__ import annotations

from dataclasses import dataclass, field
import sys
import threading
import time

import numpy as np

from pyrt.geometry import offsets
from pyrt.integrators import PreparedScene
from pyrt.render import Execution, Whitted, render_full
from pyrt.apps.acne.truth import LIT, SHADOW, UNSURE
from pyrt.apps.acne.scenes import Case, build_case, default_matrix, truth_labels

@dataclass(frozen=True)
class _Timed(offsets.Strategy):
    """A strategy that accumulates the wall-clock time of its shadow-ray set-up."""

    inner: object = None
    clock: list = field(default_factory=lambda: [0.0])
    lock: object = field(default_factory=threading.Lock)   # chunks may run on several threads

    def __call__(self, surf, w):
        return self.inner(surf, w)

    def shadow(self, surf, wi, dist, end=None):
        t0 = time.perf_counter()
        r = self.inner.shadow(surf, wi, dist, end)
        dt = time.perf_counter() - t0
        with self.lock:
            self.clock[0] += dt
        return r


@dataclass
class CaseResult:
    """Outcome of one (case, strategy): pixel counts, timing, and the images for reports."""

    case: Case
    strategy: str
    acne: int
    leak: int
    n_lit: int
    n_shadow: int
    n_dontcare: int
    shadow_rays: int
    time_shadow: float          # seconds: origins + tmax + Embree occlusion test
    truth: np.ndarray = field(repr=False, default=None)
    lit: np.ndarray = field(repr=False, default=None)
    image: np.ndarray = field(repr=False, default=None)

    @property
    def ok(self):
        return self.acne == 0 and self.leak == 0

    @property
    def us_per_shadow_ray(self):
        return 1e6 * self.time_shadow / max(self.shadow_rays, 1)

    @property
    def error_rate(self):
        """(acne + leak) / labelled pixels."""
        return (self.acne + self.leak) / max(self.n_lit + self.n_shadow, 1)


def strategy_name(offset):
    """The name a result is reported under.

    Parameters
    ----------
    offset : None, str, pyrt.geometry.offsets.Strategy or callable
        None: the default strategy; a name; a strategy (its ``name``); a plain function (its
        ``__name__``, else "custom").

    Returns
    -------
    str
    """
    if isinstance(offset, str):
        return offset
    if offset is None:
        return offsets.DEFAULT
    if isinstance(offset, offsets.Strategy):
        return offset.name or "custom"
    return getattr(offset, "__name__", "custom")      # the user's own function (any callable)


def run_case(case, offset=None, *, width=64, height=48, built=None, prepared=None, truth=None, threads=None,
             backend="numpy"):
    """Render ``case`` with ``offset`` (name, callable(surf, w) -> origins, or Strategy) and score it.

    ``backend="numpy"`` (default) renders through the NumPy path with the strategy wrapped to time its shadow
    rays; ``"compiled"`` through the compiled kernel (:mod:`pyrt.integrators.compiled`: the built-in ``robust``
    strategies only, shadow-ray time not measured)."""
    built = built if built is not None else build_case(case, width, height)
    truth = truth if truth is not None else truth_labels(built)
    strat = offsets.get_strategy(offset)
    timed = _Timed(name=strat.name, origin=strat.origin, tmax=strat.tmax, terminator=strat.terminator, inner=strat)
    res = render_full(built.scene, spp=1,
                      integrator=Whitted(max_depth=built.max_depth, offset=timed if backend == "numpy" else offset),
                      execution=Execution(progress=False, prepared=prepared, threads=threads, backend=backend))
    lit = res.image.max(axis=2) > 0
    acne = int(np.sum((truth == LIT) & ~lit))
    leak = int(np.sum((truth == SHADOW) & lit))
    return CaseResult(case=case, strategy=strategy_name(offset), acne=acne, leak=leak,
                      n_lit=int(np.sum(truth == LIT)), n_shadow=int(np.sum(truth == SHADOW)),
                      n_dontcare=int(np.sum(truth == UNSURE)), shadow_rays=res.stats.shadow_rays,
                      time_shadow=timed.clock[0] + res.stats.time_occluded, truth=truth, lit=lit, image=res.image)


def run_matrix(offset=None, cases=None, *, strategies=None, width=64, height=48, keep_images=False, threads=None,
               progress=False):
    """Run ``cases`` (default :func:`default_matrix`) for one ``offset`` or a list of ``strategies``.

    Returns a list of :class:`CaseResult` (case-major). Each case's scene and truth are built once.
    """
    cases = default_matrix() if cases is None else list(cases)
    strategies = [offset] if strategies is None else list(strategies)
    out = []
    for i, case in enumerate(cases):
        built = build_case(case, width, height)
        truth = truth_labels(built)
        ps = PreparedScene(built.scene, threads=threads)
        try:
            for st in strategies:
                r = run_case(case, st, built=built, prepared=ps, truth=truth)
                if not keep_images:
                    r.truth = r.lit = r.image = None
                out.append(r)
        finally:
            ps.close()
        if progress:
            print(f"\r[{i + 1}/{len(cases)}] {case.id}" + " " * 20, end="", file=sys.stderr, flush=True)
    if progress:
        print(file=sys.stderr)
    return out


def summarize(results):
    """Per strategy: cases, failing cases, acne, leak, labelled pixels, rate and mean us per shadow ray."""
    out = {}
    for r in results:
        s = out.setdefault(r.strategy, {"cases": 0, "failing": 0, "acne": 0, "leak": 0, "pixels": 0,
                                        "time": 0.0, "rays": 0})
        s["cases"] += 1
        s["failing"] += 0 if r.ok else 1
        s["acne"] += r.acne
        s["leak"] += r.leak
        s["pixels"] += r.n_lit + r.n_shadow
        s["time"] += r.time_shadow
        s["rays"] += r.shadow_rays
    for s in out.values():
        s["rate"] = (s["acne"] + s["leak"]) / max(s["pixels"], 1)
        s["us_per_ray"] = 1e6 * s["time"] / max(s["rays"], 1)
    return out


def format_table(results):
    """Text table: one row per case, ``acne/leak`` per strategy, then per-strategy totals and cost."""
    strategies = list(dict.fromkeys(r.strategy for r in results))
    cases = list(dict.fromkeys(r.case for r in results))
    by = {(r.case, r.strategy): r for r in results}
    w = max(9, *(len(s) for s in strategies))
    cw = max(len(c.id) for c in cases)
    lines = [f"{'case':<{cw}} {'care':>5} {'dc%':>5} " + " ".join(f"{s:>{w}}" for s in strategies)]
    for c in cases:
        r0 = by[(c, strategies[0])]
        care = r0.n_lit + r0.n_shadow
        dc = 100.0 * r0.n_dontcare / max(care + r0.n_dontcare, 1)
        cells = []
        for s in strategies:
            r = by[(c, s)]
            cells.append(f"{'.' if r.ok else f'{r.acne}/{r.leak}':>{w}}")
        lines.append(f"{c.id:<{cw}} {care:>5} {dc:>5.1f} " + " ".join(cells))
    summ = summarize(results)
    lines.append("")
    lines.append("cells: '.' = 0 acne and 0 leak pixels, else acne/leak pixel counts; care = labelled pixels, "
                 "dc% = don't-care share of surface pixels")
    lines.append("")
    lines.append(f"{'strategy':<{w}} {'failing':>9} {'acne':>8} {'leak':>8} {'rate %':>8} {'us/shadow ray':>14}")
    for s in strategies:
        v = summ[s]
        lines.append(f"{s:<{w}} {v['failing']:>4}/{v['cases']:<4} {v['acne']:>8} {v['leak']:>8} "
                     f"{100 * v['rate']:>8.3f} {v['us_per_ray']:>14.3f}")
    return "\n".join(lines)
