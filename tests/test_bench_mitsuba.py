"""tools/bench_mitsuba.py's scenes and convention helpers (tools/_mitsuba_scenes.py).

Runs without Mitsuba; the tests that need it (a one-hot environment render, a pyrt vs Mitsuba image) skip
when ``mitsuba`` is not importable and use the ``scalar_rgb`` variant (``llvm_ad_rgb`` may abort the process
with the system's LLVM, see the tool's docstring).
"""
from __future__ import annotations

import math
import pathlib
import sys

import numpy as np
import pytest

import pyrt
from pyrt.shaders import envmap as K
from pyrt.shaders import microfacet

sys.path.insert(0, str(pathlib.Path(__file__).resolve().parents[1] / "tools"))
import _mitsuba_scenes as ms  # noqa: E402
import _mitsuba_report as rep  # noqa: E402


def _small(scene, w=32, h=24, spp=1):
    c = scene.camera
    scene.camera = pyrt.Camera(position=c.position, target=c.target, up=c.up, fov=c.fov, width=w, height=h, spp=spp)
    return scene


@pytest.mark.parametrize("name", list(ms.SCENES))
def test_bench_scene_builds_a_valid_scene_that_renders(name, tmp_path):
    build, _desc, kind = ms.SCENES[name]
    scene = build(tmp_path)
    scene.validate()
    assert kind in ("direct", "whitted")
    assert scene.camera.width == ms.WIDTH and scene.camera.height == ms.HEIGHT
    img = pyrt.render(_small(scene), seed=0, progress=False, **ms.PYRT_OPTIONS)
    assert img.shape == (24, 32, 3) and np.all(np.isfinite(img)) and img.mean() > 1e-3


def test_default_scene_variant_drops_only_what_mitsuba_cannot_express(tmp_path):
    scene = ms.scene_default(tmp_path)
    assert not any(isinstance(m, pyrt.BlinnPhong) for m in scene.materials)
    assert all(lt.spot_falloff == "linear_angle" for lt in scene.lights if isinstance(lt, pyrt.SpotLight))
    orig, _ = pyrt.load_scene(ms.DEFAULT_SCENE)
    assert len(orig.meshes) == len(scene.meshes) and len(orig.lights) == len(scene.lights)


def test_mitsuba_uv_flips_v_only():
    uv = np.array([[0.0, 0.0], [0.25, 0.1], [1.0, 1.0]])
    np.testing.assert_array_equal(ms.mitsuba_uv(uv), [[0.0, 1.0], [0.25, 0.9], [1.0, 0.0]])


def _mitsuba_checkerboard(uv, color0, color1):
    """Mitsuba 3's checkerboard (src/textures/checkerboard.cpp): color0 where frac(u) > 1/2 equals frac(v) > 1/2."""
    fx, fy = uv[:, 0] - np.floor(uv[:, 0]), uv[:, 1] - np.floor(uv[:, 1])
    return np.where((fx > 0.5) == (fy > 0.5), color0, color1)


@pytest.mark.parametrize("scale", [8, 5, (4, 3), (3, 6)])
def test_checker_translation_gives_pyrt_cells(scale, rng):
    """pyrt's CheckerTexture at uv equals Mitsuba's checkerboard at the flipped, scaled uv (away from edges)."""
    uv = rng.random((4000, 2))
    s = np.broadcast_to(np.asarray(scale, dtype=float), (2,))
    frac = uv * s - np.floor(uv * s)
    uv = uv[np.all((frac > 0.01) & (frac < 0.99), axis=1)]
    pyrt_val = np.where(np.sum(np.floor(uv * s), axis=1) % 2 == 0, 0.0, 1.0)   # color0 = 0 on even cells
    c0, c1 = ms.mitsuba_checker_colors(scale, 0.0, 1.0)
    mi_uv = ms.mitsuba_uv(uv) * np.asarray(ms.mitsuba_checker_scale(scale))
    np.testing.assert_array_equal(_mitsuba_checkerboard(mi_uv, c0, c1), pyrt_val)


def test_checker_translation_refuses_fractional_v_scale():
    with pytest.raises(pyrt.Error, match="integer"):
        ms.mitsuba_checker_colors((2, 2.5), 0.0, 1.0)


