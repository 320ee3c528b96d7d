"""Asset preview (pyrt.apps.preview): framing, rig + shadow catcher, exposure, outputs, batches, Dask."""
import io
import math
import os
import shutil
import sys
import types

import numpy as np
import pytest
import trimesh
from PIL import Image

import pyrt
from pyrt.apps import preview as P
from pyrt.apps.preview import batch as P_batch, render as P_render
from pyrt.io.assets import load_asset
from pyrt.shaders import color as C

ASSETS = os.path.join(os.path.dirname(__file__), "..", "assets", "models")
BLOB = os.path.join(ASSETS, "blob.ply")
TINY = dict(width=24, height=18, spp=1)


def _project(cam, q):
    """Raster coordinates (x, y) of world points q (N, 3) with pyrt.Camera's convention."""
    v = q - cam.position
    z = v @ cam.forward
    th = cam.tan_half
    sx, sy = (v @ cam.right) / z, (v @ cam.up_ortho) / z
    x = (sx / (th * cam.width / cam.height) + 1) * cam.width / 2
    y = (1 - sy / th) * cam.height / 2
    return x, y, z


def _fibonacci_sphere(n):
    k = np.arange(n) + 0.5
    phi = np.arccos(1 - 2 * k / n)
    th = math.pi * (1 + 5 ** 0.5) * k
    return np.stack([np.cos(th) * np.sin(phi), np.sin(th) * np.sin(phi), np.cos(phi)], axis=1)


@pytest.mark.parametrize("fov,w,h,az,el", [(35, 64, 48, 35, 20), (60, 48, 64, -120, 60), (20, 100, 30, 180, -10),
                                           (90, 50, 50, 0, 0)])
def test_frame_camera_keeps_the_bounding_sphere_in_view(fov, w, h, az, el):
    c, r = np.array([1.0, -2.0, 0.5]), 3.0
    pts = c + r * _fibonacci_sphere(20000)
    cam = P.frame_camera(c, r, fov=fov, azimuth=az, elevation=el, width=w, height=h, margin=1.0)
    x, y, z = _project(cam, pts)
    assert np.all(z > 0)
    assert x.min() >= 0 and x.max() <= w and y.min() >= 0 and y.max() <= h
    # tight: with margin 1 the sphere touches the limiting pair of edges (within the sampling density)
    reach = max(np.abs(x - w / 2).max() / (w / 2), np.abs(y - h / 2).max() / (h / 2))
    assert reach > 0.99
    np.testing.assert_allclose(cam.target, c)


def test_bounding_sphere_encloses_points(rng):
    p = rng.normal(size=(500, 3)) * [1, 5, 0.2]
    c, r = P.bounding_sphere(p)
    assert np.max(np.linalg.norm(p - c, axis=1)) <= r * (1 + 1e-12)


def test_ground_is_matched_to_the_background():
    """With the directional rig and ambient, the unshadowed ground renders exactly the backdrop colour."""
    o = P.PreviewOptions()
    rig = P.studio_rig(30.0, o)
    amb = o.ambient * o.key / math.pi
    bg = P.ground_radiance(rig, 0.5, amb)
    expected = 0.5 / math.pi * sum(L.E * max(0.0, -L.direction[1]) for L in rig) + 0.5 * amb
    np.testing.assert_allclose(bg, expected, rtol=1e-12)
    cam = pyrt.Camera((0, 2, 6), (0, 0, 0), fov=60, width=32, height=24, spp=1, jitter=False)
    scene = pyrt.Scene(cam, background=bg, ambient=np.full(3, amb))
    scene.add_plane((0, 0, 0), 500.0, pyrt.Lambert(0.5))
    for L in rig:
        scene.add_light(L)
    img = pyrt.render(scene)
    np.testing.assert_allclose(img, np.broadcast_to(bg, img.shape), rtol=2e-6)


