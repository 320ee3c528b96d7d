"""The previewer's default tone map, decided by measurement on a folder of glTF models (the shared Khronos set).

``python tools/tonemap_choice.py /work/shared/khronos-gltf --picture docs/tonemap_choice.png`` renders every model
once with the previewer's defaults (``--width``/``--height``/``--spp``, small: the measures below do not need more),
keeps the linear image, then shows it with each operator of :data:`OPERATORS`, each with the previewer's exposure rule
(:func:`pyrt.apps.preview.rig.auto_exposure`: the model's log-average to 0.18; Reinhard's white point at its 99.9th
percentile; then :func:`~pyrt.apps.preview.rig.limit_backdrop` for that operator), and prints per operator:

- ``clipped``: the share of the model's pixels with a channel at 255 (detail lost to white), median and worst model;
- ``hue shift``: the mean over the model's pixels of ``|c_d - c_l|_1``, ``c`` the chromaticity ``rgb / (r + g + b)``
  of the display-linear value and of the exposed linear radiance (0: every colour kept; desaturation toward white and
  hue twists count);
- ``mean sRGB``: the model's mean 8-bit value (how bright the picture reads);
- for EmissiveStrengthTest (found by name): the sRGB colours of its five cubes, whose radiance is known from the file
  (``emissiveFactor`` (0.1, 0.5, 0.9) x strength 1, 2, 4, 8, 16), shown at the exposure the rule gives, the smallest
  step between neighbours (Euclidean, 8-bit) and the mean distance to the cubes of Khronos' screenshot (sampled from
  ``screenshot.jpg`` at the cube centres in :data:`SCREENSHOT_CUBES`).

``--picture PNG`` writes a sheet: one row per model of ``--sheet`` (default :data:`SHEET`), one column per operator.
"""
from __future__ import annotations

import argparse
import os

import numpy as np

from pyrt.apps.preview import PreviewOptions, PreviewScene
from pyrt.apps.preview.batch import collect_inputs
from pyrt.apps.preview.rig import auto_exposure, limit_backdrop
from pyrt.core.image_io import encode_png, read_image, tonemap_to_display, write_bytes
from pyrt.io.assets import load_asset
from pyrt.shaders import color as _color

#: the operators compared (pyrt.core.image_io.TONEMAPS)
OPERATORS = ("reinhard", "pbr_neutral", "aces", "film")
#: the radiance of EmissiveStrengthTest's cubes (emissiveFactor x emissiveStrength, from the file)
CUBES = np.array([0.1, 0.5, 0.9]) * np.array([1.0, 2.0, 4.0, 8.0, 16.0])[:, None]
#: (x, y) of the cube centres in EmissiveStrengthTest/screenshot.jpg (1290 x 944)
SCREENSHOT_CUBES = ((205, 415), (445, 395), (670, 375), (885, 355), (1100, 335))
#: the models of the sheet
SHEET = ("EmissiveStrengthTest", "SpecularTest", "VertexColorTest", "Duck", "TransmissionTest", "ClearCoatTest")


def render(path, *, width, height, spp):
    """``(linear image (H, W, 3), model mask (H, W), backdrop RGB)`` of the previewer's default view."""
    o = PreviewOptions(width=width, height=height, spp=spp, exposure=0.0)
    ps = PreviewScene(load_asset(path, max_texture=o.texture_budget()), o)
    try:
        res = ps.render_view(ps.azimuth)
        return res.image, ps.model_mask(), np.asarray(ps.scene.background, dtype=np.float64)
    finally:
        ps.close()


def exposure_for(image, mask, backdrop, op):
    """``(exposure, white)`` by the previewer's rule for the operator ``op``."""
    e, w = auto_exposure(image, mask)
    return limit_backdrop(e, w, backdrop, op)


def show(image, op, exposure, white):
    """Display-linear (H, W, 3) and 8-bit sRGB of ``image`` with ``op``."""
    kw = {"L_white": white} if op == "reinhard" and white is not None else {}
    d = tonemap_to_display(image, tonemap_op=op, exposure=exposure, **kw)
    return d, np.round(_color.srgb_encode(d) * 255).astype(np.uint8)