def test_alpha_is_roughness_squared_as_in_pyrt():
    for r in (0.0, 0.1, 0.5, 1.0):
        assert ms.alpha_from_roughness(r) == pytest.approx(float(microfacet.roughness_to_alpha(np.array(r))))
    m = ms.mitsuba_bsdf(None, pyrt.CookTorrance(metal="gold", roughness=0.5, geometry="smith_separable"))
    assert m["type"] == "roughconductor" and m["alpha"] == 0.25 and m["distribution"] == "ggx"


def test_material_translation_and_refusals():
    assert ms.mitsuba_bsdf(None, pyrt.Lambert(albedo=(0.1, 0.2, 0.3)))["reflectance"]["value"] == [0.1, 0.2, 0.3]
    mirror = ms.mitsuba_bsdf(None, pyrt.Mirror(0.9))
    assert mirror["type"] == "conductor" and mirror["material"] == "none"
    assert ms.mitsuba_bsdf(None, pyrt.Glass(ior=1.33))["int_ior"] == 1.33
    for bad in (pyrt.BlinnPhong(kd=0.5, ks=0.2, exponent=20), pyrt.CookTorrance(metal="gold", roughness=0.5),
                pyrt.Glass(ior=1.5, tint=0.5)):
        with pytest.raises(pyrt.Error, match=type(bad).__name__):
            ms.mitsuba_bsdf(None, bad)


def test_light_units_translate_unchanged():
    p = ms.mitsuba_emitter(None, pyrt.PointLight((1, 2, 3), power=4 * math.pi * 5.0, color=(1.0, 0.5, 0.25)))
    assert p["type"] == "point" and p["position"] == [1.0, 2.0, 3.0]
    np.testing.assert_allclose(p["intensity"]["value"], [5.0, 2.5, 1.25])     # W/sr = Mitsuba intensity
    d = ms.mitsuba_emitter(None, pyrt.DirectionalLight((0, -1, 0), irradiance=2.0))
    assert d["type"] == "directional" and d["irradiance"]["value"] == [2.0, 2.0, 2.0]
    with pytest.raises(pyrt.Error, match="linear_angle"):
        ms.mitsuba_emitter(None, pyrt.SpotLight((0, 2, 0), (0, -1, 0), intensity=1.0))


def test_latlong_texel_direction_is_pyrt_mapping():
    h, w = 16, 32
    for row, col in [(0, 0), (3, 5), (8, 16), (15, 31), (10, 7)]:
        d = ms.latlong_texel_direction(row, col, h, w)
        u, v = K.latlong_dir_to_uv(d[None])[0]
        assert (int(u * w), int(v * h)) == (col, row)
        env = pyrt.LatLongEnvironment(ms.one_hot_latlong(h, w, row, col), filter="nearest")
        assert env.radiance(d[None])[0, 0] == 100.0


def _mitsuba_envmap_lookup(img, d):
    """NumPy transcription of Mitsuba 3's envmap radiance lookup (src/emitters/envmap.cpp: an extra wrap column,
    u shifted by half a texel, ``uv * (res - 1)``, bilinear), for an (H, W, 3) image and directions (N, 3)."""
    data = np.concatenate([img, img[:, :1]], axis=1).astype(np.float64)
    h, w1 = data.shape[:2]
    u = np.arctan2(d[:, 0], -d[:, 2]) / (2 * np.pi) - 0.5 / (w1 - 1)
    v = np.arccos(np.clip(d[:, 1], -1, 1)) / np.pi
    u, v = u - np.floor(u), v - np.floor(v)
    x, y = u * (w1 - 1), v * (h - 1)
    px, py = np.minimum(x.astype(int), w1 - 2), np.minimum(y.astype(int), h - 2)
    fx, fy = (x - px)[:, None], (y - py)[:, None]
    top = (1 - fx) * data[py, px] + fx * data[py, px + 1]
    bot = (1 - fx) * data[py + 1, px] + fx * data[py + 1, px + 1]
    return (1 - fy) * top + fy * bot


