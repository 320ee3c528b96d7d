"""pyrt against Mitsuba 3 at equal error: relMSE against wall time on the same scenes, matched conventions.

Usage::

    python tools/bench_mitsuba.py [--quick] [--scenes diffuse,shadowed,mirror_glass,sky,default] [--repeats 3]
        [--out out/bench_mitsuba] [--chart docs/bench_mitsuba.png] [--table docs/bench_mitsuba.md]
        [--mitsuba-sampler independent]
    python tools/bench_mitsuba.py --plot-only out/bench_mitsuba/bench_mitsuba.json   # chart + table again

What it does, per scene (320x240; builders in tools/_mitsuba_scenes.py): builds the scene in pyrt, translates
it to a Mitsuba 3 scene dict (the same triangles, written as PLY), renders a converged reference with Mitsuba
``llvm_ad_rgb`` (or the best renderer available), then alternates renders at increasing spp of pyrt (fixed
spp), Mitsuba ``llvm_ad_rgb`` and ``scalar_rgb`` (interleaved: one of each per spp per repeat, the order
rotating, a fresh seed every run), timing the render call inside this process (scene loading, BVH builds and
JIT compilation excluded; the first run of each spp, which for llvm compiles the kernel, is reported apart as
"first-run") and measuring relMSE (:func:`pyrt.core.metrics.relmse`, mean((I-R)^2 / (R^2 + 1e-2))) against the
reference. pyrt *adaptive* (``pyrt.render(scene, target_error=E, time_budget=T, max_spp=N, seed=S)``) is one
more series at Mitsuba llvm's errors at 16, 64 and 256 spp; it is skipped with a one-line note while
``pyrt.render`` does not take ``target_error`` (TypeError). The reference match is validated: pyrt's own
high-spp render against Mitsuba's reference, compared with the relMSE the two references' noise alone explains.

Outputs: ``OUT/bench_mitsuba.json`` (every run), the chart (relMSE vs seconds, log-log, one panel per scene;
matplotlib, the ``[charts]`` extra) and a markdown table (time to reach Mitsuba llvm's error at 16/64/256 spp as
a ratio pyrt / Mitsuba, samples per second at equal spp, reference agreement, first-run costs, machine and load).
``--quick``: pyrt at 1/4/16/64 spp (1 spp: its error crossings are measured, not extrapolated), scalar at
4/16/64, llvm up to 256, 2 repeats, a 2048-spp reference (22 minutes for the five scenes on 2 cores shared at
load 11-13, where pyrt's 64-spp times were 4-10x those of issue 13's table for similar scenes); the default adds
256 spp for pyrt and scalar, 1024 for llvm, 3 repeats, an 8192-spp reference and a 512-spp pyrt check (not run
here yet). ``--scenes`` picks scenes, ``--repeats`` overrides.

Installing Mitsuba (never a test dependency): ``pip install 'pyrt-embree[bench]'`` (= ``pip install mitsuba``).
``scalar_rgb`` works as installed. ``llvm_ad_rgb`` needs an LLVM that handles this CPU: with the system's
LLVM 15 it aborts the process ("Cannot select ... fmaximum"); install ``libllvm19`` (Debian:
``apt-get install -y libllvm19``) and point ``DRJIT_LIBLLVM_PATH`` at it (``dpkg -L libllvm19 | grep libLLVM``,
e.g. /usr/lib/x86_64-linux-gnu/libLLVM-19.so; the tool uses that path by itself when the variable is unset and
the file exists). Each variant is probed in a subprocess first (an abort cannot be caught in-process); a missing
Mitsuba or variant is one line on stderr (which one, how to install it) and the tool runs what it can.

Matched conventions (pyrt = Mitsuba 3 here; the translation is :func:`_mitsuba_scenes.mitsuba_dict`):

=================  ==========================================================================================
camera             pinhole, vertical fov (``fov_axis="y"``), same look-at and up; no near/far effects in view
pixels             pixel (row, col) = [col, col+1) x [row, row+1), row 0 at the top; Mitsuba ``box`` rfilter
                   (radius 0.5: each sample counts only in its pixel, weight 1) = pyrt's per-pixel mean
sampling           pyrt: stratified (jittered grid / Latin hypercube); Mitsuba: ``--mitsuba-sampler``
                   (default ``independent``, what its docs and tutorials use); both are unbiased
point light        pyrt ``intensity`` I (W/sr) x ``color`` = Mitsuba ``point`` ``intensity`` (RGB)
spot light         pyrt ``spot_falloff="linear_angle"`` = Mitsuba ``spot`` (linear in angle from ``beam_width`` =
                   inner angle to ``cutoff_angle`` = outer angle; I on the axis)
directional        irradiance E (W/m^2) on a perpendicular surface = Mitsuba ``irradiance``; same ``direction``
Lambert            ``albedo`` = ``diffuse`` ``reflectance``
mirror             ``Mirror(r)`` = ``conductor`` with ``material="none"`` (F = 1) and ``specular_reflectance`` r
glass              ``Glass(ior)`` = ``dielectric`` (``int_ior``, ``ext_ior=1``): exact unpolarised Fresnel, 1/eta^2
                   radiance scaling on refraction in both; pyrt splits reflection + refraction deterministically,
                   Mitsuba picks one with probability R (same expectation)
rough metal        ``CookTorrance(metal=, roughness=r, geometry="smith_separable")`` = ``roughconductor`` GGX with
                   ``alpha`` = r^2 (pyrt's mapping), exact conductor Fresnel with pyrt's RGB eta/k, separable
                   Smith G (Mitsuba's; pyrt's default is height-correlated, so the bench selects separable)
textures           pyrt uv (0, 0) = bottom-left; Mitsuba bitmaps have v = 0 at the top: the PLYs carry 1 - v.
                   Checker: ``CheckerTexture(filtered=False)`` = ``checkerboard`` (to_uv scale / 2, colours
                   swapped for an even v scale); images bilinear without MIP maps on both sides
environment        the same EXR; pyrt's lat-long mapping (u = atan2(x, -z)/2pi, v = acos(y)/pi, row 0 = +y) is
                   Mitsuba's ``envmap`` with the identity ``to_world`` (checked by a one-hot render in
                   tests/test_bench_mitsuba.py); both sample it by luminance, MIS with the BSDF (power heuristic)
integrator         delta-light diffuse scenes and the sky: Mitsuba ``direct`` (1 emitter sample; 1 BSDF sample
                   only with an environment, as pyrt's ``mis`` strategy) = pyrt's Whitted direct light.
                   Mirror/glass scenes: ``whitted_bench``, a small ``mi.SamplingIntegrator`` in
                   tools/_mitsuba_scenes.py (every light sampled at non-delta hits, continue through delta
                   BSDFs, background on misses), which ``llvm_ad_rgb`` JIT-compiles; ``scalar_rgb`` would call it in
                   Python per sample, so scalar is skipped there
max depth          camera ray + 8 specular bounces in both (pyrt ``max_depth=8``, ``throughput_cutoff=0``)
normals            interpolated vertex normals from the same PLY data; pyrt ``shading_normal_fallback=False`` and
                   ``offset="robust_no_terminator"`` (Mitsuba has neither the fallback nor the terminator lift)
colour             RGB rendering (``*_rgb`` variants), linear radiance, float32 films
=================  ==========================================================================================
"""
from __future__ import annotations

