"""How noisy are surfaces lit by emissive geometry in a preview, with and without emitter light sampling?

Without :meth:`pyrt.Scene.add_emissive_lights` (``pyrt-preview --emissive-lights off``, ``pyrt.render``'s default)
a surface lit by emissive geometry (glTF ``emissiveFactor``, ``KHR_materials_emissive_strength``) receives its
light only through the glossy integrator's BSDF-sampled rays (``glossy_samples`` per hit on the first bounce, only
for lobes with alpha <= ``glossy_threshold``), so walls next to bright emitters are grainy at the previewer's 4 spp
and Lambertian ones get nothing. With it (the previewer's default ``--emissive-lights auto``) every lit hit also
samples the emissive triangles with ``emissive_samples`` shadow rays, MIS-combined with the glossy rays. This tool
renders a model with ``pyrt-preview``'s defaults in several variants, two seeds each, interleaved, and reports for
each variant the median render time and the estimated relMSE of one image from the difference of the two seeds
(``E[(I1 - I2)^2] / 2`` is the variance of one image):

    relMSE_est = mean over pixels and channels of (I1 - I2)^2 / 2 / (((I1 + I2) / 2)^2 + 0.01)

(pyrt.core.metrics' relMSE with the two-seed mean as the reference), over every pixel of the model and over its
non-emissive pixels ("walls": first hit on a material that does not emit), and relMSE x time, the cost of a given
noise level (lower is better). The variants differ in their estimator, so their means differ too (without emitter
sampling Lambertian surfaces miss the emitters' light): compare noise within a row's estimator, cost across rows.
Times are wall-clock seconds of ``render_full`` in this process; read the ratios (the variants are interleaved,
medians over ``--runs``) and the load printed with them.

    python tools/experiments/emissive_noise.py ../shared/khronos-gltf/EmissiveStrengthTest/EmissiveStrengthTest.glb
"""
from __future__ import annotations

import argparse
import os
import statistics
import time

import numpy as np

import pyrt
from pyrt.apps.preview import PreviewOptions, PreviewScene
from pyrt.geometry import offsets
from pyrt.geometry.surface import surface_from_hits

VARIANTS = {        # name -> (spp, glossy_samples, emissive light samples or None: off, triangle selection)
    "off: 4 spp, 4 glossy (before)": (4, 4, None, None),
    "off: 4 spp, 16 glossy": (4, 16, None, None),
    "off: 16 spp, 4 glossy": (16, 4, None, None),
    "emissive 1: 4 spp, 4 glossy": (4, 4, 1, "power"),
    "emissive 2: 4 spp, 4 glossy": (4, 4, 2, "power"),
    "emissive 4: 4 spp, 4 glossy": (4, 4, 4, "power"),
    "emissive 8: 4 spp, 4 glossy": (4, 4, 8, "power"),
    "oriented 1: 4 spp, 4 glossy": (4, 4, 1, "oriented"),
    "oriented 2: 4 spp, 4 glossy": (4, 4, 2, "oriented"),
    "oriented 4: 4 spp, 4 glossy": (4, 4, 4, "oriented"),
}


def render(ps, spp, glossy_samples, seed, emissive_samples=None):
    """One view of the preview scene ``ps`` (its default azimuth) as ``PreviewScene.render_view`` renders it, with
    ``spp``, ``glossy_samples`` and ``emissive_samples`` shadow rays toward the emitters (``ps`` must have its
    emissive light then); returns (image, seconds)."""
    o = ps.options
    ps._set_view(ps.azimuth)
    ps.scene.camera.spp = spp
    if emissive_samples is not None:
        ps.emissive_light.n_samples = emissive_samples
    t0 = time.perf_counter()
    res = pyrt.render_full(ps.scene, seed=seed,
                           integrator=pyrt.Glossy(max_depth=o.max_depth, samples=glossy_samples, transparent_shadows=True,
                                                  light_select_depth=o.light_select_depth),
                           execution=pyrt.Execution(progress=False, prepared=ps.prepared, chunk_samples=o.chunk_samples))
    return res.image, time.perf_counter() - t0


def wall_mask(ps, model):
    """(H, W) bool: the ``model`` pixels whose pixel-centre ray first hits a triangle that emits nothing (one the
    emissive light of ``ps`` does not sample: zero emission at its probe points)."""
    cam = ps.scene.camera
    ys, xs = np.mgrid[0:cam.height, 0:cam.width]
    d = cam.directions(xs.ravel() + 0.5, ys.ravel() + 0.5)
    hits = ps.prepared.accel.intersect(np.broadcast_to(cam.position, d.shape), d)
    lt = ps.emissive_light
    tri = lt.triangle_index(hits.mesh_id, np.maximum(hits.prim_id, 0))
    emitter = (tri >= 0) & (np.take(lt.pmf, np.maximum(tri, 0)) > 0)
    return model & ~emitter.reshape(cam.height, cam.width)


