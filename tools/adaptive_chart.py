"""Adaptive against fixed-spp rendering: relMSE against wall time, the calibration of the error estimate, the bias.

Scenes (320 x 240 by default, ``--size`` scales): ``delta`` (checker ground, glass and gold spheres, one point
light: error from pixel integration), ``env`` (the same geometry, Lambert + rough gold under an HDR sky with a
sun: error from light sampling), ``default`` (``assets/default_scene.toml``).

Reference: two independent fixed renders at ``--ref-spp``, averaged; its own relMSE is estimated as
``relmse(R1, R2) / 4`` and subtracted from every measured relMSE (printed). For each scene, interleaved:
fixed renders at several spp and adaptive renders at several ``target_error``; each point is the median time of
``--repeats`` runs (different seeds) and the mean relMSE. The calibration column is true / estimated relMSE of
the adaptive renders (the target: within [0.5, 2]). The bias line compares the relMSE of the mean of the
adaptive renders with what an unbiased estimator would give (mean estimated error / repeats).

Usage: python tools/adaptive_chart.py [--size 0.5] [--repeats 3] [--chart docs/adaptive_chart.png]
"""
from __future__ import annotations

import argparse
import os
import statistics
import time

import numpy as np

import pyrt
from pyrt.core.metrics import relmse


def scene(kind, w, h):
    """One of the benchmark scenes at ``w x h``."""
    if kind == "default":
        s, _ = pyrt.load_scene(os.path.join(os.path.dirname(__file__), "..", "assets", "default_scene.toml"))
        s.camera.width, s.camera.height = w, h
        return s
    cam = pyrt.Camera(position=(0, 1, 4), target=(0, 0.5, 0), fov=40, width=w, height=h)
    s = pyrt.Scene(cam, background=(0.02, 0.02, 0.03))
    s.add_plane((0, 0, 0), 4.0, pyrt.Lambert(albedo=pyrt.CheckerTexture(0.2, 0.8, scale=8, filtered=False)))
    if kind == "delta":
        s.add_sphere((-0.6, 0.5, 0), 0.5, pyrt.Glass(ior=1.5))
        s.add_sphere((0.6, 0.5, 0), 0.5, pyrt.CookTorrance(metal="gold", roughness=0.3))
        s.add_light(pyrt.PointLight((2, 3, 2), intensity=20.0))
    else:
        s.add_sphere((-0.6, 0.5, 0), 0.5, pyrt.Lambert(albedo=(0.7, 0.7, 0.7)))
        s.add_sphere((0.6, 0.5, 0), 0.5, pyrt.CookTorrance(metal="gold", roughness=0.3))
        pyrt.set_environment(s, pyrt.LatLongEnvironment(pyrt.procedural_sky(sun_radiance=(200.0, 180.0, 150.0))))
    return s


def timed(fn):
    t0 = time.perf_counter()
    r = fn()
    return r, time.perf_counter() - t0


def run(kind, w, h, ref_spp, spps, targets, repeats):
    sc = scene(kind, w, h)
    r1 = pyrt.render(sc, spp=ref_spp, seed=10 ** 6)
    r2 = pyrt.render(sc, spp=ref_spp, seed=10 ** 6 + 1)
    ref = (r1.astype(np.float64) + r2) / 2
    e_ref = relmse(r1, r2) / 4
    fixed = {s: ([], []) for s in spps}
    adapt = {t: ([], [], [], [], []) for t in targets}
    for rep in range(repeats):                                # interleaved: every setting once per round
        for s in spps:
            img, dt = timed(lambda: pyrt.render(sc, spp=s, seed=rep))
            fixed[s][0].append(dt)
            fixed[s][1].append(relmse(img, ref) - e_ref)
        for t in targets:
            res, dt = timed(lambda: pyrt.render_full(sc, seed=rep, sampling=pyrt.Sampling(target_error=t)))
            a = adapt[t]
            a[0].append(dt)
            a[1].append(relmse(res.image, ref) - e_ref)
            a[2].append(res.estimated_error)
            a[3].append(res.film.weight.mean())
            a[4].append(res.image.astype(np.float64))
    out = {"kind": kind, "e_ref": e_ref, "fixed": [], "adaptive": []}
    for s, (ts, es) in fixed.items():
        out["fixed"].append((s, statistics.median(ts), float(np.mean(es))))
    for t, (ts, es, est, spp, imgs) in adapt.items():
        bias = relmse(np.mean(imgs, axis=0), ref) - e_ref
        out["adaptive"].append((t, statistics.median(ts), float(np.mean(es)), float(np.mean(est)),
                                float(np.mean(spp)), bias, float(np.mean(est)) / repeats))
    return out