def measures(image, mask, d, s8, exposure):
    """``(clipped share, hue shift, mean sRGB)`` over the model's pixels."""
    lin = image[mask] * 2.0 ** exposure
    disp = d[mask]
    clipped = float(np.mean(s8[mask].max(axis=1) >= 255))
    ok = (lin.sum(axis=1) > 1e-6) & (disp.sum(axis=1) > 1e-6)
    cl = lin[ok] / lin[ok].sum(axis=1, keepdims=True)
    cd = disp[ok] / disp[ok].sum(axis=1, keepdims=True)
    hue = float(np.abs(cd - cl).sum(axis=1).mean()) if ok.any() else 0.0
    return clipped, hue, float(s8[mask].mean())


def screenshot_cubes(folder):
    """The 8-bit sRGB colours (5, 3) of the cubes in EmissiveStrengthTest's screenshot (median of 16 x 16 texels)."""
    img = np.asarray(read_image(os.path.join(folder, "screenshot.jpg")), dtype=np.float64)[..., :3]
    img = img * 255.0 if img.max() <= 1.0 else img
    return np.array([np.median(img[y - 8:y + 8, x - 8:x + 8].reshape(-1, 3), axis=0) for x, y in SCREENSHOT_CUBES])


def cube_colours(op, exposure, white):
    """8-bit sRGB (5, 3) of :data:`CUBES` shown with ``op`` at ``exposure``."""
    return show(CUBES[None], op, exposure, white)[1][0].astype(np.float64)


def main(argv=None):
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("folder")
    ap.add_argument("--width", type=int, default=240)
    ap.add_argument("--height", type=int, default=180)
    ap.add_argument("--spp", type=int, default=4)
    ap.add_argument("--picture", help="write the sheet here (PNG)")
    ap.add_argument("--sheet", default=",".join(SHEET), help="models of the sheet (comma-separated names)")
    args = ap.parse_args(argv)
    rows = {op: [] for op in OPERATORS}
    tiles = {}
    sheet = args.sheet.split(",")
    for path in collect_inputs([args.folder]):
        name = os.path.basename(os.path.dirname(path)) if "glTF" not in path else path.split(os.sep)[-3]
        image, mask, bg = render(path, width=args.width, height=args.height, spp=args.spp)
        line = [f"{name:26s}"]
        for op in OPERATORS:
            e, w = exposure_for(image, mask, bg, op)
            d, s8 = show(image, op, e, w)
            clip, hue, mean = measures(image, mask, d, s8, e)
            rows[op].append((clip, hue, mean))
            line.append(f"{op} clip {100 * clip:5.2f}% hue {hue:.3f} mean {mean:5.1f} ({e:+.2f} stops)")
            if name in sheet:
                tiles.setdefault(name, []).append(s8)
            if name == "EmissiveStrengthTest":
                cubes = cube_colours(op, e, w)
                step = np.linalg.norm(np.diff(cubes, axis=0), axis=1)
                shot = screenshot_cubes(os.path.dirname(path))
                print(f"EmissiveStrengthTest {op:12s} cubes {cubes.astype(int).tolist()} smallest step "
                      f"{step.min():.1f} mean |d| to the screenshot's {np.abs(cubes - shot).mean():.1f}", flush=True)
        print(" | ".join(line), flush=True)
    for op in OPERATORS:
        a = np.array(rows[op])
        print(f"{op:12s} clipped median {100 * np.median(a[:, 0]):.2f}% worst {100 * a[:, 0].max():.2f}%  hue shift "
              f"mean {a[:, 1].mean():.3f} worst {a[:, 1].max():.3f}  mean sRGB {a[:, 2].mean():.1f}")
    if args.picture and tiles:
        pad = lambda t: np.pad(t, ((2, 2), (2, 2), (0, 0)), constant_values=255)   # noqa: E731
        grid = np.concatenate([np.concatenate([pad(t) for t in tiles[n]], axis=1) for n in sheet if n in tiles])
        write_bytes(args.picture, encode_png(grid))


if __name__ == "__main__":
    main()
