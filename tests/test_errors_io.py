"""Bad input gets clear errors; outputs are written and read back; the CLI works (import rules: test_architecture.py)."""
import importlib
import math
import pathlib
import subprocess
import sys
import warnings

import numpy as np
import pytest
import trimesh

import pyrt

ROOT = pathlib.Path(__file__).resolve().parents[1]


def test_non_finite_vertices_rejected_with_mesh_name():
    s = pyrt.Scene()
    v = np.array([[0, 0, 0], [1, 0, 0], [0, np.nan, 0]], dtype=float)
    with pytest.raises(pyrt.GeometryError, match=r"'bad'.*not finite"):
        s.add_mesh((v, [[0, 1, 2]]), pyrt.Lambert(), name="bad")


def test_degenerate_triangles_skipped_with_warning():
    s = pyrt.Scene()
    v = np.array([[0, 0, 0], [1, 0, 0], [0, 1, 0], [2, 0, 0]], dtype=float)
    with pytest.warns(UserWarning, match="skipping 2 degenerate"):
        s.add_mesh((v, [[0, 1, 2], [0, 1, 3], [1, 1, 2]]), pyrt.Lambert(), name="tri", smooth=False)
    assert s.meshes[0].faces.shape[0] == 1
    with pytest.raises(pyrt.GeometryError, match="all 1 triangles are degenerate"):
        s.add_mesh((v, [[0, 1, 3]]), pyrt.Lambert(), name="flat")


def test_bad_indices_rejected():
    with pytest.raises(pyrt.GeometryError, match="out of range"):
        pyrt.Scene().add_mesh((np.eye(3), [[0, 1, 5]]), pyrt.Lambert(), name="x")


@pytest.mark.parametrize("make, match", [
    (lambda: pyrt.DirectionalLight((0, 0, 0), 1.0), "zero-length direction"),
    (lambda: pyrt.SpotLight((0, 1, 0), (0, 0, 0), intensity=1.0), "zero-length direction"),
    (lambda: pyrt.PointLight((0, 1, 0), intensity=-1.0), "intensity must be >= 0"),
    (lambda: pyrt.PointLight((0, 1, 0)), "exactly one of intensity"),
    (lambda: pyrt.PointLight((0, math.nan, 0), intensity=1.0), "position must be 3 finite"),
    (lambda: pyrt.SpotLight((0, 1, 0), (0, -1, 0), intensity=1.0, inner_angle=40, outer_angle=20), "inner_angle"),
    (lambda: pyrt.Glass(ior=0.0), "ior must be > 0"),
    (lambda: pyrt.Glass(ior=-1.5), "ior must be > 0"),
    (lambda: pyrt.Lambert(albedo=1.5), r"albedo must be in \[0.0, 1.0\]"),
    (lambda: pyrt.Lambert(albedo=(1, 2)), "RGB triple"),
    (lambda: pyrt.BlinnPhong(kd=0.8, ks=0.5), "kd \\+ ks"),
    (lambda: pyrt.Camera(position=(0, 0, 0), target=(0, 0, 0)), "zero-length view direction"),
    (lambda: pyrt.Camera(up=(0, 0, 1), position=(0, 0, 5), target=(0, 0, 0)), "parallel"),
    (lambda: pyrt.Camera(fov=180), "fov"),
    (lambda: pyrt.Camera(width=0), "width"),
])
def test_invalid_parameters_raise_clear_errors(make, match):
    with pytest.raises(ValueError, match=match):
        make()


def test_unknown_material_parameter_rejected():
    with pytest.raises(TypeError, match="roughness"):
        pyrt.Lambert(albedo=0.5, roughness=0.2)


def _write(tmp_path, text, name="s.toml"):
    p = tmp_path / name
    p.write_text(text)
    return p