def sample_use(ps, walls, seed=0):
    """Where one emitter sample per wall pixel goes (pixel-centre camera hits): the shares with ``E = 0`` (the
    back of a one-sided emitter, a triangle edge-on), below the receiver's horizon, blocked by a shadow ray, and
    the rest (those that add light): ``(zero, horizon, blocked, useful)``."""
    cam = ps.scene.camera
    ys, xs = np.mgrid[0:cam.height, 0:cam.width]
    d = cam.directions(xs.ravel() + 0.5, ys.ravel() + 0.5)[walls.ravel()]
    o = np.broadcast_to(cam.position, d.shape).copy()
    idx, hits = ps.prepared.accel.intersect_hits(o, d)
    surf = surface_from_hits(ps.prepared.geo, hits, o[idx], d[idx])
    ls = ps.emissive_light.sample_li(surf.p, np.random.default_rng(seed).random((idx.size, 2)))
    lit = ls.irradiance().max(axis=1) > 0
    side = surf.light_side(ls.wi)
    live = np.flatnonzero(lit & side)
    org, tmax = offsets.get_strategy(None).shadow(surf.subset(live), ls.wi[live], ls.dist[live], None)
    blocked = ps.prepared.accel.occluded(org, ls.wi[live], tmax)
    n = max(idx.size, 1)
    return np.mean(~lit), np.mean(lit & ~side), blocked.sum() / n, (live.size - blocked.sum()) / n


def main(argv=None):
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("model")
    ap.add_argument("--runs", type=int, default=1, help="timed repetitions of each variant and seed")
    ap.add_argument("--width", type=int, default=320)
    ap.add_argument("--height", type=int, default=240)
    ap.add_argument("--only", action="append", help="run only the variants whose name contains this (repeatable)")
    args = ap.parse_args(argv)
    size = dict(width=args.width, height=args.height)
    asset = pyrt.load_asset(args.model)
    scenes = {None: PreviewScene(asset, PreviewOptions(emissive_lights="off", **size))}
    for sel in ("power", "oriented"):
        scenes[sel] = PreviewScene(asset, PreviewOptions(emissive_lights="auto", emissive_selection=sel, **size))
    variants = {k: v for k, v in VARIANTS.items() if (v[2] is None or scenes["power"].emissive_light is not None)
                and (not args.only or any(w in k for w in args.only))}
    times = {k: [] for k in variants}
    images = {k: {} for k in variants}
    for _ in range(args.runs):
        for seed in (1, 2):
            for name, (spp, gs, ne, sel) in variants.items():   # interleaved: load drifts hit every variant alike
                img, dt = render(scenes[sel], spp, gs, seed, ne)
                times[name].append(dt)
                images[name][seed] = img
    ps = scenes["power"]
    ps._set_view(ps.azimuth)
    model = ps.model_mask()          # the camera of the view rendered
    walls = wall_mask(ps, model) if ps.emissive_light is not None else model
    print(f"{os.path.basename(args.model)} at {args.width}x{args.height}, {int(model.sum())} model pixels "
          f"({int(walls.sum())} non-emissive), load {os.getloadavg()[0]:.1f}, {os.cpu_count()} cores, "
          f"{args.runs} run(s)")
    print("| variant | median render s | relMSE model px | relMSE walls | walls mean | relMSE walls x s |")
    print("|---|---:|---:|---:|---:|---:|")
    for name in variants:
        row = []
        for mask in (model, walls):
            a, b = (images[name][s][mask].astype(np.float64) for s in (1, 2))
            ref = (a + b) / 2
            row.append(float(np.mean((a - b) ** 2 / 2 / (ref * ref + 0.01))))
        mean_w = float(np.mean((images[name][1][walls] + images[name][2][walls]) / 2))
        t = statistics.median(times[name])
        print(f"| {name} | {t:.2f} | {row[0]:.4g} | {row[1]:.4g} | {mean_w:.4g} | {row[1] * t:.4g} |")
    for sel in ("power", "oriented"):
        if scenes[sel].emissive_light is None:
            continue
        scenes[sel]._set_view(scenes[sel].azimuth)
        zero, horizon, blocked, useful = sample_use(scenes[sel], walls)
        print(f"{sel}: emitter samples at the wall pixels' camera hits: E = 0 (back faces) {zero:.1%}, below the "
              f"horizon {horizon:.1%}, shadowed {blocked:.1%}, adding light {useful:.1%}")
    for p in scenes.values():
        p.close()


if __name__ == "__main__":
    main()