import argparse
import json
import os
import platform
import statistics
import subprocess
import sys
import time

import numpy as np

import pyrt
from pyrt.core.metrics import relmse
from pyrt.render.adaptive import render_adaptive

import _mitsuba_scenes as ms  # noqa: E402  (tools/_mitsuba_scenes.py)
from bench import replay_batches, replay_seconds  # noqa: E402  (tools/bench.py: Embree alone on recorded rays)
from _charts import pyplot  # noqa: E402  (tools/_charts.py: matplotlib behind the 'charts' extra)

LLVM_DEFAULT = "/usr/lib/x86_64-linux-gnu/libLLVM-19.so"
VARIANTS = ("llvm_ad_rgb", "scalar_rgb")
INSTALL = {"mitsuba": "pip install 'pyrt-embree[bench]' (or pip install mitsuba)",
           "llvm_ad_rgb": "apt-get install -y libllvm19 and DRJIT_LIBLLVM_PATH=$(dpkg -L libllvm19 | grep 'libLLVM-19.so$')",
           "scalar_rgb": "pip install mitsuba (scalar_rgb ships with the wheel)"}
MODES = {  # spp levels per series, repeats, reference spp (Mitsuba llvm) and pyrt's own reference spp
    "quick": {"pyrt": [1, 4, 16, 64], "llvm_ad_rgb": [4, 16, 64, 256], "scalar_rgb": [4, 16, 64], "repeats": 2,
              "ref_spp": 2048, "pyrt_ref_spp": 128},
    "full": {"pyrt": [1, 4, 16, 64, 256], "llvm_ad_rgb": [4, 16, 64, 256, 1024], "scalar_rgb": [4, 16, 64, 256],
             "repeats": 3, "ref_spp": 8192, "pyrt_ref_spp": 512},
}
AGREE_FACTOR = 2.0                 # converged pyrt vs the reference: relMSE <= this x the noise-only expectation
ERROR_SPP = (16, 64, 256)          # the error levels: Mitsuba llvm's relMSE at these spp

_PROBE = """
import sys, mitsuba as mi
mi.set_variant(sys.argv[1])
s = mi.load_dict({"type": "scene", "integrator": {"type": "direct"}, "sphere": {"type": "sphere"}, "light": {"type": "point", "position": [0, 0, 3]},
                  "sensor": {"type": "perspective", "film": {"type": "hdrfilm", "width": 8, "height": 8}}})
import numpy as np
print(float(np.array(mi.render(s, spp=4)).mean()))
"""


