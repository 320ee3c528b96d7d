"""Chart of image-based lighting: error vs render time for each strategy at increasing sample counts.

Scene: a Lambertian sphere (albedo 0.8) and a glossy GGX sphere (CookTorrance, gold conductor Fresnel,
roughness 0.35) under a procedural HDR sky (``pyrt.procedural_sky``: gradient + a small bright sun,
256 x 128, generated at run time; ``--write-asset`` also saves it as ``assets/sky.exr``).

For each strategy in ``pyrt.lights.environment.STRATEGIES`` and N = 1, 2, 4, ... samples per hit, the image
is rendered and its relative RMS error against a high-sample MIS reference is measured separately on
the pixels of each sphere; the time is the render's wall time (``stats.time_total``, best of
``--repeats``; the importance table is built before timing, and the preview's one-off SH projection and
prefiltering are timed apart and printed in the title). With a small, very bright sun the relative RMS
error of the glossy sphere is dominated by its ~10 highlight pixels.

Usage::

    python tools/ibl_chart.py [--out out/ibl] [--width 160] [--height 80] [--ref-samples 4096]

Writes ``ibl_chart.png`` (two log-log panels), ``ibl_chart.csv`` and PNGs of the reference and of each
strategy at N = 4.
"""
from __future__ import annotations

import argparse
import csv
import os
import time

import numpy as np

import pyrt
from pyrt.lights import set_environment
from pyrt.lights.environment import STRATEGIES, LatLongEnvironment
from _charts import pyplot  # noqa: E402  (tools/_charts.py)

HERE = os.path.dirname(os.path.abspath(__file__))


def make_sky(width=256, height=128):
    return pyrt.procedural_sky(width, height, sun_direction=(0.5, 0.6, 0.45), sun_angle=3.0,
                               sun_radiance=(3000.0, 2700.0, 2300.0))


def make_scene(env, width, height):
    # no pixel jitter: every render sees the same points, so the error is that of the lighting estimate alone
    cam = pyrt.Camera(position=(0, 0.6, 4.2), target=(0, 0, 0), fov=32, width=width, height=height, jitter=False)
    sc = pyrt.Scene(cam)
    sc.add_sphere((-0.75, 0, 0), 0.6, pyrt.Lambert(albedo=0.8), name="diffuse")
    sc.add_sphere((0.75, 0, 0), 0.6, pyrt.materials.CookTorrance(kd=0.0, ks=1.0, roughness=0.35, metal="gold"),
                  name="glossy")
    return sc


def render(env, width, height, strategy, n, seed=1):
    sc = make_scene(env, width, height)
    set_environment(sc, env, lighting=strategy, n_samples=n)
    r = pyrt.render_full(sc, spp=1, seed=seed, output=pyrt.Output(aovs=True),
                         execution=pyrt.Execution(progress=False))
    return r.image.astype(np.float64), r.stats.time_total, r.aovs


