"""Same scene, same seed, same pixels: render a fixed set of scenes and compare against an earlier run.

Used to check that a restructuring changes no output. ``--save DIR`` renders every scene and stores
the float32 images (and AOVs) as ``.npy``; ``--compare DIR`` renders again and reports, per scene,
the maximum absolute difference and the number of differing pixels. Only the public API
(``pyrt.*``) and the two command lines are used, so the same file runs on any version of the code.

Scenes: ``assets/*.toml``; the benchmark scene (``tools/bench.py``, fewer triangles); a texture
scene (checker, image texture with MIP maps and ray differentials, normal map); nested dielectrics
with absorption; area lights; Gouraud/Phong shading; the IBL strategies; projector, goniometric and
IES lights; every registered material on a sphere; AOVs; and the previewer on the sample glTF and a
few Khronos models (when ``../shared/khronos-gltf`` is present).

Usage: python tools/same_pixels.py --save out/pixels_before
       python tools/same_pixels.py --compare out/pixels_before
"""
from __future__ import annotations

import argparse
import os
import subprocess
import sys
import tempfile

import numpy as np
import trimesh

import pyrt

HERE = os.path.dirname(os.path.abspath(__file__))
ROOT = os.path.dirname(HERE)
sys.path.insert(0, HERE)
from bench import bumpy_sphere, make_scene  # noqa: E402

KHRONOS = os.path.join(ROOT, "..", "shared", "khronos-gltf")


def _cam(w=96, h=72, spp=4, pos=(0, 1.2, 3.5), target=(0, 0.5, 0)):
    return pyrt.Camera(position=pos, target=target, up=(0, 1, 0), fov=40, width=w, height=h, spp=spp)


def scene_textures():
    s = pyrt.Scene(_cam(), background=(0.05, 0.05, 0.06))
    img = np.random.default_rng(3).random((64, 64, 3)).astype(np.float32)
    s.add_plane((0, 0, 0), 6.0, pyrt.Lambert(albedo=pyrt.CheckerTexture(0.1, 0.9, scale=16)))
    s.add_sphere((-0.6, 0.5, 0), 0.5, pyrt.Lambert(albedo=pyrt.ImageTexture(img)))
    nm = np.zeros((32, 32, 3), np.float32)
    nm[..., 0] = 0.5 + 0.3 * np.sin(np.arange(32) / 3)[None, :]
    nm[..., 1] = 0.5
    nm[..., 2] = 1.0
    mat = pyrt.BlinnPhong(kd=0.5, ks=0.2, exponent=40)
    mat.normal_map = pyrt.NormalMap(nm)
    s.add_sphere((0.6, 0.5, 0), 0.5, mat)
    s.add_light(pyrt.PointLight((2, 3, 2), intensity=20.0))
    s.add_light(pyrt.DirectionalLight((0.3, -1, -0.2), 1.0))
    return s


def scene_dielectrics():
    s = pyrt.Scene(_cam(), background=(0.2, 0.2, 0.25))
    s.add_plane((0, 0, 0), 6.0, pyrt.Lambert(albedo=pyrt.CheckerTexture(0.2, 0.8, scale=8)))
    s.add_sphere((0, 0.6, 0), 0.6, pyrt.Glass(ior=1.5, priority=1, absorption=(0.5, 0.1, 0.1)))
    s.add_sphere((0, 0.6, 0), 0.3, pyrt.Glass(ior=1.33, priority=2))
    s.add_sphere((1.1, 0.4, 0), 0.4, pyrt.Glass(ior=1.7))
    s.add_light(pyrt.PointLight((2, 3, 2), intensity=30.0))
    return s


def scene_area_lights():
    s = pyrt.Scene(_cam(spp=2))
    s.add_plane((0, 0, 0), 6.0, pyrt.Lambert(albedo=0.6))
    s.add_sphere((0, 0.5, 0), 0.5, pyrt.CookTorrance(metal="gold", roughness=0.3))
    for lt in (pyrt.RectLight((0, 2.5, 0), size=1.0, power=40.0), pyrt.DiskLight((1.5, 2, 1), radius=0.3, power=20.0),
               pyrt.SphereLight((-1.5, 1.5, 1), radius=0.2, power=20.0)):
        s.add_light(lt)
    return s