def probe_variants():
    """{variant: None if usable else the reason}; each variant is tried in a subprocess (LLVM may abort)."""
    if "DRJIT_LIBLLVM_PATH" not in os.environ and os.path.exists(LLVM_DEFAULT):
        os.environ["DRJIT_LIBLLVM_PATH"] = LLVM_DEFAULT
    out = {}
    for v in VARIANTS:
        try:
            r = subprocess.run([sys.executable, "-c", _PROBE, v], capture_output=True, text=True, timeout=300)
            ok, why = r.returncode == 0, (r.stderr.strip().splitlines() or [f"exit code {r.returncode}"])[-1]
        except (OSError, subprocess.TimeoutExpired) as exc:
            ok, why = False, str(exc)
        if "No module named 'mitsuba'" in why:
            return {x: "Mitsuba 3 is not installed" for x in VARIANTS}
        out[v] = None if ok else why[:160]
    return out


def machine():
    """Machine, software and load, as noted in the outputs."""
    info = {"platform": platform.platform(), "cpu_count": os.cpu_count(), "python": platform.python_version(),
            "numpy": np.__version__, "pyrt": pyrt.__version__, "load_start": os.getloadavg()}
    try:
        with open("/proc/cpuinfo") as fh:
            info["cpu"] = next((ln.split(":", 1)[1].strip() for ln in fh if ln.startswith("model name")), "?")
    except OSError:
        info["cpu"] = "?"
    return info


# ----------------------------------------------------------------------------- the renderers

class PyrtRunner:
    """pyrt on one bench scene: a PreparedScene built once, ``render(spp, seed)`` timed around the call."""

    name = "pyrt"

    def __init__(self, scene):
        self.scene = scene
        t = time.perf_counter()
        self.prepared = pyrt.PreparedScene(scene)
        self.load_s = time.perf_counter() - t

    def render(self, spp, seed):
        """(image, seconds)."""
        t = time.perf_counter()
        img = pyrt.render(self.scene, spp=spp, seed=seed, prepared=self.prepared, progress=False, **ms.PYRT_OPTIONS)
        return img, time.perf_counter() - t

    def adaptive(self, target_error, seed, max_spp=4096, time_budget=600.0):
        """(image, seconds) of ``pyrt.render(target_error=...)``; TypeError where pyrt has no adaptive render."""
        t = time.perf_counter()
        img = pyrt.render(self.scene, target_error=target_error, time_budget=time_budget, max_spp=max_spp,
                          seed=seed, prepared=self.prepared, progress=False, **ms.PYRT_OPTIONS)
        return img, time.perf_counter() - t

    def embree_floor(self, seed, spp=None, target_error=None, repeats=3):
        """Embree alone on the rays of one pyrt render (fixed ``spp``, or adaptive to ``target_error``), recorded
        and replayed through the same binding and thread pool (tools/bench.py): ``(median seconds of ``repeats``
        replays, number of rays)``. No shading, no film, no Python between queries: what the render would cost if
        everything but the ray queries were free."""
        kw = dict(seed=seed, prepared=self.prepared, progress=False, record_rays=True, **ms.PYRT_OPTIONS)
        if target_error is None:
            res = pyrt.render_full(self.scene, spp=spp, **kw)
        else:
            res = render_adaptive(self.scene, target_error=target_error, time_budget=600.0, max_spp=4096, **kw)
        merged = replay_batches(res.stats.recorded)
        res.stats.recorded = []
        rays = int(sum(o.shape[0] for o, _d, _t in merged.values()))
        return statistics.median(replay_seconds(self.prepared.accel, merged) for _ in range(repeats)), rays

    def close(self):
        """Free the BVH."""
        self.prepared.close()


class MitsubaRunner:
    """One Mitsuba variant on one bench scene (the variant is set before every call: two can alternate)."""

    def __init__(self, mi, dr, variant, scene, workdir, kind, sampler):
        self.mi, self.dr, self.name, self.kind = mi, dr, variant, kind
        mi.set_variant(variant)
        if kind == "whitted":
            ms.register_whitted(mi, dr)
        t = time.perf_counter()
        self.scene = mi.load_dict(ms.mitsuba_dict(mi, scene, workdir, integrator=kind, sampler=sampler))
        self.load_s = time.perf_counter() - t

    def render(self, spp, seed):
        """(image as float64 numpy, seconds): the render call and the transfer of its result."""
        self.mi.set_variant(self.name)
        t = time.perf_counter()
        img = self.mi.render(self.scene, spp=spp, seed=seed)   # Mitsuba >= 3.6 splits large spp into passes
        arr = np.array(img, dtype=np.float64)    # forces the (lazy, llvm) evaluation
        return arr, time.perf_counter() - t

    def close(self):
        """Nothing to free explicitly."""