def test_scene_file_unknown_keys_and_missing_files(tmp_path):
    base = '[materials.w]\ntype = "lambert"\n'
    with pytest.raises(pyrt.SceneFileError, match=r"unknown key\(s\) \['fvo'\] in \[camera\]"):
        pyrt.load_scene(_write(tmp_path, "[camera]\nfvo = 30\n"))
    with pytest.raises(pyrt.SceneFileError, match=r"\[materials.w\].*albdo"):
        pyrt.load_scene(_write(tmp_path, base + "albdo = 0.5\n"))
    with pytest.raises(pyrt.SceneFileError, match="unknown material type 'lamber'"):
        pyrt.load_scene(_write(tmp_path, '[materials.w]\ntype = "lamber"\n'))
    with pytest.raises(pyrt.SceneFileError, match="mesh file not found"):
        pyrt.load_scene(_write(tmp_path, base + '[[meshes]]\nfile = "nope.obj"\nmaterial = "w"\n'))
    with pytest.raises(pyrt.SceneFileError, match="unknown material 'q'"):
        pyrt.load_scene(_write(tmp_path, base + '[[meshes]]\nprimitive = "sphere"\nmaterial = "q"\n'))
    with pytest.raises(pyrt.SceneFileError, match=r"\[\[lights\]\] #0.*zero-length"):
        pyrt.load_scene(_write(tmp_path, '[[lights]]\ntype = "directional"\ndirection = [0,0,0]\nirradiance = 1\n'))
    with pytest.raises(pyrt.SceneFileError, match="cannot parse"):
        pyrt.load_scene(_write(tmp_path, "[camera\n"))
    with pytest.raises(FileNotFoundError, match="scene file not found"):
        pyrt.load_scene(tmp_path / "missing.toml")


def test_scene_file_loads_mesh_file_and_json(tmp_path):
    trimesh.creation.icosphere(2).export(tmp_path / "ball.obj")
    p = _write(tmp_path, '{"camera": {"width": 16, "height": 12}, "materials": {"w": {"type": "lambert"}},'
               ' "meshes": [{"file": "ball.obj", "material": "w", "translate": [0, 0, 0]}],'
               ' "lights": [{"type": "point", "position": [0, 0, 5], "intensity": 3}]}', "s.json")
    scene, _ = pyrt.load_scene(p)
    img = pyrt.render(scene)
    assert img.shape == (12, 16, 3) and img.max() > 0


def test_no_nan_in_output_for_nasty_scenes():
    cam = pyrt.Camera(position=(0, 0.5, 3), target=(0, 0.5, 0), width=32, height=32, spp=2)
    s = pyrt.Scene(cam)
    s.add_plane((0, 0, 0), 4, pyrt.Lambert(0.5))
    s.add_sphere((0, 0.5, 0), 0.5, pyrt.Glass(1.5))
    s.add_sphere((0.6, 0.5, 0), 0.3, pyrt.BlinnPhong(kd=0.3, ks=0.7, exponent=1e4))
    s.add_light(pyrt.PointLight((0, 0, 0), intensity=5.0))        # exactly on the floor
    s.add_light(pyrt.PointLight((0, 0.5, 0), intensity=5.0))      # at the glass centre
    s.add_light(pyrt.SpotLight((0, 2, 0), (0, -1, 0), intensity=5, inner_angle=0, outer_angle=0))
    s.add_light(pyrt.DirectionalLight((1, -1e-9, 0), 3.0))         # grazing
    with warnings.catch_warnings():
        warnings.simplefilter("error")
        res = pyrt.render_full(s)
    assert np.all(np.isfinite(res.image))
    assert res.stats.nonfinite_samples == 0


@pytest.mark.parametrize("spp", [1, 4])
def test_a_nonfinite_sample_is_zeroed_counted_and_reported(spp):
    """The last line of defence: a material bug producing NaN reaches neither the image nor its neighbours."""
    class Broken(pyrt.Lambert):
        def emission(self, ctx):
            e = np.zeros((ctx.n_hits, 3))
            e[ctx.p[:, 0] > 0.5] = np.nan
            return e

    cam = pyrt.Camera(position=(0, 3, 0.01), target=(0, 0, 0), fov=40, width=16, height=16, spp=spp)
    s = pyrt.Scene(cam)
    s.add_plane((0, 0, 0), 4, Broken(0.5))
    s.add_light(pyrt.PointLight((0, 2, 0), intensity=5.0))
    with pytest.warns(RuntimeWarning, match="non-finite"):
        res = pyrt.render_full(s)
    assert np.all(np.isfinite(res.image))
    assert 0 < res.stats.nonfinite_samples < 16 * 16 * spp
    assert res.image[:, :4].min() > 0            # the healthy half is lit as usual


def test_exr_round_trip_and_aovs(tmp_path):
    img = np.random.default_rng(1).random((6, 5, 3)).astype(np.float32) * 10
    pyrt.write_exr(tmp_path / "a.exr", img)
    np.testing.assert_array_equal(pyrt.read_exr(tmp_path / "a.exr"), img)
    pyrt.write_exr(tmp_path / "h.exr", img, half=True, aovs={"depth": np.full((6, 5), np.inf),
                                                             "normal": img, "albedo": img})
    np.testing.assert_allclose(pyrt.read_exr(tmp_path / "h.exr"), img, rtol=1e-3)
    with pytest.raises(ValueError, match="NaN"):
        pyrt.write_exr(tmp_path / "n.exr", np.full((2, 2, 3), np.nan, dtype=np.float32))
    with pytest.raises(FileNotFoundError):
        pyrt.read_exr(tmp_path / "none.exr")