def test_mitsuba_envmap_image_reproduces_pyrt_bilinear_radiance(rng):
    img = rng.random((8, 16, 3)).astype(np.float32)
    d = rng.normal(size=(5000, 3))
    d /= np.linalg.norm(d, axis=1, keepdims=True)
    pyrt_L = K.latlong_lookup(img, d, "bilinear")
    np.testing.assert_allclose(_mitsuba_envmap_lookup(ms.mitsuba_envmap_image(img), d), pyrt_L, rtol=1e-5, atol=1e-6)
    # without the conversion Mitsuba's rows sit elsewhere: the lookups differ
    assert np.max(np.abs(_mitsuba_envmap_lookup(img, d) - pyrt_L)) > 0.1


def _bright_centroid(img):
    """(row, col) centroid of the pixels brighter than half the maximum (the one-hot texel's image)."""
    r, c = np.nonzero(img[..., 0] > 0.5 * img[..., 0].max())
    return r.mean(), c.mean()


def _look_at_texel(h, w, row, col, n=33):
    d = ms.latlong_texel_direction(row, col, h, w)
    up = (0, 1, 0) if abs(d[1]) < 0.9 else (1, 0, 0)
    return d, up, pyrt.Camera(position=(0, 0, 0), target=tuple(d), up=up, fov=10, width=n, height=n, spp=1,
                              jitter=False)


def test_one_hot_environment_seen_at_image_centre_in_pyrt():
    h, w, row, col = 32, 64, 9, 21
    _d, _up, cam = _look_at_texel(h, w, row, col)
    scene = pyrt.Scene(cam)
    scene.add_sphere((50, 50, 50), 0.1, pyrt.Lambert(0.5))      # a mesh far away (a scene needs one)
    pyrt.set_environment(scene, pyrt.LatLongEnvironment(ms.one_hot_latlong(h, w, row, col), filter="nearest"),
                         lighting=None)
    img = pyrt.render(scene, seed=0, progress=False)
    np.testing.assert_allclose(_bright_centroid(img), (16, 16), atol=1.0)   # the texel is centred (+-1 px)


def test_write_ply_round_trip(tmp_path):
    v = np.array([[0, 0, 0], [1, 0, 0], [0, 1, 0.5]], dtype=np.float64)
    n = np.array([[0, 0, 1]] * 3, dtype=np.float64)
    uv = np.array([[0, 0], [1, 0], [0, 1.0]])
    path = ms.write_ply(tmp_path / "t.ply", v, [[0, 1, 2]], n, uv)
    head = ms.ply_header(path)
    assert "element vertex 3" in head and "element face 1" in head and "property float u" in head
    np.testing.assert_array_equal(ms.ply_body(path, 3, 8), np.concatenate([v, n, uv], axis=1).astype(np.float32))


# ----------------------------------------------------------------------------- with Mitsuba (scalar_rgb)

@pytest.fixture
def mi():
    mitsuba = pytest.importorskip("mitsuba")
    mitsuba.set_variant("scalar_rgb")
    return mitsuba


def test_one_hot_environment_seen_at_image_centre_in_mitsuba(mi, tmp_path):
    """Mitsuba's envmap with the identity to_world maps texels where pyrt's lat-long map does."""
    h, w, row, col = 32, 64, 9, 21
    d, up, cam = _look_at_texel(h, w, row, col)
    path = str(tmp_path / "hot.exr")
    pyrt.write_exr(path, ms.mitsuba_envmap_image(ms.one_hot_latlong(h, w, row, col)))
    scene = mi.load_dict({
        "type": "scene", "integrator": {"type": "direct"},
        "env": {"type": "envmap", "filename": path},
        "sensor": {"type": "perspective", "fov_axis": "y", "fov": 10.0,
                   "to_world": mi.ScalarTransform4f().look_at(origin=[0, 0, 0], target=[float(x) for x in d],
                                                              up=[float(x) for x in up]),
                   "film": {"type": "hdrfilm", "width": 33, "height": 33, "rfilter": {"type": "box"}}}})
    img = np.array(mi.render(scene, spp=4))
    np.testing.assert_allclose(_bright_centroid(img), (16, 16), atol=1.0)   # the texel is centred (+-1 px)