def scene_shading():
    s = pyrt.Scene(_cam())
    s.add_plane((0, 0, 0), 6.0, pyrt.Lambert(albedo=0.6))
    ico = trimesh.creation.icosphere(subdivisions=1, radius=0.4)
    for x, shading in ((-0.9, "flat"), (0.0, "gouraud"), (0.9, "phong")):
        s.add_mesh(ico, pyrt.BlinnPhong(kd=0.5, ks=0.3, exponent=30),
                   transform=pyrt.transform_matrix(translate=(x, 0.45, 0)), smooth=True, shading=shading)
    s.add_light(pyrt.PointLight((1, 3, 2), intensity=20.0))
    s.add_light(pyrt.SpotLight((-2, 3, 1), target=(0, 0.5, 0), intensity=30, inner_angle=15, outer_angle=30))
    return s


def scene_ibl(strategy):
    s = pyrt.Scene(_cam(spp=2))
    s.add_plane((0, 0, 0), 6.0, pyrt.Lambert(albedo=0.6))
    s.add_sphere((-0.6, 0.5, 0), 0.5, pyrt.Lambert(albedo=0.8))
    s.add_sphere((0.6, 0.5, 0), 0.5, pyrt.CookTorrance(metal="copper", roughness=0.25))
    env = pyrt.LatLongEnvironment(pyrt.procedural_sky(64, 32))
    pyrt.set_environment(s, env, lighting=strategy, n_samples=2)
    return s


def scene_lights():
    s = pyrt.Scene(_cam())
    s.add_plane((0, 0, 0), 6.0, pyrt.Lambert(albedo=0.7))
    s.add_sphere((0, 0.5, 0), 0.5, pyrt.Lambert(albedo=0.5))
    gobo = np.zeros((16, 16, 3), np.float32)
    gobo[::2, :, :] = 1.0
    s.add_light(pyrt.ProjectorLight((2, 3, 1), target=(0, 0, 0), image=gobo, intensity=40.0, outer_angle=30))
    gon = np.linspace(0.2, 1.0, 32 * 16 * 3, dtype=np.float32).reshape(16, 32, 3)
    s.add_light(pyrt.GoniometricLight((-2, 2.5, 1), gon, intensity=10.0))
    s.add_light(pyrt.IESLight((0, 3, -1), os.path.join(ROOT, "assets", "ies", "pyrt_downlight.ies"), scale=0.01))
    return s


def scene_materials():
    names = sorted(pyrt.MATERIALS)
    s = pyrt.Scene(_cam(w=160, h=48, spp=2, pos=(0, 0.6, 6.0), target=(0, 0.4, 0)), background=(0.1, 0.1, 0.12))
    s.add_plane((0, 0, 0), 20.0, pyrt.Lambert(albedo=0.5))
    xs = np.linspace(-3.2, 3.2, len(names))
    for x, nm in zip(xs, names):
        cls = pyrt.MATERIALS[nm]
        try:
            mat = cls()
        except TypeError:
            continue
        s.add_sphere((float(x), 0.3, 0), 0.28, mat)
    s.add_light(pyrt.PointLight((1, 3, 3), intensity=30.0))
    s.add_light(pyrt.DirectionalLight((0.2, -1, -0.5), 1.0))
    return s