def test_png_tonemaps(tmp_path):
    from skimage import io as skio
    img = np.array([[[0.0, 0.0, 0.0], [0.18, 0.18, 0.18], [100, 100, 100]]], dtype=np.float32)
    pyrt.write_png(tmp_path / "lin.png", img, tonemap="linear")
    out = skio.imread(tmp_path / "lin.png")
    assert out[0, 0, 0] == 0 and out[0, 2, 0] == 255
    assert out[0, 1, 0] == round((1.055 * 0.18 ** (1 / 2.4) - 0.055) * 255)  # sRGB curve of 0.18
    pyrt.write_png(tmp_path / "r.png", img, tonemap="reinhard", L_white=100.0)
    assert skio.imread(tmp_path / "r.png")[0, 2, 0] == 255   # L_white maps to white
    pyrt.write_png(tmp_path / "f.png", img, tonemap="film", exposure=1.0)
    with pytest.raises(ValueError, match="unknown tone-mapping"):
        pyrt.write_png(tmp_path / "x.png", img, tonemap="agx")


def test_cli_renders_exr_and_png(tmp_path):
    out_exr, out_png = tmp_path / "d.exr", tmp_path / "d.png"
    r = subprocess.run([sys.executable, "-m", "pyrt", "render", str(ROOT / "assets/default_scene.toml"),
                        "-o", str(out_exr), "-o", str(out_png), "--width", "40", "--height", "30", "--spp", "1",
                        "--aovs"], capture_output=True, text=True, cwd=ROOT)
    assert r.returncode == 0, r.stderr
    assert pyrt.read_exr(out_exr).shape == (30, 40, 3) and out_png.stat().st_size > 0
    r = subprocess.run([sys.executable, "-m", "pyrt", "render", str(tmp_path / "none.toml"), "-o", "x.png"],
                       capture_output=True, text=True)
    assert r.returncode == 2 and "scene file not found" in r.stderr


def test_memory_is_bounded_by_chunk_not_image():
    """Peak memory beyond the film grows with the chunk size, not with the image (4K x 16 spp stays < 2 GB)."""
    import tracemalloc
    scene, _ = pyrt.load_scene(ROOT / "assets/default_scene.toml")

    def peak(w, h, spp):
        scene.camera.width, scene.camera.height = w, h
        tracemalloc.start()
        pyrt.render(scene, spp=spp, chunk_samples=1 << 14, threads=1)
        _, pk = tracemalloc.get_traced_memory()
        tracemalloc.stop()
        film = w * h * 3 * (8 + 4)  # float64 accumulation + float32 output
        return pk - film

    small = peak(128, 128, 1)  # exactly one chunk
    big = peak(256, 256, 4)    # 16x more samples, 16 chunks
    assert big < 2.0 * small, (small, big)
    # default: chunks 2x larger, one in flight per core (2 here): chunk part <= 4 * big (8 * big: margin); 4K film 0.3 GB
    assert 8 * big + 3840 * 2160 * 3 * 12 < 2e9


def _pyrt_module_names():
    for path in sorted((ROOT / "pyrt").rglob("*.py")):
        parts = list(path.relative_to(ROOT).with_suffix("").parts)
        yield ".".join(parts[:-1] if parts[-1] == "__init__" else parts)
    for path in sorted((ROOT / "shaders").rglob("*.py")):
        parts = list(path.relative_to(ROOT / "shaders").with_suffix("").parts)
        yield ".".join(["pyrt", "shaders", *(parts[:-1] if parts[-1] == "__init__" else parts)])


def test_every_error_class_derives_from_pyrt_error():
    """``except pyrt.Error`` catches every error pyrt defines (scan: every class defined in a pyrt module that
    derives from Exception)."""
    errors, bad = [], []
    for name in _pyrt_module_names():
        if name.endswith(".__main__"):
            continue
        mod = importlib.import_module(name)
        for obj in vars(mod).values():
            if (isinstance(obj, type) and issubclass(obj, Exception) and not issubclass(obj, Warning)
                    and obj.__module__ == name):   # warnings (PrecisionWarning) are not errors
                errors.append(obj)
                if not issubclass(obj, pyrt.Error):
                    bad.append(f"{name}.{obj.__qualname__}")
    assert not bad, f"error classes not deriving from pyrt.Error: {bad}"
    assert len(errors) >= 8, errors  # the scan found the families' errors (GeometryError, MaterialError, ...)