def test_preview_scene_shadow_catcher_and_exposure():
    ball = load_asset(BLOB)
    ps = P.PreviewScene(ball, P.PreviewOptions(width=64, height=48, spp=1))
    try:
        res = ps.render_view(35.0)
        mask = ps.model_mask()
        bg = ps.scene.background
        rest = res.image[~mask]
        Yb, Yr = C.luminance(bg), C.luminance(rest)
        # most of the ground is indistinguishable from the backdrop, and it catches a shadow
        assert np.median(np.abs(Yr / Yb - 1)) < 1e-5
        assert Yr.min() < 0.7 * Yb
        # exposure: the model's log-average maps to mid grey; at most ~1% of its pixels clip
        disp = ps.to_display(res.image)[mask]
        assert 0.2 < disp.mean() / 255 < 0.8
        assert np.mean(np.any(disp >= 255, axis=1)) < 0.01
        assert np.mean(np.all(disp <= 5, axis=1)) < 0.01
    finally:
        ps.close()


def test_auto_exposure_formula():
    img = np.full((4, 4, 3), 2.0)
    mask = np.zeros((4, 4), bool)
    mask[1:3, 1:3] = True
    img[~mask] = 1000.0                                   # outside the mask: ignored
    ev, white = P.auto_exposure(img, mask)
    assert math.isclose(2.0 ** ev, 0.18 / (1e-4 + 2.0), rel_tol=1e-12)
    assert white == 1.0
    ev0, w0 = P.auto_exposure(np.zeros((2, 2, 3)))
    assert (ev0, w0) == (0.0, None)


def test_up_axis_detection(tmp_path):
    assert P.detect_up_axis(load_asset(os.path.join(ASSETS, "bracket.stl")))[0] == "+z"
    assert P.detect_up_axis(load_asset(os.path.join(ASSETS, "crate.obj")))[0] == "+y"
    assert P.detect_up_axis(load_asset(os.path.join(ASSETS, "studio_sample.glb")))[0] == "+y"
    m = trimesh.load(os.path.join(ASSETS, "bracket.stl"))
    m.apply_transform(trimesh.transformations.rotation_matrix(-math.pi / 2, [1, 0, 0]))   # z-up -> y-up
    p = tmp_path / "bracket_y.ply"
    p.write_bytes(m.export(file_type="ply"))
    assert P.detect_up_axis(load_asset(str(p)))[0] == "+y"
    np.testing.assert_allclose(P.up_transform("+z")[:3, :3], [[1, 0, 0], [0, 0, 1], [0, -1, 0]], atol=1e-12)
    for ax, vec in P.AXES.items():
        np.testing.assert_allclose(P.up_transform(ax)[:3, :3] @ vec, [0, 1, 0], atol=1e-12)
    np.testing.assert_allclose(P.up_transform("-y")[:3, :3] @ [0, -1, 0], [0, 1, 0], atol=1e-12)


def test_up_axis_puts_the_model_on_the_ground():
    ps = P.PreviewScene(load_asset(os.path.join(ASSETS, "bracket.stl")), P.PreviewOptions(**TINY))
    try:
        assert ps.up_axis == "+z"
        v = np.concatenate([ps.scene.meshes[i].vertices for i in ps.model_meshes])
        ext = v.max(axis=0) - v.min(axis=0)
        np.testing.assert_allclose(ext, [1.2, 0.8, 0.8], atol=1e-6)   # 0.8 high after the z -> y turn
        ground = ps.scene.meshes[ps.ground_mesh].vertices[:, 1]
        assert np.all(ground < v[:, 1].min()) and v[:, 1].min() - ground.max() < 1e-3
    finally:
        ps.close()


def _png(data):
    return np.asarray(Image.open(io.BytesIO(data)))


