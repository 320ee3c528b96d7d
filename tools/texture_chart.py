"""Texture filtering: error vs render time on a grazing-angle textured plane (the issue's chart).

A plane seen at a grazing angle, textured with (a) a generated checkerboard image and (b) a photo
that scikit-image ships (``skimage.data.astronaut``, sRGB, linearised on load), lit by the constant
ambient term only, so a pixel's radiance is exactly the filtered texture value. Candidates:

- 1 spp at pixel centres with ``nearest``, ``bilinear``, ``trilinear`` and ``anisotropic`` (EWA)
  lookups, footprints from the camera's ray differentials;
- stratified supersampling with ``bilinear`` lookups at 1, 4, 16 and 64 spp.

Reference: the same view at 256 spp (stratified) with ``bilinear`` lookups. Error = RMS of the
linear radiance difference to the reference over the *interior* plane pixels (the pixel centre and
its 8 neighbours hit the plane), so that the aliased far edge of the plane (geometry, not texture)
does not count. Time = wall-clock ``pyrt.render_full``
with the texture's MIP levels already built (the warm time); the cold time of the first render,
which includes building the levels it reads, is in the CSV.

Writes to ``--out`` (default ``out/``): ``texture_chart.png`` (error vs time, log-log, one panel per
texture), ``texture_chart.csv``, every render as ``texture_<texture>_<method>.png`` and a
side-by-side comparison ``texture_<texture>_side_by_side.png``.

Usage::

    python tools/texture_chart.py                 # 320x180, reference 256 spp (~1-3 min on 2 cores)
    python tools/texture_chart.py --width 160 --height 90 --ref-spp 64   # quick look
"""
from __future__ import annotations

import argparse
import csv
import os
import time

import numpy as np

import pyrt
from _charts import pyplot  # noqa: E402  (tools/_charts.py)

CANDIDATES = [  # (label, filter, spp, jitter)
    ("nearest", "nearest", 1, False),
    ("bilinear", "bilinear", 1, False),
    ("trilinear", "trilinear", 1, False),
    ("anisotropic", "anisotropic", 1, False),
    ("ss1", "bilinear", 1, True),
    ("ss4", "bilinear", 4, True),
    ("ss16", "bilinear", 16, True),
    ("ss64", "bilinear", 64, True),
]