def sphere_masks(aovs, width):
    hit = np.isfinite(aovs["depth"]) & (aovs["depth"] < 1e30)
    xs = np.arange(width)[None, :]
    return {"diffuse": hit & (xs < width // 2), "glossy": hit & (xs >= width // 2)}


def rel_rmse(img, ref, mask):
    d = (img - ref)[mask]
    return float(np.sqrt(np.mean(d ** 2)) / np.mean(ref[mask]))


def run(out, width, height, ref_samples, counts, repeats=3):
    os.makedirs(out, exist_ok=True)
    env = LatLongEnvironment(make_sky())
    _ = env.distribution                 # build the importance table outside the timings
    t0 = time.perf_counter()
    # reference = mean of two independent halves; their difference estimates the reference's own error
    ref_a, t_a, aovs = render(env, width, height, "mis", ref_samples // 2, seed=12345)
    ref_b, t_b, _ = render(env, width, height, "mis", ref_samples // 2, seed=54321)
    ref = 0.5 * (ref_a + ref_b)
    masks = sphere_masks(aovs, width)
    ref_err = {k: rel_rmse(ref_a, ref_b, m) / 2 for k, m in masks.items()}
    print(f"reference: MIS x {ref_samples}, {t_a + t_b:.1f} s, own relative RMS error ~ "
          + ", ".join(f"{k} {v:.4f}" for k, v in ref_err.items()))
    pyrt.write_png(os.path.join(out, "ibl_reference.png"), ref.astype(np.float32), tonemap="reinhard")
    pyrt.write_exr(os.path.join(out, "ibl_reference.exr"), ref.astype(np.float32))
    rows = []
    # the preview's one-off costs, measured on a fresh environment object
    fresh = LatLongEnvironment(make_sky())
    t = time.perf_counter()
    fresh.sh9()
    t_sh = time.perf_counter() - t
    t = time.perf_counter()
    fresh.prefiltered(np.array([[0.0, 1.0, 0.0]]), np.array([0.3]))
    t_pref = time.perf_counter() - t
    print(f"preview setup: SH projection {t_sh * 1e3:.1f} ms, prefiltered maps {t_pref:.2f} s")
    for strategy in STRATEGIES:
        ns = [1] if strategy == "preview" else counts
        for n in ns:
            # the preview renders with `fresh`, whose SH and prefiltered tables were built (and timed) above
            runs = [render(env if strategy != "preview" else fresh, width, height, strategy, n)
                    for _ in range(repeats)]
            img = runs[0][0]
            t = min(r[1] for r in runs)      # best of `repeats` wall times (the machine is shared)
            row = {"strategy": strategy, "n": n, "time_s": t}
            for k, m in masks.items():
                row[f"rel_rmse_{k}"] = rel_rmse(img, ref, m)
            rows.append(row)
            print(f"{strategy:8s} N={n:3d} {t:6.2f} s  diffuse {row['rel_rmse_diffuse']:.4f}  "
                  f"glossy {row['rel_rmse_glossy']:.4f}")
            if n == 4 or strategy == "preview":
                pyrt.write_png(os.path.join(out, f"ibl_{strategy}_N{n}.png"), img.astype(np.float32),
                               tonemap="reinhard")
    with open(os.path.join(out, "ibl_chart.csv"), "w", newline="") as f:
        w = csv.DictWriter(f, fieldnames=list(rows[0]))
        w.writeheader()
        w.writerows(rows)
    plot(rows, os.path.join(out, "ibl_chart.png"), width, height, ref_samples, t_sh, t_pref, ref_err)
    print(f"total {time.perf_counter() - t0:.1f} s; wrote {out}/ibl_chart.png")
    return rows


def plot(rows, path, width, height, ref_samples, t_sh, t_pref, ref_err):
    plt = pyplot()
    fig, axes = plt.subplots(1, 2, figsize=(11, 4.4), sharey=True)
    markers = {"uniform": "o", "cosine": "s", "map": "^", "bsdf": "v", "mis": "D", "preview": "*"}
    for ax, key, title in ((axes[0], "rel_rmse_diffuse", "diffuse sphere (Lambert 0.8)"),
                           (axes[1], "rel_rmse_glossy", "glossy sphere (GGX gold, roughness 0.35)")):
        for s in STRATEGIES:
            rs = [r for r in rows if r["strategy"] == s]
            t = [r["time_s"] for r in rs]
            e = [r[key] for r in rs]
            ax.loglog(t, e, marker=markers[s], ms=10 if s == "preview" else 5, label=s,
                      ls="none" if s == "preview" else "-")
            if s != "preview":
                for r in rs:
                    if r["n"] in (1, 4, 16, 64):
                        ax.annotate(f"{r['n']}", (r["time_s"], r[key]), fontsize=7, xytext=(3, 3),
                                    textcoords="offset points")
        ax.axhline(ref_err[key.replace("rel_rmse_", "")], color="grey", lw=0.8, ls=":")
        ax.set_title(title)
        ax.set_xlabel("render time (s)")
        ax.grid(True, which="both", alpha=0.3)
    axes[0].set_ylabel("relative RMS error vs reference")
    axes[1].legend(title="strategy (labels: samples/hit)", fontsize=8)
    fig.suptitle(f"IBL: error vs time, {width}x{height}, 1 spp (no jitter), reference MIS x {ref_samples} "
                 f"(its own error: dotted); preview setup (SH {t_sh * 1e3:.0f} ms, prefilter {t_pref:.1f} s) "
                 "not included", fontsize=9)
    fig.tight_layout()
    fig.savefig(path, dpi=110)
    plt.close(fig)


def main(argv=None):
    ap = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    ap.add_argument("--out", default="out/ibl")
    ap.add_argument("--width", type=int, default=160)
    ap.add_argument("--height", type=int, default=80)
    ap.add_argument("--ref-samples", type=int, default=4096)
    ap.add_argument("--counts", type=int, nargs="+", default=[1, 2, 4, 8, 16, 32, 64])
    ap.add_argument("--repeats", type=int, default=3, help="timing: best of this many renders")
    ap.add_argument("--write-asset", action="store_true", help="also write assets/sky.exr (the chart's sky)")
    a = ap.parse_args(argv)
    if a.write_asset:
        pyrt.write_exr(os.path.join(os.path.dirname(HERE), "assets", "sky.exr"), make_sky())
    run(a.out, a.width, a.height, a.ref_samples, a.counts, a.repeats)


if __name__ == "__main__":
    main()