def test_turntable_sequence_and_contact_sheet():
    o = P.PreviewOptions(turntable=3, formats=("png", "exr"), aovs=True, **TINY)
    res = P.render_preview(BLOB, o, name="blob")
    frames = [f"blob_turntable/frame_{k:03d}" for k in range(3)]
    for f in frames:
        assert {f + ".png", f + ".exr", f + "_depth.png", f + "_normal.png", f + "_albedo.png"} <= set(res.files)
    assert res.azimuths == [35.0, 155.0, 275.0]
    sheet = _png(res.files["blob_sheet.png"])
    assert sheet.shape == (2 * 18 + 3 * 4, 2 * 24 + 3 * 4, 3)
    np.testing.assert_array_equal(sheet[4:22, 4:28], _png(res.files[frames[0] + ".png"]))
    assert not np.array_equal(res.images[0], res.images[1])
    # one exposure for every frame
    assert res.exposure is not None


def test_exr_output_has_linear_radiance_and_aovs(tmp_path):
    import OpenEXR

    res = P.render_preview(BLOB, P.PreviewOptions(formats=("exr",), aovs=True, **TINY), name="v")
    P.write_files(res.files, str(tmp_path))
    with OpenEXR.File(str(tmp_path / "v.exr"), separate_channels=True) as f:
        ch = f.channels()
        assert {"R", "G", "B", "Z", "N.X", "albedo.R"} <= set(ch)
        np.testing.assert_array_equal(np.asarray(ch["G"].pixels), res.images[0][..., 1])


def _bad_folder(tmp_path):
    d = tmp_path / "models"
    d.mkdir()
    shutil.copy(BLOB, d / "blob.ply")
    (d / "broken.glb").write_bytes(b"\x00garbage")
    (d / "m.obj").write_text("mtllib m.mtl\nv 0 0 0\nv 1 0 0\nv 0 1 0\nvt 0 0\nusemtl a\nf 1/1 2/1 3/1\n")
    (d / "m.mtl").write_text("newmtl a\nKd 1 1 1\nmap_Kd gone.png\n")
    (d / "notes.txt").write_text("not a model")
    return d


def test_batch_reports_failures_and_goes_on(tmp_path):
    d = _bad_folder(tmp_path)
    out = tmp_path / "out"
    reps = P.preview_batch([str(d)], str(out), P.PreviewOptions(**TINY), progress=False)
    by = {os.path.basename(r.path): r for r in reps}
    assert set(by) == {"blob.ply", "broken.glb", "m.obj"}          # the .txt is not a model
    assert by["blob.ply"].status == "ok" and by["blob.ply"].triangles == 1280
    assert (out / "blob_ply.png").exists()
    assert by["broken.glb"].status == "failed" and "not a GLB file" in by["broken.glb"].error
    # a missing texture is a substitution (Kd alone), listed under the table, not a failure
    assert by["m.obj"].status == "ok" and "map_Kd: texture file not found" in by["m.obj"].substitutions[0]
    table = (out / "summary.txt").read_text()
    assert "2/3 assets ok" in table and "broken.glb" in table
    assert "substitutions (what was replaced" in table and "map_Kd: texture file not found" in table
    rows = (out / "summary.csv").read_text().splitlines()
    assert len(rows) == 4 and rows[0].startswith("asset,status,triangles,load_s,render_s")


def test_batch_glob_and_name_collisions(tmp_path):
    for sub in ("a", "b"):
        (tmp_path / sub).mkdir()
        shutil.copy(os.path.join(ASSETS, "bracket.stl"), tmp_path / sub / "bracket.stl")
    paths = P.collect_inputs([str(tmp_path / "*" / "*.stl")])
    assert len(paths) == 2
    taken = set()
    assert [P.output_name(p, taken) for p in paths] == ["bracket_stl", "bracket_stl_2"]


def test_time_budget(monkeypatch):
    clock = [0.0]
    for module in (P_batch, P_render):                     # preview_asset's and render_preview's clocks
        monkeypatch.setattr(module, "time", types.SimpleNamespace(perf_counter=lambda: clock[0]))
    real = P.PreviewScene.render_view

    def slow_view(self, azimuth, **kw):
        clock[0] += 10.0                                   # every view "takes" 10 s
        return real(self, azimuth, **kw)

    monkeypatch.setattr(P.PreviewScene, "render_view", slow_view)
    o = P.PreviewOptions(turntable=4, time_budget=25.0, **TINY)
    rep = P.preview_asset(BLOB, None, o, return_files=True)
    assert rep.status == "timeout" and "after 2/4 views" in rep.error
    o1 = P.PreviewOptions(turntable=2, time_budget=25.0, **TINY)
    assert P.preview_asset(BLOB, None, o1, return_files=True).status == "ok"