def test_pyrt_and_mitsuba_agree_on_the_diffuse_scene(mi, tmp_path):
    """Per image quadrant and channel, the mean difference pyrt - Mitsuba is zero within 4 standard errors
    (the per-pixel differences are independent; a mirrored camera, wrong units or a wrong falloff fail)."""
    scene = _small(ms.scene_diffuse(tmp_path), 64, 48)
    a = pyrt.render(scene, spp=16, seed=3, progress=False, **ms.PYRT_OPTIONS).astype(np.float64)
    m = mi.load_dict(ms.mitsuba_dict(mi, scene, tmp_path, integrator="direct", spp=64))
    b = np.array(mi.render(m, spp=64, seed=3), dtype=np.float64)
    assert abs(a.mean() / b.mean() - 1) < 0.02
    dif = a - b
    for qy in (slice(0, 24), slice(24, 48)):
        for qx in (slice(0, 32), slice(32, 64)):
            q = dif[qy, qx].reshape(-1, 3)
            z = q.mean(axis=0) / (q.std(axis=0, ddof=1) / math.sqrt(q.shape[0]))
            assert np.all(np.abs(z) < 4), (qy, qx, z)


def test_whitted_bench_integrator_matches_pyrt_on_mirror_and_glass(mi, tmp_path):
    """The Mitsuba Whitted integrator (run per sample in scalar_rgb: a tiny image) gives pyrt's image: the mean
    difference per channel is zero within 4 standard errors of the per-pixel differences."""
    import drjit as dr
    ms.register_whitted(mi, dr)
    scene = _small(ms.scene_mirror_glass(tmp_path), 24, 18)
    a = pyrt.render(scene, spp=16, seed=5, progress=False, **ms.PYRT_OPTIONS).astype(np.float64)
    m = mi.load_dict(ms.mitsuba_dict(mi, scene, tmp_path, integrator="whitted", spp=16))
    b = np.array(mi.render(m, spp=16, seed=5), dtype=np.float64)
    q = (a - b).reshape(-1, 3)
    z = q.mean(axis=0) / (q.std(axis=0, ddof=1) / math.sqrt(q.shape[0]))
    assert np.all(np.abs(z) < 4), z
    assert abs(a.mean() / b.mean() - 1) < 0.03


# ----------------------------------------------------------------------------- the tool's bookkeeping

def test_time_to_error_interpolates_log_log_and_marks_extrapolation():
    curve = {4: (1.0, 1e-2), 16: (4.0, 2.5e-3), 64: (16.0, 6.25e-4)}       # relMSE ~ 1/time
    t, extra = rep.time_to_error(curve, 1.25e-3)
    assert t == pytest.approx(8.0) and not extra
    t, extra = rep.time_to_error(curve, 1e-4)                                  # below the range: 1/time
    assert t == pytest.approx(100.0) and extra
    t, extra = rep.time_to_error(curve, 1e-1)
    assert t == pytest.approx(0.1) and extra


def test_reference_noise_is_subtracted_from_the_curves():
    runs = [{"series": "llvm_ad_rgb", "spp": n, "seconds": 0.1 * n, "relmse": 1e-2 / n} for n in (4, 16, 64)]
    noise = rep.reference_noise(runs, {"by": "llvm_ad_rgb", "spp": 1024})
    assert noise == pytest.approx(1e-2 / 1024)
    c = rep.summarize(runs, noise)["llvm_ad_rgb"]
    assert c[64][1] == pytest.approx(1e-2 / 64 - 1e-2 / 1024) and c[16][0] == pytest.approx(1.6)


def test_adaptive_series_is_skipped_with_a_note_when_render_has_no_target_error():
    import bench_mitsuba as bm

    class NoAdaptive:
        def adaptive(self, target_error, seed):
            raise TypeError("render_full() got an unexpected keyword argument 'target_error'")

    res = {"runs": [{"series": "llvm_ad_rgb", "spp": n, "seconds": 1.0, "relmse": 1e-3} for n in (16, 64)],
           "notes": []}
    assert bm.run_adaptive(NoAdaptive(), res, np.zeros((2, 2, 3)), lambda msg: None) == []
    assert any("target_error" in n for n in res["notes"])


def test_bench_cpu_counts_work_not_waiting():
    """tools/bench_cpu.py's premise: the process's CPU time counts a computation and not a wait (a sleep, or a
    thread waiting for a core on a loaded machine)."""
    import time

    import bench_cpu

    _, waited = bench_cpu.cpu_seconds(lambda: time.sleep(0.2))
    x = np.random.default_rng(0).random((400, 400))
    _, worked = bench_cpu.cpu_seconds(lambda: [x @ x for _ in range(20)])
    assert waited < 0.05 < worked