def checker_image(n=256, checks=8):
    """(n, n, 3) float32 checkerboard of ``checks`` x ``checks`` cells, values 0.05 / 0.85 (linear)."""
    yy, xx = np.mgrid[0:n, 0:n]
    odd = ((xx * checks // n) + (yy * checks // n)) % 2
    return np.where(odd[..., None] == 1, 0.85, 0.05).astype(np.float32).repeat(3, axis=2)


def photo_image():
    """``skimage.data.astronaut()``: 512 x 512 RGB uint8, sRGB-encoded (shipped with scikit-image)."""
    from skimage import data

    return data.astronaut()


def make_scene(texture, width, height, spp, jitter):
    """Grazing view of a 40 x 200 plane (y = 0) tiled 8 x 40 times (5 x 5 world units per tile)."""
    cam = pyrt.Camera(position=(0.0, 1.0, 8.0), target=(0.0, 0.0, -30.0), fov=40.0, width=width, height=height,
                      spp=spp, jitter=jitter)
    scene = pyrt.Scene(cam, ambient=(1.0, 1.0, 1.0), background=(0.0, 0.0, 0.0))
    scene.add_plane((0.0, 0.0, -90.0), (40.0, 200.0), pyrt.Lambert(albedo=texture), name="floor")
    return scene


def texture_for(image, filt, srgb):
    return pyrt.ImageTexture(image, filter=filt, scale=(8.0, 40.0), srgb=srgb)


def interior_mask(width, height):
    """Pixels whose centre and 8 neighbours hit the plane (from a pixel-centre depth AOV)."""
    res = pyrt.render_full(make_scene(pyrt.ConstantTexture(0.5), width, height, 1, False),
                           output=pyrt.Output(aovs=True), execution=pyrt.Execution(progress=False))
    hit = np.isfinite(res.aovs["depth"])
    pad = np.pad(hit, 1, constant_values=False)
    ok = np.ones_like(hit)
    for dy in (-1, 0, 1):
        for dx in (-1, 0, 1):
            ok &= pad[1 + dy:1 + dy + height, 1 + dx:1 + dx + width]
    return ok


def render_timed(scene, seed):
    t0 = time.perf_counter()
    res = pyrt.render_full(scene, seed=seed, execution=pyrt.Execution(progress=False))
    return res.image, time.perf_counter() - t0


def run(width, height, ref_spp, out_dir, repeats=2):
    textures = {"checker": (checker_image(), False), "photo": (photo_image(), True)}
    rows = []
    images = {}
    mask = interior_mask(width, height)
    print(f"error measured over {int(mask.sum())} interior plane pixels of {width * height}")
    for tname, (img, srgb) in textures.items():
        ref_scene = make_scene(texture_for(img, "bilinear", srgb), width, height, ref_spp, True)
        ref, t_ref = render_timed(ref_scene, seed=12345)
        images[(tname, "reference")] = ref
        print(f"[{tname}] reference {ref_spp} spp bilinear: {t_ref:.2f} s")
        rows.append(dict(texture=tname, method=f"reference{ref_spp}", filter="bilinear", spp=ref_spp,
                         rmse=0.0, time_warm=t_ref, time_cold=t_ref, mip_levels_built=""))
        for label, filt, spp, jitter in CANDIDATES:
            tex = texture_for(img, filt, srgb)
            scene = make_scene(tex, width, height, spp, jitter)
            out, t_cold = render_timed(scene, seed=1)
            t_warm = min(render_timed(scene, seed=1)[1] for _ in range(repeats))
            rmse = float(np.sqrt(np.mean((out.astype(np.float64) - ref)[mask] ** 2)))
            images[(tname, label)] = out
            rows.append(dict(texture=tname, method=label, filter=filt, spp=spp, rmse=rmse, time_warm=t_warm,
                             time_cold=t_cold, mip_levels_built=" ".join(map(str, tex.mip_levels_built))))
            print(f"[{tname}] {label:12s} {filt:12s} spp={spp:3d}  rmse={rmse:.4f}  "
                  f"time={t_warm:.3f} s (cold {t_cold:.3f} s)  levels={tex.mip_levels_built}")
    os.makedirs(out_dir, exist_ok=True)
    with open(os.path.join(out_dir, "texture_chart.csv"), "w", newline="") as f:
        w = csv.DictWriter(f, fieldnames=list(rows[0]))
        w.writeheader()
        w.writerows(rows)
    for (tname, label), img in images.items():
        pyrt.write_png(os.path.join(out_dir, f"texture_{tname}_{label}.png"), img, tonemap="linear")
    plot_chart(rows, os.path.join(out_dir, "texture_chart.png"), width, height, ref_spp)
    for tname in textures:
        plot_side_by_side(images, rows, tname, os.path.join(out_dir, f"texture_{tname}_side_by_side.png"))
    return rows


def plot_chart(rows, path, width, height, ref_spp):
    plt = pyplot()

    tnames = sorted({r["texture"] for r in rows})
    fig, axes = plt.subplots(1, len(tnames), figsize=(6 * len(tnames), 4.5))
    for ax, tname in zip(np.atleast_1d(axes), tnames):
        rs = [r for r in rows if r["texture"] == tname and not r["method"].startswith("reference")]
        ss = [r for r in rs if r["method"].startswith("ss")]
        ax.plot([r["time_warm"] for r in ss], [r["rmse"] for r in ss], "-o", color="0.5",
                label="supersampling, bilinear (1/4/16/64 spp)")
        for r in rs:
            if r["method"].startswith("ss"):
                ax.annotate(f"{r['spp']} spp", (r["time_warm"], r["rmse"]), textcoords="offset points",
                            xytext=(4, 4), fontsize=8, color="0.35")
        markers = {"nearest": "s", "bilinear": "D", "trilinear": "^", "anisotropic": "*"}
        for r in rs:
            if r["method"] in markers:
                ax.plot(r["time_warm"], r["rmse"], markers[r["method"]], markersize=10 if r["method"] == "anisotropic" else 8,
                        label=f"{r['method']}, 1 spp")
        ax.set_xscale("log")
        ax.set_yscale("log")
        ax.set_xlabel("render time (s, MIP levels built)")
        ax.set_ylabel(f"RMS error vs {ref_spp}-spp bilinear reference (linear)")
        ax.set_title(f"{tname} on a grazing plane ({width}x{height})")
        ax.grid(True, which="both", alpha=0.3)
        ax.legend(fontsize=8)
    fig.tight_layout()
    fig.savefig(path, dpi=110)
    plt.close(fig)


def plot_side_by_side(images, rows, tname, path):
    plt = pyplot()

    order = ["reference", "nearest", "bilinear", "trilinear", "anisotropic", "ss4", "ss16", "ss64"]
    err = {r["method"]: r for r in rows if r["texture"] == tname}
    fig, axes = plt.subplots(2, 4, figsize=(16, 5.2))
    for ax, label in zip(axes.ravel(), order):
        disp = pyrt.tonemap_to_display(images[(tname, label)], tonemap_op="linear")
        from pyrt.shaders.color import srgb_encode

        ax.imshow(srgb_encode(np.clip(disp, 0, 1)))
        r = err.get(label)
        title = label if r is None else f"{label}: rmse {r['rmse']:.4f}, {r['time_warm']:.2f} s"
        if label == "reference":
            ref = next(v for k, v in err.items() if k.startswith("reference"))
            title = f"reference {ref['spp']} spp: {ref['time_warm']:.1f} s"
        ax.set_title(title, fontsize=9)
        ax.axis("off")
    fig.tight_layout()
    fig.savefig(path, dpi=100)
    plt.close(fig)


def main(argv=None):
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("--width", type=int, default=320)
    ap.add_argument("--height", type=int, default=180)
    ap.add_argument("--ref-spp", type=int, default=256)
    ap.add_argument("--repeats", type=int, default=2, help="timed warm renders per candidate (min is kept)")
    ap.add_argument("--out", default="out")
    a = ap.parse_args(argv)
    run(a.width, a.height, a.ref_spp, a.out, a.repeats)


if __name__ == "__main__":
    main()