def test_dask_missing_is_a_preview_error_naming_the_extra(monkeypatch, tmp_path, capsys):
    monkeypatch.setitem(sys.modules, "distributed", None)      # makes ``import distributed`` fail
    o = P.PreviewOptions(**TINY)
    with pytest.raises(P.PreviewError, match="the 'preview' extra"):
        P.preview_batch([BLOB], str(tmp_path / "out"), o, dask=True, progress=False)
    assert not (tmp_path / "out").exists()                     # raised before anything is written
    rc = P.main([BLOB, "--out-dir", str(tmp_path / "cli"), "--dask", "--width", "24", "--height", "18", "--quiet"])
    assert rc == 2 and "pip install 'pyrt-embree[preview]'" in capsys.readouterr().err


def _batch_files(out):
    return {os.path.relpath(os.path.join(r, f), out): open(os.path.join(r, f), "rb").read()
            for r, _, fs in os.walk(out) for f in fs if not f.startswith("summary")}


def test_dask_batch_matches_local(tmp_path):
    pytest.importorskip("distributed")
    d = _bad_folder(tmp_path)
    shutil.copy(os.path.join(ASSETS, "bracket.stl"), d / "bracket.stl")
    o = P.PreviewOptions(formats=("png", "exr"), threads=1, **TINY)
    local = P.preview_batch([str(d)], str(tmp_path / "local"), o, progress=False)
    dist = P.preview_batch([str(d)], str(tmp_path / "dask"), o, dask=True, n_workers=2, processes=False,
                           progress=False)
    assert [(r.path, r.status, r.triangles) for r in local] == [(r.path, r.status, r.triangles) for r in dist]
    fl, fd = _batch_files(tmp_path / "local"), _batch_files(tmp_path / "dask")
    assert set(fl) == set(fd) and len(fl) == 6                # blob, bracket, m.obj (its map_Kd replaced): .png + .exr
    for k in fl:
        assert fl[k] == fd[k], k                               # byte-identical files
    # an existing scheduler, given by its address
    from distributed import LocalCluster

    with LocalCluster(n_workers=1, threads_per_worker=1, processes=False, dashboard_address=None) as cluster:
        P.preview_batch([str(d)], str(tmp_path / "addr"), o, dask=cluster.scheduler_address, progress=False)
    assert _batch_files(tmp_path / "addr") == fl


@pytest.mark.slow
def test_dask_batch_with_worker_processes_matches_local(tmp_path):
    pytest.importorskip("distributed")
    d = tmp_path / "m"
    d.mkdir()
    for f in ("blob.ply", "bracket.stl", "crate.obj", "crate.mtl", "crate_wood.png", "studio_sample.glb"):
        shutil.copy(os.path.join(ASSETS, f), d / f)
    o = P.PreviewOptions(threads=1, **TINY)
    P.preview_batch([str(d)], str(tmp_path / "local"), o, progress=False)
    P.preview_batch([str(d)], str(tmp_path / "dask"), o, dask=True, n_workers=2, processes=True, progress=False)
    assert _batch_files(tmp_path / "local") == _batch_files(tmp_path / "dask")


def test_cli_single_and_batch(tmp_path, capsys):
    out = tmp_path / "v.png"
    rc = P.main([BLOB, "-o", str(out), "-o", str(tmp_path / "v.exr"), "--width", "24", "--height", "18",
                 "--spp", "1", "--quiet"])
    assert rc == 0 and out.exists() and (tmp_path / "v.exr").exists()
    assert pyrt.read_exr(str(tmp_path / "v.exr")).shape == (18, 24, 3)
    d = _bad_folder(tmp_path)
    rc = P.main([str(d), "--out-dir", str(tmp_path / "b"), "--width", "24", "--height", "18", "--spp", "1",
                 "--quiet"])
    assert rc == 1                                             # a failing asset -> non-zero exit
    assert "2/3 assets ok" in capsys.readouterr().out              # m.obj renders with its map_Kd replaced
    assert P.main([BLOB, "-o", str(tmp_path / "x.jpg"), "--quiet"]) == 2