def renders():
    """Yield ``(name, image)`` and ``(name + "/aov", array)`` for every scene."""
    for f in sorted(os.listdir(os.path.join(ROOT, "assets"))):
        if f.endswith(".toml"):
            scene, opts = pyrt.load_scene(os.path.join(ROOT, "assets", f))
            scene.camera.width, scene.camera.height = 160, 120
            yield f, pyrt.render(scene, **opts)
    yield "bench", pyrt.render(make_scene(bumpy_sphere(3), 160, 120), seed=0)
    yield "textures", pyrt.render(scene_textures(), seed=1)
    yield "dielectrics", pyrt.render(scene_dielectrics(), seed=2)
    yield "area_lights", pyrt.render(scene_area_lights(), seed=3)
    yield "shading", pyrt.render(scene_shading(), seed=4)
    for st in ("uniform", "cosine", "map", "bsdf", "mis", "preview"):
        yield f"ibl_{st}", pyrt.render(scene_ibl(st), seed=5)
    yield "lights", pyrt.render(scene_lights(), seed=6)
    yield "materials", pyrt.render(scene_materials(), seed=7)
    res = pyrt.render_full(scene_textures(), seed=8, output=pyrt.Output(aovs=True))
    yield "aovs_image", res.image
    for k, v in sorted(res.aovs.items()):
        yield f"aovs_{k}", v
    yield from previews()


def previews():
    models = [os.path.join(ROOT, "assets", "models", m) for m in ("studio_sample.glb", "crate.obj", "blob.ply")]
    for m in ("Duck", "BoxTextured", "NormalTangentTest", "VertexColorTest"):
        d = os.path.join(KHRONOS, m)
        if os.path.isdir(d):
            models += sorted(os.path.join(d, f) for f in os.listdir(d) if f.endswith((".gltf", ".glb")))[:1]
    with tempfile.TemporaryDirectory() as tmp:
        for m in models:
            out = os.path.join(tmp, "p.exr")
            # the previewer's entry point, run with the working copy first on sys.path (a worktree's code)
            cmd = [sys.executable, "-c", "import sys; sys.path.insert(0, sys.argv.pop(1)); "
                   "from pyrt.apps.preview import main; sys.exit(main(sys.argv[1:]))", ROOT, m, "-o", out, "--width", "96", "--height", "72", "--spp", "2", "--quiet"]
            r = subprocess.run(cmd, capture_output=True, text=True)
            if r.returncode != 0:
                print(f"preview {m} failed: {r.stderr.strip()[-300:]}")
                continue
            yield "preview_" + os.path.basename(m), pyrt.read_exr(out)


def main(argv=None):
    ap = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    g = ap.add_mutually_exclusive_group(required=True)
    g.add_argument("--save", metavar="DIR")
    g.add_argument("--compare", metavar="DIR")
    args = ap.parse_args(argv)
    worst = 0.0
    n_bad = 0
    for name, img in renders():
        img = np.asarray(img)
        if args.save:
            os.makedirs(args.save, exist_ok=True)
            np.save(os.path.join(args.save, name + ".npy"), img)
            print(f"{name:32s} {img.shape} saved")
            continue
        path = os.path.join(args.compare, name + ".npy")
        if not os.path.exists(path):
            print(f"{name:32s} no reference")
            n_bad += 1
            continue
        ref = np.load(path)
        if ref.shape != img.shape:
            print(f"{name:32s} shape {img.shape} != {ref.shape}")
            n_bad += 1
            continue
        both_inf = np.isinf(ref) & np.isinf(img) & (np.sign(ref) == np.sign(img))
        a64, r64 = np.where(both_inf, 0.0, img.astype(np.float64)), np.where(both_inf, 0.0, ref.astype(np.float64))
        diff = np.abs(a64 - r64)
        px = diff.reshape(diff.shape[0], diff.shape[1], -1).max(axis=2) if diff.ndim >= 2 else diff
        mx = float(np.nanmax(diff)) if diff.size else 0.0
        worst = max(worst, mx)
        n_px = int((px > 0).sum())
        n_bad += n_px > 0
        print(f"{name:32s} max |diff| {mx:.3g}  differing pixels {n_px} / {px.size}")
    if args.compare:
        print(f"worst max |diff| {worst:.3g}; scenes that differ: {n_bad}")
        return 1 if n_bad else 0
    return 0


if __name__ == "__main__":
    sys.exit(main())