def time_to_error(points, err):
    """Interpolated (log-log) time at which a (time, error) curve reaches ``err``; None outside it."""
    pts = sorted(points)
    for (t0, e0), (t1, e1) in zip(pts, pts[1:]):
        if (e0 - err) * (e1 - err) <= 0 and e0 > 0 and e1 > 0 and e0 != e1:
            f = (np.log(err) - np.log(e0)) / (np.log(e1) - np.log(e0))
            return float(np.exp(np.log(t0) + f * (np.log(t1) - np.log(t0))))
    return None


def main(argv=None):
    ap = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    ap.add_argument("--size", type=float, default=1.0, help="scale of 320 x 240")
    ap.add_argument("--repeats", type=int, default=3)
    ap.add_argument("--ref-spp", type=int, default=4096)
    ap.add_argument("--scenes", default="delta,env,default")
    ap.add_argument("--chart", help="write the chart here (needs the charts extra)")
    a = ap.parse_args(argv)
    w, h = max(8, int(320 * a.size)), max(6, int(240 * a.size))
    settings = {"delta": ([4, 8, 16, 32, 64], [1e-3, 3e-4, 1e-4, 3e-5]),
                "env": ([16, 32, 64, 128, 256], [1e-2, 3e-3, 1e-3, 5e-4]),
                "default": ([4, 8, 16, 32, 64], [1e-3, 3e-4, 1e-4, 5e-5])}
    print(f"machine: {os.cpu_count()} cores, load {os.getloadavg()[0]:.1f}; {w}x{h}, {a.repeats} repeats, "
          f"reference 2 x {a.ref_spp} spp")
    results = []
    for kind in a.scenes.split(","):
        spps, targets = settings[kind]
        r = run(kind, w, h, a.ref_spp, spps, targets, a.repeats)
        results.append(r)
        print(f"\n{kind}: reference relMSE {r['e_ref']:.2g} (subtracted)")
        print("  fixed    spp   time s   relMSE")
        for s, t, e in r["fixed"]:
            print(f"         {s:5d} {t:8.2f} {e:10.3g}")
        print("  adaptive target   time s   relMSE   estimated  true/est  mean spp   bias relMSE (unbiased would be)")
        for tg, t, e, est, spp, bias, ub in r["adaptive"]:
            print(f"         {tg:8.1e} {t:7.2f} {e:10.3g} {est:10.3g} {e / est:8.2f} {spp:9.1f}   {bias:.2g} ({ub:.2g})")
        fx = [(t, e) for _, t, e in r["fixed"]]
        ad = [(t, e) for _, t, e, *_ in r["adaptive"]]
        for tg in r["adaptive"][1:3]:
            err = tg[2]
            tf, ta = time_to_error(fx, err), time_to_error(ad, err)
            if tf and ta:
                print(f"  time to relMSE {err:.2g}: fixed {tf:.2f} s, adaptive {ta:.2f} s: {tf / ta:.2f}x faster")
    if a.chart:
        from _charts import pyplot
        plt = pyplot()
        fig, axes = plt.subplots(1, len(results), figsize=(4.2 * len(results), 3.6))
        for ax, r in zip(np.atleast_1d(axes), results):
            ax.loglog([t for _, t, _ in r["fixed"]], [max(e, 1e-9) for *_, e in r["fixed"]], "o-", label="fixed spp")
            ax.loglog([x[1] for x in r["adaptive"]], [max(x[2], 1e-9) for x in r["adaptive"]], "s-",
                      label="adaptive (true)")
            ax.loglog([x[1] for x in r["adaptive"]], [x[3] for x in r["adaptive"]], "s:", alpha=0.6,
                      label="adaptive (estimated)")
            ax.set_title(r["kind"])
            ax.set_xlabel("wall time (s)")
            ax.set_ylabel("relMSE")
            ax.grid(True, which="both", alpha=0.3)
            ax.legend(fontsize=8)
        fig.tight_layout()
        fig.savefig(a.chart, dpi=110)
        print(f"wrote {a.chart}")


if __name__ == "__main__":
    main()