def test_options_are_validated():
    with pytest.raises(P.PreviewError, match="fov"):
        P.PreviewOptions(fov=0).validate()
    with pytest.raises(P.PreviewError, match="up must be"):
        P.PreviewOptions(up="y").validate()
    with pytest.raises(P.PreviewError, match="formats"):
        P.PreviewOptions(formats=("jpg",)).validate()
    with pytest.raises(P.PreviewError, match="bvh_quality"):
        P.PreviewOptions(bvh_quality="fast").validate()


def test_bvh_quality_auto_picks_low_for_big_models_and_keeps_the_image(monkeypatch):
    """``bvh_quality="auto"``: Embree's "low" build from BVH_LOW_TRIANGLES triangles on, "medium" below; the BVH
    changes, the closest hits and so the image do not (bitwise)."""
    asset = load_asset(BLOB)
    images = {}
    for threshold, quality, expect in ((10 ** 9, "auto", "medium"), (1, "auto", "low"), (10 ** 9, "high", "high")):
        monkeypatch.setattr(P_render, "BVH_LOW_TRIANGLES", threshold)
        ps = P.PreviewScene(asset, P.PreviewOptions(bvh_quality=quality, width=48, height=36, spp=1))
        try:
            assert ps.prepared.accel.build_quality == expect
            images[expect] = ps.render_view(35.0).image
        finally:
            ps.close()
    assert np.array_equal(images["low"], images["medium"]) and np.array_equal(images["high"], images["medium"])


def test_asset_camera_and_lights():
    o = P.PreviewOptions(camera="asset", lights="asset", **TINY)
    res = P.render_preview(os.path.join(ASSETS, "studio_sample.glb"), o, name="v")
    np.testing.assert_allclose(res.camera.position, [0, 1, 3.2])
    assert math.isclose(res.camera.fov, 40.0)
    assert np.isfinite(res.images[0]).all() and res.images[0].max() > 0


def test_environment_map_option_keeps_the_matched_backdrop(tmp_path):
    """A constant environment (preview strategy: SH irradiance, exact for a constant map) lights the
    ground with rho * L_env, which the backdrop adds to the rig's ground radiance."""
    env = tmp_path / "grey.exr"
    pyrt.write_exr(str(env), np.full((8, 16, 3), 0.5, np.float32))
    o = P.PreviewOptions(environment=str(env), environment_lighting="preview", width=32, height=24, spp=1)
    ps = P.PreviewScene(load_asset(BLOB), o)
    try:
        res = ps.render_view(35.0)
        bg = ps.scene.background
        rig_only = P.ground_radiance(P.studio_rig(35.0, o), o.ground_albedo, ps.ambient_radiance)
        # the SH projection of a coarse 8x16 map of a constant is ~0.8% off pi * L (environment module's
        # quadrature); the backdrop uses exactly what the integrator's preview strategy uses (next check)
        np.testing.assert_allclose(bg, rig_only + o.ground_albedo * 0.5, rtol=1e-2)
        rest = res.image[~ps.model_mask()]
        assert np.median(np.abs(C.luminance(rest) / C.luminance(bg) - 1)) < 1e-4
    finally:
        ps.close()


