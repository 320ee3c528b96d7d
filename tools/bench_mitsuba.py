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

import _mitsuba_scenes as ms  # noqa: E402  (tools/_mitsuba_scenes.py)
from bench import replay_batches, replay_seconds  # noqa: E402  (tools/bench.py: Embree alone on recorded rays)
from _mitsuba_report import (curves_of, error_levels, reference_noise, write_chart,  # noqa: E402  (tools/
                             write_table)                                            # _mitsuba_report.py)

LLVM_DEFAULT = "/usr/lib/x86_64-linux-gnu/libLLVM-19.so"
VARIANTS = ("llvm_ad_rgb", "scalar_rgb")
INSTALL = {"mitsuba": "pip install 'pyrt-embree[bench]' (or pip install mitsuba)",
           "llvm_ad_rgb": "apt-get install -y libllvm19 and DRJIT_LIBLLVM_PATH=$(dpkg -L libllvm19 | grep 'libLLVM-19.so$')",
           "scalar_rgb": "pip install mitsuba (scalar_rgb ships with the wheel)"}
MODES = {  # spp levels per series, repeats, reference spp (Mitsuba llvm) and pyrt's own reference spp
    "quick": {"pyrt": [1, 4, 16, 64, 256], "pyrt_numpy": [16, 64], "llvm_ad_rgb": [4, 16, 64, 256],
              "scalar_rgb": [4, 16, 64], "repeats": 2,
              "ref_spp": 2048, "pyrt_ref_spp": 128},
    "full": {"pyrt": [1, 4, 16, 64, 256, 1024], "pyrt_numpy": [16, 64], "llvm_ad_rgb": [4, 16, 64, 256, 1024],
             "scalar_rgb": [4, 16, 64, 256],
             "repeats": 3, "ref_spp": 8192, "pyrt_ref_spp": 512},
}

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
            lines = fh.read().splitlines()
        info["cpu"] = next((ln.split(":", 1)[1].strip() for ln in lines if ln.startswith("model name")), "?")
        flags = set(next((ln.split(":", 1)[1].split() for ln in lines if ln.startswith("flags")), []))
        # the vector ISA: Embree's packet width and the kernel's vector code follow it (tables from machines of
        # different ISAs are not comparable in ns per sample)
        info["cpu"] += " (AVX-512)" if "avx512f" in flags else " (AVX2)" if "avx2" in flags else ""
    except OSError:
        info["cpu"] = "?"
    return info


# ----------------------------------------------------------------------------- the renderers

class PyrtRunner:
    """pyrt on one bench scene: a PreparedScene built once, ``render(spp, seed)`` timed around the call.

    ``backend``: what ``pyrt.render`` is given (``"auto"``: the compiled kernel where it covers the scene; the
    series ``pyrt_numpy`` forces the NumPy path for comparison); :attr:`backends` collects the paths that ran."""

    name = "pyrt"

    def __init__(self, scene, backend="auto", prepared=None):
        self.scene = scene
        self.backend = backend
        self.backends = set()
        t = time.perf_counter()
        self.prepared = pyrt.PreparedScene(scene) if prepared is None else prepared
        self.own = prepared is None
        self.load_s = time.perf_counter() - t

    def render(self, spp, seed):
        """(image, seconds)."""
        t = time.perf_counter()
        res = pyrt.render_full(self.scene, spp=spp, seed=seed,
                               execution=pyrt.Execution(prepared=self.prepared, progress=False, backend=self.backend),
                               **ms.PYRT_OPTIONS)
        s = time.perf_counter() - t
        self.backends.add(res.stats.backend)
        return res.image, s

    def adaptive(self, target_error, seed, max_spp=4096, time_budget=600.0):
        """(image, seconds) of ``pyrt.render(target_error=...)``; TypeError where pyrt has no adaptive render."""
        t = time.perf_counter()
        img = pyrt.render(self.scene, seed=seed,
                          sampling=pyrt.Sampling(target_error=target_error, time_budget=time_budget, max_spp=max_spp),
                          execution=pyrt.Execution(prepared=self.prepared, progress=False), **ms.PYRT_OPTIONS)
        return img, time.perf_counter() - t

    def embree_floor(self, seed, spp=None, target_error=None, repeats=3):
        """Embree alone on the rays of one pyrt render (fixed ``spp``, or adaptive to ``target_error``), recorded
        and replayed through the same binding and thread pool (tools/bench.py): ``(median seconds of ``repeats``
        replays, number of rays)``. No shading, no film, no Python between queries: what the render would cost if
        everything but the ray queries were free."""
        sampling = (pyrt.Sampling(spp=spp) if target_error is None else
                    pyrt.Sampling(target_error=target_error, time_budget=600.0, max_spp=4096))
        res = pyrt.render_full(self.scene, seed=seed, sampling=sampling, output=pyrt.Output(record_rays=True),
                               execution=pyrt.Execution(prepared=self.prepared, progress=False), **ms.PYRT_OPTIONS)
        merged = replay_batches(res.stats.recorded)
        res.stats.recorded = []
        rays = int(sum(o.shape[0] for o, _d, _t in merged.values()))
        return statistics.median(replay_seconds(self.prepared.accel, merged) for _ in range(repeats)), rays

    def close(self):
        """Free the BVH (when this runner built it)."""
        if self.own:
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
    runners["pyrt_numpy"] = PyrtRunner(scene, backend="numpy", prepared=runners["pyrt"].prepared)
    for v in VARIANTS:
        if usable.get(v) is not None:
            continue
        if v == "scalar_rgb" and kind == "whitted":
            res["notes"].append("scalar_rgb skipped: the Python Whitted integrator would run per sample in Python")
            continue
        runners[v] = MitsubaRunner(mi, dr, v, scene, workdir, kind, args.mitsuba_sampler)
    res["load_s"] = {k: r.load_s for k, r in runners.items()}
    # first runs, before anything else renders (llvm: kernel compilation, or a load from drjit's disk cache)
    series = [k for k in ("pyrt", "pyrt_numpy", "llvm_ad_rgb", "scalar_rgb") if k in runners]
    for k in series:      # llvm: every spp (a kernel per wavefront size); pyrt and scalar: the smallest spp
        for spp in (cfg[k] if k == "llvm_ad_rgb" else cfg[k][:1]):
            _img, s = runners[k].render(spp, seed=7)
            res["first_run"][f"{k}@{spp}"] = s
    if "pyrt" in runners:      # the adaptive passes' kernel entry (compiled once, or loaded from pyrt's cache)
        _img, s = runners["pyrt"].adaptive(1.0, seed=7, max_spp=4)
        res["first_run"]["pyrt adaptive"] = s
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
    res["pyrt_backends"] = sorted(runners["pyrt"].backends)      # the paths the "pyrt" series took
    for r in runners.values():
        r.close()
    return res


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