def reference_image(runner, spp, seed=999_983, chunk=None):
    """A high-spp render (in chunks of ``chunk`` spp with their own seeds for pyrt: bounded memory)."""
    if chunk is None or spp <= chunk:
        return runner.render(spp, seed)
    acc, total = 0.0, 0.0
    for i in range(spp // chunk):
        img, s = runner.render(chunk, seed + i)
        acc, total = acc + np.asarray(img, dtype=np.float64), total + s
    return acc / (spp // chunk), total


# ----------------------------------------------------------------------------- one scene

def bench_scene(name, mode, mi, dr, usable, args, log):
    """Every series of one scene: a dict of runs, reference checks and first-run costs."""
    build, desc, kind = ms.SCENES[name]
    workdir = os.path.join(args.out, name)
    os.makedirs(workdir, exist_ok=True)
    scene = build(workdir)
    cfg = MODES[mode]
    res = {"name": name, "description": desc, "mitsuba_integrator": kind, "runs": [], "notes": [], "first_run": {}}
    runners = {"pyrt": PyrtRunner(scene)}
    for v in VARIANTS:
        if usable.get(v) is not None:
            continue
        if v == "scalar_rgb" and kind == "whitted":
            res["notes"].append("scalar_rgb skipped: the Python Whitted integrator would run per sample in Python")
            continue
        runners[v] = MitsubaRunner(mi, dr, v, scene, workdir, kind, args.mitsuba_sampler)
    res["load_s"] = {k: r.load_s for k, r in runners.items()}
    # first runs, before anything else renders (llvm: kernel compilation, or a load from drjit's disk cache)
    series = [k for k in ("pyrt", "llvm_ad_rgb", "scalar_rgb") if k in runners]
    for k in series:      # llvm: every spp (a kernel per wavefront size); pyrt and scalar: the smallest spp
        for spp in (cfg[k] if k == "llvm_ad_rgb" else cfg[k][:1]):
            _img, s = runners[k].render(spp, seed=7)
            res["first_run"][f"{k}@{spp}"] = s
    # reference: Mitsuba llvm if it runs, else scalar, else pyrt
    ref_by = next(k for k in ("llvm_ad_rgb", "scalar_rgb", "pyrt") if k in runners)
    ref_spp = {"llvm_ad_rgb": cfg["ref_spp"], "scalar_rgb": cfg["ref_spp"] // 8, "pyrt": cfg["pyrt_ref_spp"]}[ref_by]
    ref, ref_s = reference_image(runners[ref_by], ref_spp, chunk=256 if ref_by == "pyrt" else None)
    res["reference"] = {"by": ref_by, "spp": ref_spp, "seconds": ref_s}
    log(f"  {name}: reference {ref_by} {ref_spp} spp in {ref_s:.1f} s")
    np.save(os.path.join(workdir, "reference.npy"), ref.astype(np.float32))
    # interleaved timed runs
    for rep in range(cfg["repeats"] if args.repeats is None else args.repeats):
        levels = sorted({spp for k in series for spp in cfg[k]})
        for spp in levels:
            order = series[rep % len(series):] + series[:rep % len(series)]
            for k in order:
                if spp not in cfg[k]:
                    continue
                seed = 1 + 1000 * rep + spp
                img, s = runners[k].render(spp, seed)
                res["runs"].append({"series": k, "spp": spp, "seconds": s, "relmse": relmse(img, ref), "seed": seed})
        log(f"  {name}: repeat {rep + 1} done (load {os.getloadavg()[0]:.1f})")
    res["ref_noise"] = reference_noise(res["runs"], res["reference"])
    # the Embree floor: Embree alone on the rays of pyrt's renders (what pyrt would take with free shading)
    res["embree_floor"] = {}
    for spp in cfg["pyrt"]:
        s, rays = runners["pyrt"].embree_floor(seed=1 + spp, spp=spp)
        res["embree_floor"][str(spp)] = {"seconds": s, "rays": rays}
    log(f"  {name}: Embree floor " + ", ".join(f"{k} spp {v['seconds']:.3f} s" for k, v in res["embree_floor"].items()))
    # the validation: pyrt's own converged render against the (Mitsuba) reference
    if ref_by != "pyrt":
        own, own_s = reference_image(runners["pyrt"], cfg["pyrt_ref_spp"], chunk=256)
        np.save(os.path.join(workdir, "pyrt_reference.npy"), own.astype(np.float32))
        agree = relmse(own, ref)
        curves = curves_of(res)
        noise = 0.0
        for k, n in (("pyrt", cfg["pyrt_ref_spp"]), (ref_by, ref_spp)):
            spp_max, (_t, e) = max(curves[k].items())
            noise += e * spp_max / n              # relMSE of a mean falls as 1/spp
        res["agreement"] = {"pyrt_spp": cfg["pyrt_ref_spp"], "seconds": own_s, "relmse": agree,
                            "noise_expected": noise}
        log(f"  {name}: pyrt {cfg['pyrt_ref_spp']} spp vs reference relMSE {agree:.3g} "
            f"(noise alone ~{noise:.3g})")
    # pyrt adaptive at Mitsuba llvm's errors
    res["adaptive"] = run_adaptive(runners["pyrt"], res, ref, log)
    for r in runners.values():
        r.close()
    return res


def summarize(runs, ref_noise=0.0):
    """{series: {spp: (median seconds, mean relMSE - ref_noise)}}.

    An image's relMSE against a noisy reference is, in expectation, its own error plus the reference's
    (independent noise, to first order in the relative errors): ``ref_noise`` (:func:`reference_noise`) is
    subtracted, floored at 1 % of the measured value.
    """
    by = {}
    for r in runs:
        by.setdefault(r["series"], {}).setdefault(r["spp"], []).append(r)
    out = {}
    for k, v in by.items():
        out[k] = {}
        for spp, rs in sorted(v.items()):
            e = float(np.mean([x["relmse"] for x in rs]))
            out[k][spp] = (statistics.median(x["seconds"] for x in rs), max(e - ref_noise, 0.01 * e))
    return out


def reference_noise(runs, ref):
    """The reference's own relMSE, estimated from its renderer's measured errors: median of relMSE(n) n / N
    over that series' spp levels n (relMSE of a mean of N independent samples falls as 1/N)."""
    curve = summarize(runs).get(ref["by"], {})
    if not curve:
        return 0.0
    return float(statistics.median(e * n / ref["spp"] for n, (_t, e) in curve.items()))


def curves_of(sc):
    """The scene's series with the reference's noise taken out (:func:`summarize`)."""
    return summarize(sc["runs"], sc.get("ref_noise", 0.0))


def error_levels(curves):
    """The error levels of the table: Mitsuba llvm's (else the first Mitsuba series') relMSE at ERROR_SPP."""
    base = next((k for k in ("llvm_ad_rgb", "scalar_rgb") if k in curves), None)
    if base is None:
        return None, {}
    c = curves[base]
    return base, {spp: c[spp][1] for spp in ERROR_SPP if spp in c}


def run_adaptive(runner, res, ref, log):
    """pyrt's adaptive series at the table's error levels, or a note when pyrt has no adaptive render."""
    _base, levels = error_levels(curves_of(res))
    out = []
    for spp, err in levels.items():
        try:
            img, s = runner.adaptive(err, seed=4242 + spp)
        except TypeError as exc:
            note = f"pyrt adaptive skipped: pyrt.render does not take target_error yet ({exc})"
            res["notes"].append(note)
            log("  " + note)
            return []
        floor_s, rays = runner.embree_floor(seed=4242 + spp, target_error=err)
        out.append({"target": err, "at_llvm_spp": spp, "seconds": s,
                    "relmse": max(relmse(img, ref) - res.get("ref_noise", 0.0), 0.0),
                    "embree_floor_s": floor_s, "embree_floor_rays": rays})
    return out


def time_to_error(curve, err):
    """Seconds a series needs to reach relMSE ``err``: log-log interpolation between its measured points;
    outside them relMSE ~ 1/time from the nearest end (returned with ``extrapolated`` True)."""
    pts = sorted((e, t) for t, e in curve.values())          # by error, ascending
    es, ts = np.log([p[0] for p in pts]), np.log([p[1] for p in pts])
    le = np.log(err)
    if le < es[0]:
        return float(np.exp(ts[0] + (es[0] - le))), True
    if le > es[-1]:
        return float(np.exp(ts[-1] - (le - es[-1]))), True
    order = np.argsort(es)
    return float(np.exp(np.interp(le, es[order], ts[order]))), False


# ----------------------------------------------------------------------------- outputs

def write_table(data, path):
    """The markdown report: time-to-error ratios, samples/s at equal spp, reference checks, first runs."""
    px = ms.WIDTH * ms.HEIGHT
    lines = ["# pyrt against Mitsuba 3", "",
             f"Generated by `python tools/bench_mitsuba.py{' --quick' if data['mode'] == 'quick' else ''}` "
             f"({data['mode']} mode; {ms.WIDTH}x{ms.HEIGHT}; conventions in the tool's docstring). Machine: "
             f"{data['machine']['cpu']}, {data['machine']['cpu_count']} cores, load average "
             f"{data['machine']['load_start'][0]:.1f} at the start and {data['machine']['load_end'][0]:.1f} at the "
             f"end (shared machine: absolute times are noisy; ratios come from interleaved runs). Mitsuba "
             f"{data.get('mitsuba_version', 'n/a')}, sampler `{data['mitsuba_sampler']}`. Times are medians "
             "of the render call inside the process (scene load, BVH build and JIT compilation excluded).", ""]
    missing = [f"- {v} not run: {why}" for v, why in data["variants"].items() if why is not None]
    common = set.intersection(*(set(sc["notes"]) for sc in data["scenes"])) if data["scenes"] else set()
    missing += [f"- {n}" for n in sorted(common)]
    lines += missing + ([""] if missing else [])
    lines += ["relMSE values have the reference's own estimated noise subtracted (an error measured against a "
              "noisy reference is the image's error plus the reference's); the JSON keeps the raw values.", "",
              "## Time to reach Mitsuba llvm's error at 16 / 64 / 256 spp (pyrt time / Mitsuba time)", "",
              "| scene | E@16 | pyrt / llvm | pyrt / scalar | E@64 | pyrt / llvm | pyrt / scalar | E@256 | "
              "pyrt / llvm | pyrt / scalar | pyrt adaptive / llvm (16 / 64 / 256) |",
              "|---|---:|---:|---:|---:|---:|---:|---:|---:|---:|---|"]
    any_extra = False
    for sc in data["scenes"]:
        curves = curves_of(sc)
        _base, levels = error_levels(curves)
        row = [sc["name"]]
        for spp in ERROR_SPP:
            err = levels.get(spp)
            row.append("—" if err is None else f"{err:.2e}")
            for other in ("llvm_ad_rgb", "scalar_rgb"):
                if err is None or other not in curves:
                    row.append("—")
                    continue
                tp, xp = time_to_error(curves["pyrt"], err)
                to, xo = time_to_error(curves[other], err)
                any_extra |= xp or xo
                row.append(f"{tp / to:.2f}{'*' if xp or xo else ''}")
        ad = {a["at_llvm_spp"]: a for a in sc.get("adaptive", [])}
        if ad and "llvm_ad_rgb" in curves:
            row.append(" / ".join(f"{ad[s]['seconds'] / time_to_error(curves['llvm_ad_rgb'], levels[s])[0]:.2f}"
                                  if s in ad else "—" for s in ERROR_SPP))
        else:
            row.append("not run")
        lines.append("| " + " | ".join(row) + " |")
    if any_extra:
        lines += ["", "\\* outside the measured spp range of one series: extrapolated with relMSE ∝ 1/time."]
    lines += ["", "## Per-sample speed at equal spp (64 spp)", "",
              "| scene | pyrt s | llvm s | scalar s | pyrt Msamples/s | llvm Msamples/s | scalar Msamples/s | "
              "pyrt / scalar samples/s | relMSE @64: pyrt | llvm | scalar |",
              "|---|---:|---:|---:|---:|---:|---:|---:|---:|---:|---:|"]
    for sc in data["scenes"]:
        curves = curves_of(sc)
        got = {k: curves[k].get(64) for k in ("pyrt", "llvm_ad_rgb", "scalar_rgb") if k in curves}
        row = [sc["name"]]
        row += [f"{got[k][0]:.2f}" if got.get(k) else "—" for k in ("pyrt", "llvm_ad_rgb", "scalar_rgb")]
        row += [f"{px * 64 / got[k][0] / 1e6:.2f}" if got.get(k) else "—" for k in ("pyrt", "llvm_ad_rgb", "scalar_rgb")]
        row.append(f"{got['scalar_rgb'][0] / got['pyrt'][0]:.2f}" if got.get("scalar_rgb") and got.get("pyrt") else "—")
        row += [f"{got[k][1]:.2e}" if got.get(k) else "—" for k in ("pyrt", "llvm_ad_rgb", "scalar_rgb")]
        lines.append("| " + " | ".join(row) + " |")
    lines += floor_table(data)
    lines += ["", "## Do the renderers agree? (pyrt's converged render against the Mitsuba reference)", "",
              f"Tolerance: the relMSE between the two converged images is at most {AGREE_FACTOR:g}x what their "
              "noise alone explains (each image's relMSE scaled from its measured curve as 1/spp); above it the "
              "renderers compute different images.", "",
              "| scene | reference | pyrt spp | relMSE pyrt vs reference | from the two images' noise alone | "
              "ratio | agree | llvm first run @4 / @64 spp s (JIT compile or drjit's disk cache) | llvm warm @4 / @64 s | scene load s: pyrt (BVH) / llvm / scalar | notes |",
              "|---|---|---:|---:|---:|---:|---|---:|---:|---|---|"]
    for sc in data["scenes"]:
        ag, ref = sc.get("agreement"), sc["reference"]
        curves = curves_of(sc)
        fr = [sc["first_run"].get(f"llvm_ad_rgb@{n}") for n in (4, 64)]
        warm = [curves.get("llvm_ad_rgb", {}).get(n) for n in (4, 64)]
        lines.append(f"| {sc['name']} | {ref['by']} {ref['spp']} spp | {ag['pyrt_spp'] if ag else '—'} | "
                     f"{ag['relmse']:.2e} | {ag['noise_expected']:.2e} | {ag['relmse'] / ag['noise_expected']:.2f} | "
                     f"{'yes' if ag['relmse'] <= AGREE_FACTOR * ag['noise_expected'] else '**no**'} | " if ag else
                     f"| {sc['name']} | {ref['by']} {ref['spp']} spp | — | — | — | — | — | ")
        lines[-1] += " / ".join(f"{x:.2f}" if x else "—" for x in fr) + " | "
        lines[-1] += " / ".join(f"{x[0]:.2f}" if x else "—" for x in warm) + " | "
        lines[-1] += " / ".join(f"{sc['load_s'][k]:.2f}" if k in sc["load_s"] else "—"
                                for k in ("pyrt", "llvm_ad_rgb", "scalar_rgb")) + " | "
        lines[-1] += "; ".join(n for n in sc["notes"] if n not in common) + " |"
    lines += ["", "Scenes: " + "; ".join(f"**{sc['name']}** ({sc['description']}; Mitsuba integrator "
                                         f"`{'whitted_bench' if sc['mitsuba_integrator'] == 'whitted' else 'direct'}`)"
                                         for sc in data["scenes"]) + ".",
              "The default scene as rendered here (in both renderers): " + "; ".join(ms.DEFAULT_SCENE_CHANGES) + ".",
              "", "## How the scenes are matched, and what still differs", "",
              "The scenes are built once in pyrt and translated (tools/_mitsuba_scenes.py): the same triangles "
              "and vertex normals (PLY), the same light units (W/sr, W/m^2), Lambert = `diffuse`, Mirror = "
              "`conductor` (F = 1), Glass = `dielectric`, CookTorrance GGX with alpha = roughness^2, separable "
              "Smith and pyrt's RGB eta/k = `roughconductor`, a vertical fov, the `box` pixel filter, max depth "
              "8; the sky is pyrt's map, resampled to 2H + 1 rows for Mitsuba's envmap (its rows sit at "
              "v = j/(H-1), pyrt's at (j + 1/2)/H). Mitsuba has no Whitted integrator: the delta-light scenes "
              "without specular surfaces and the sky use Mitsuba's `direct` (which computes pyrt's estimator "
              "there), the mirror/glass scenes a small `mi.SamplingIntegrator` (`whitted_bench`) that "
              "`llvm_ad_rgb` JIT-compiles (`scalar_rgb` would run it in Python per sample: not run there).",
              "", "Differences that change the noise, not the expected image: pyrt stratifies pixel samples, "
              "Mitsuba's `independent` sampler does not (`--mitsuba-sampler` picks another); pyrt splits glass "
              "into reflection + refraction, Mitsuba picks one by Fresnel (both sample every light at every hit: "
              "`whitted_bench` loops over the emitters instead of picking one as Mitsuba's own integrators do); "
              "BSDF and environment "
              "importance sampling are each renderer's own (pyrt's `mis` strategy, Mitsuba's visible-normal "
              "GGX sampling and luminance warp). The table above checks the expected images agree: relMSE "
              "between pyrt's converged render and the Mitsuba reference against what their noise alone "
              "explains.", ""]
    with open(path, "w") as fh:
        fh.write("\n".join(lines))


def floor_curve(sc):
    """pyrt's fixed-spp curve with Embree-alone seconds in place of pyrt's: {spp: (floor seconds, relMSE)}."""
    pyrt_curve = curves_of(sc)["pyrt"]
    return {int(k): (v["seconds"], pyrt_curve[int(k)][1]) for k, v in sc.get("embree_floor", {}).items()
            if int(k) in pyrt_curve}


def floor_table(data):
    """Lines of the "Embree floor" section: what pyrt's rays alone cost in Embree, against Mitsuba's times."""
    scenes = [sc for sc in data["scenes"] if sc.get("embree_floor") and "llvm_ad_rgb" in curves_of(sc)]
    if not scenes:
        return []
    px = ms.WIDTH * ms.HEIGHT
    lines = ["", "## The Embree floor: Embree alone on pyrt's own rays", "",
             "pyrt's renders at each spp (and its adaptive renders at each target) are repeated with their rays "
             "recorded; the rays are replayed through the binding alone (`tools/bench.py`'s replay: every query "
             "kind as one batch over both cores, no shading, no film, no Python in between). That is what pyrt "
             "would take if everything but the ray queries were free. Where the floor is above half of "
             "Mitsuba llvm's time, issue 13's \"time to llvm's error <= 0.5x llvm's\" cannot be met by cheaper "
             "shading with these estimators: only fewer rays (better estimators) or faster ray queries than "
             "embreex's could. Where the floor's samples/s are below scalar's, neither can \"samples/s >= "
             "scalar_rgb\" at pyrt's rays per sample.", "",
             "| scene | E@64 | llvm s | pyrt fixed s | floor s | floor / llvm | pyrt adaptive s | floor s | "
             "floor / llvm | rays per sample @64 | floor Msamples/s @64 | scalar Msamples/s | floor / scalar |",
             "|---|---:|---:|---:|---:|---:|---:|---:|---:|---:|---:|---:|---:|"]
    for sc in scenes:
        curves = curves_of(sc)
        _base, levels = error_levels(curves)
        err = levels.get(64)
        if err is None:
            continue
        t_llvm = time_to_error(curves["llvm_ad_rgb"], err)[0]
        t_pyrt = time_to_error(curves["pyrt"], err)[0]
        t_floor = time_to_error(floor_curve(sc), err)[0]
        ad = {a["at_llvm_spp"]: a for a in sc.get("adaptive", [])}.get(64)
        fl64 = sc["embree_floor"].get("64")
        scalar = curves.get("scalar_rgb", {}).get(64)
        row = [sc["name"], f"{err:.2e}", f"{t_llvm:.3f}", f"{t_pyrt:.3f}", f"{t_floor:.3f}", f"{t_floor / t_llvm:.2f}"]
        if ad and "embree_floor_s" in ad:
            row += [f"{ad['seconds']:.3f}", f"{ad['embree_floor_s']:.3f}", f"{ad['embree_floor_s'] / t_llvm:.2f}"]
        else:
            row += ["—"] * 3
        if fl64:
            floor_rate = px * 64 / fl64["seconds"] / 1e6
            row += [f"{fl64['rays'] / (px * 64):.2f}", f"{floor_rate:.2f}"]
            row += [f"{px * 64 / scalar[0] / 1e6:.2f}", f"{floor_rate / (px * 64 / scalar[0] / 1e6):.2f}"] if scalar \
                else ["—", "—"]
        else:
            row += ["—"] * 4
        lines.append("| " + " | ".join(row) + " |")
    lines += ["", "Fixed floor: pyrt's error curve with Embree-alone seconds in place of pyrt's, read at E@64 "
              "(log-log interpolation, as the first table). Adaptive floor: the rays of the adaptive render to E@64."]
    return lines


def write_chart(data, path):
    """relMSE against seconds, log-log, one panel per scene."""
    plt = pyplot()
    n = len(data["scenes"])
    cols = min(3, n)
    rows = (n + cols - 1) // cols
    fig, axes = plt.subplots(rows, cols, figsize=(4.2 * cols, 3.4 * rows), squeeze=False)
    style = {"pyrt": ("C0", "o", "pyrt (fixed spp)"), "llvm_ad_rgb": ("C3", "s", "Mitsuba llvm_ad_rgb"),
             "scalar_rgb": ("C2", "^", "Mitsuba scalar_rgb")}
    for ax, sc in zip(axes.ravel(), data["scenes"]):
        curves = curves_of(sc)
        for k, (col, mk, label) in style.items():
            if k not in curves:
                continue
            spps = list(curves[k])
            t = [curves[k][s][0] for s in spps]
            e = [curves[k][s][1] for s in spps]
            ax.loglog(t, e, marker=mk, color=col, label=label)
            for s, ti, ei in zip(spps, t, e):
                ax.annotate(str(s), (ti, ei), fontsize=6, textcoords="offset points", xytext=(3, 3), color=col)
        ad = sc.get("adaptive") or []
        if ad:
            ax.loglog([a["seconds"] for a in ad], [a["relmse"] for a in ad], marker="*", ls="--", color="C1",
                      label="pyrt adaptive")
        _b, levels = error_levels(curves)
        for err in levels.values():
            ax.axhline(err, color="0.8", lw=0.6, zorder=0)
        ax.set_title(sc["name"], fontsize=9)
        ax.set_xlabel("render seconds (median)", fontsize=8)
        ax.set_ylabel("relMSE", fontsize=8)
        ax.tick_params(labelsize=7)
        ax.grid(True, which="both", lw=0.3, alpha=0.5)
    for ax in axes.ravel()[n:]:
        ax.axis("off")
    axes[0, 0].legend(fontsize=7)
    load = data["machine"]
    fig.suptitle(f"pyrt vs Mitsuba 3 at {ms.WIDTH}x{ms.HEIGHT} ({data['mode']}; {load['cpu_count']} cores, load "
                 f"{load['load_start'][0]:.1f}-{load['load_end'][0]:.1f}); grey lines: llvm's error at 16/64/256 spp",
                 fontsize=9)
    fig.tight_layout()
    fig.savefig(path, dpi=110)
    plt.close(fig)


def main(argv=None):
    """Command line: run the benchmark (or ``--plot-only``) and write the JSON, the chart and the table."""
    ap = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    ap.add_argument("--quick", action="store_true", help="a few-minute run: fewer spp levels, 2 repeats")
    ap.add_argument("--scenes", default=",".join(ms.SCENES), help="comma-separated: " + ", ".join(ms.SCENES))
    ap.add_argument("--repeats", type=int, default=None, help="interleaved repeats (default 2 quick, 3 full)")
    ap.add_argument("--out", default="out/bench_mitsuba")
    ap.add_argument("--chart", default="docs/bench_mitsuba.png")
    ap.add_argument("--table", default="docs/bench_mitsuba.md")
    ap.add_argument("--mitsuba-sampler", default="independent",
                    help="Mitsuba sampler plugin (independent, stratified, multijitter, ldsampler, ...)")
    ap.add_argument("--plot-only", metavar="JSON", help="only redraw the chart and table from a previous run")
    args = ap.parse_args(argv)
    if args.plot_only:
        with open(args.plot_only) as fh:
            data = json.load(fh)
        write_chart(data, args.chart)
        write_table(data, args.table)
        return 0
    names = [s.strip() for s in args.scenes.split(",") if s.strip()]
    bad = [s for s in names if s not in ms.SCENES]
    if bad:
        print(f"bench_mitsuba: error: unknown scene(s) {bad}; known: {list(ms.SCENES)}", file=sys.stderr)
        return 2
    os.makedirs(args.out, exist_ok=True)

    def log(msg):
        print(msg, flush=True)

    data = {"mode": "quick" if args.quick else "full", "machine": machine(), "mitsuba_sampler": args.mitsuba_sampler,
            "variants": probe_variants(), "scenes": []}
    for v, why in data["variants"].items():
        if why is not None:
            print(f"bench_mitsuba: {v} unavailable ({why}); install: {INSTALL[v]}", file=sys.stderr)
    mi = dr = None
    if any(why is None for why in data["variants"].values()):
        import drjit as dr
        import mitsuba as mi
        data["mitsuba_version"], data["drjit_version"] = mi.__version__, dr.__version__
    for name in names:
        log(f"{name} ...")
        data["scenes"].append(bench_scene(name, data["mode"], mi, dr, data["variants"], args, log))
        data["machine"]["load_end"] = os.getloadavg()
        with open(os.path.join(args.out, "bench_mitsuba.json"), "w") as fh:
            json.dump(data, fh, indent=1)
    write_chart(data, args.chart)
    write_table(data, args.table)
    log(f"wrote {args.chart}, {args.table}, {os.path.join(args.out, 'bench_mitsuba.json')}")
    return 0


if __name__ == "__main__":
    sys.exit(main())