def test_dielectric_cutoff_only_for_models_with_a_dielectric(monkeypatch):
    """Models with a dielectric render with ``dielectric_cutoff``, Russian roulette below it (``dielectric_roulette``)
    and ``dielectric_depth``, others with pyrt.render's throughput cutoff 1e-4, no roulette and ``max_depth``; the
    options are validated."""
    seen = []

    class Stop(Exception):
        pass

    def fake_render_full(scene, **kw):
        seen.append(kw)
        raise Stop

    monkeypatch.setattr(P_render, "render_full", fake_render_full)
    ps = P.PreviewScene(load_asset(BLOB), P.PreviewOptions(dielectric_cutoff=0.05, **TINY))
    with pytest.raises(Stop):
        ps.render_view(0.0)
    assert (seen[-1]["integrator"].throughput_cutoff, seen[-1]["integrator"].max_depth, seen[-1]["integrator"].roulette) == (1e-4, 4, False)
    monkeypatch.setattr(ps.prepared, "dielectric", np.ones_like(ps.prepared.dielectric, dtype=bool))
    with pytest.raises(Stop):
        ps.render_view(0.0)
    assert (seen[-1]["integrator"].throughput_cutoff, seen[-1]["integrator"].max_depth, seen[-1]["integrator"].roulette) == (0.05, 10, True)
    assert P.PreviewOptions().dielectric_cutoff == 0.01 and P.PreviewOptions().dielectric_roulette is True
    with pytest.raises(P.PreviewError, match="dielectric_roulette must be True or False"):
        P.PreviewOptions(dielectric_roulette="yes").validate()
    for bad in (-0.1, 1.0):
        with pytest.raises(P.PreviewError, match="dielectric_cutoff"):
            P.PreviewOptions(dielectric_cutoff=bad).validate()


def test_adaptive_preview_spends_samples_where_the_image_needs_them(tmp_path, capsys):
    """``target_error`` renders adaptively (base pass ``min_spp``, at most ``max_spp``): edges of the model get more
    samples than the flat background; bad combinations are refused with a one-line CLI error (exit 2). (A target
    the render cannot reach within max_spp, 1e-4 here, ends with every pixel at max_spp: no edge is left.)"""
    from pyrt.io.assets import load_asset
    o = P.PreviewOptions(width=48, height=36, target_error=2.5e-3, max_spp=8, min_spp=2, threads=1, render_budget=None)
    ps = P.PreviewScene(load_asset(BLOB), o)
    try:
        res = ps.render_view(ps.azimuth)
        spp = res.film.weight.reshape(36, 48)
        mask = ps.model_mask()
    finally:
        ps.close()
    assert np.isfinite(res.image).all() and res.stop_reason == "target_error"
    assert spp.min() >= 2 and spp.max() <= 8
    assert spp[mask].mean() > spp[~mask].mean()           # the blob's shading and edges, not the backdrop
    for kw, what in ((dict(target_error=-1.0), "target_error"), (dict(max_spp=2, min_spp=4), "max_spp 2 is below"),
                     (dict(target_error=1e-3, min_spp=3), "min_spp"), (dict(render_budget=0), "render_budget"),
                     (dict(target_error=None, render_budget=None), "needs target_error or render_budget"),
                     (dict(spp=0), "spp must be")):
        with pytest.raises(P.PreviewError, match=what):
            P.PreviewOptions(**kw).validate()
    assert P.main([BLOB, "-o", str(tmp_path / "a.png"), "--max-spp", "2", "--quiet"]) == 2
    assert "pyrt-preview: error: max_spp 2 is below min_spp 4" in capsys.readouterr().err
    rc = P.main([BLOB, "-o", str(tmp_path / "b.png"), "--width", "24", "--height", "18", "--target-error", "1e-2",
                 "--quiet"])
    assert rc == 0 and (tmp_path / "b.png").exists()


@pytest.mark.parametrize("argv", [["x.glb", "--width", "-3"], [], ["x.glb", "--tonemap", "bogus"],
                                  ["x.glb", "--unknown-flag"]])
def test_bad_arguments_give_one_line_errors(argv, capsys):
    """Bad command-line arguments: exit 2 and exactly one line on stderr, ``pyrt-preview: error: ...``."""
    with pytest.raises(SystemExit) as e:
        P.main(argv)
    assert e.value.code == 2
    err = capsys.readouterr().err.strip().splitlines()
    assert len(err) == 1 and err[0].startswith("pyrt-preview: error: "), err
