"""IES LM-63 type C: parsing, symmetric cases, bilinear interpolation, flux, IESLight."""
import math
import os

import numpy as np
import pytest

import pyrt
from pyrt.shaders import ies
from sphere_quadrature import sphere_integral

ROOT = os.path.dirname(os.path.dirname(os.path.abspath(__file__)))
ASSET = os.path.join(ROOT, "assets", "ies", "pyrt_downlight.ies")


def _profile(v, h, cd):
    return ies.parse_ies(ies.format_ies(v, h, cd))


def test_shipped_asset_is_current_and_parses():
    import sys
    sys.path.insert(0, os.path.join(ROOT, "tools"))
    try:
        import make_ies_profile
    finally:
        sys.path.pop(0)
    with open(ASSET) as f:
        text = f.read()
    assert text == make_ies_profile.downlight_text()
    p = ies.parse_ies(text)
    assert p.vertical_angles.shape == (19,) and p.horizontal_angles.shape == (9,)
    assert p.keywords["MANUFAC"] == "pyrt"
    # the header's lumens are the exact flux of the interpolant; the smooth formula gives 2000 pi / 3
    assert ies.ies_flux(p) == pytest.approx(p.lumens_per_lamp, rel=1e-6)
    assert ies.ies_flux(p) == pytest.approx(2000 * math.pi / 3, rel=0.01)


def test_candela_at_nodes_and_bilinear_between():
    v = np.array([0.0, 30.0, 90.0, 180.0])
    h = np.array([0.0, 90.0, 180.0, 270.0, 360.0])
    cd = np.arange(20.0).reshape(5, 4)
    cd[4] = cd[0]
    p = _profile(v, h, cd)
    V, H = np.meshgrid(v, h[:4])
    np.testing.assert_allclose(ies.ies_candela(p, V.ravel(), H.ravel()), cd[:4].ravel())
    # halfway in both angles: mean of four corners
    val = ies.ies_candela(p, np.array([15.0]), np.array([45.0]))
    assert val[0] == pytest.approx(cd[0:2, 0:2].mean())
    # H wraps: 405 == 45, -45 == 315
    np.testing.assert_allclose(ies.ies_candela(p, np.array([15.0, 15.0]), np.array([405.0, -45.0])),
                               ies.ies_candela(p, np.array([15.0, 15.0]), np.array([45.0, 315.0])))


@pytest.mark.parametrize("sym, h_range, fn", [
    ("rotational", [0.0], lambda V, H: np.cos(V / 2) ** 2),
    ("quadrant", np.arange(0, 91, 15.0), lambda V, H: (1 + 0.4 * np.cos(2 * H)) * np.cos(V / 2) ** 2),
    ("bilateral", np.arange(0, 181, 15.0), lambda V, H: (1 + 0.4 * np.cos(H)) * np.cos(V / 2) ** 2),
    ("bilateral_90", np.arange(90, 271, 15.0), lambda V, H: (1 + 0.4 * np.sin(H)) * np.cos(V / 2) ** 2),
])
def test_symmetric_tables_equal_the_full_table(sym, h_range, fn, rng):
    v = np.arange(0, 181, 10.0)
    h_full = np.arange(0, 361, 15.0)
    Vf, Hf = np.meshgrid(np.radians(v), np.radians(h_full))
    full = _profile(v, h_full, 1000 * fn(Vf, Hf))
    Vs, Hs = np.meshgrid(np.radians(v), np.radians(np.asarray(h_range)))
    part = _profile(v, h_range, 1000 * fn(Vs, Hs))
    assert ies._symmetry(part.horizontal_angles) == sym
    V = rng.uniform(0, 180, 2000)
    H = rng.uniform(0, 360, 2000)
    np.testing.assert_allclose(ies.ies_candela(part, V, H), ies.ies_candela(full, V, H), rtol=1e-12, atol=1e-9)
    assert ies.ies_flux(part) == pytest.approx(ies.ies_flux(full), rel=1e-12)


def test_flux_is_the_integral_of_the_interpolant():
    p = ies.parse_ies(open(ASSET).read())
    light = pyrt.IESLight((0, 0, 0), p)
    # kinks at every tabulated vertical angle: split the quadrature there (theta from the nadir axis)
    breaks = np.cos(np.radians(p.vertical_angles))
    num = sphere_integral(light.radiant_intensity, light.direction, breaks=breaks, n_per_piece=40, n_phi=2880)
    np.testing.assert_allclose(num, light.radiant_power(), rtol=2e-6)
    assert light.luminous_power() == pytest.approx(ies.ies_flux(p), rel=1e-12)


def test_uniform_profile_equals_point_light(rng):
    p = _profile([0.0, 90.0, 180.0], [0.0], [[100.0, 100.0, 100.0]])
    a = pyrt.IESLight((0.3, 2.0, -0.1), p, direction=(0.2, -1, 0.4))
    b = pyrt.PointLight((0.3, 2.0, -0.1), candela=100.0)
    pts = rng.normal(size=(500, 3)) * 3
    for x, y in zip(a.sample(pts, None), b.sample(pts, None)):
        np.testing.assert_allclose(x, y, rtol=1e-13)
    np.testing.assert_allclose(a.radiant_power(), b.radiant_power(), rtol=1e-13)


def test_orientation_nadir_and_horizontal_reference():
    p = ies.parse_ies(open(ASSET).read())
    light = pyrt.IESLight((0, 0, 0), p, direction=(0, -1, 0), reference=(1, 0, 0), scale=2.0)
    s = 1 / math.sqrt(2)
    w = np.array([[0, -1, 0], [s, -s, 0], [0, -s, -s], [0, -s, s], [0, 1, 0]], dtype=float)
    # luminaire frame: z = up (+y), x = H 0 (+x), y = z cross x = -z world: H 90 along -z
    expected = 2.0 * ies.ies_candela(p, np.array([0, 45, 45, 45, 180.0]), np.array([0, 0, 90, 270, 0.0]))
    np.testing.assert_allclose(light.radiant_intensity(w)[:, 1] * 683.0, expected, rtol=1e-12)
    assert expected[1] > expected[2] > 0 and expected[4] == 0


def test_tilt_include_and_multipliers():
    text = """IESNA91
[TEST] tilt
TILT=INCLUDE
1
3
0 45 90
1 0.9 0.8
1 -1 2.0 3 1 1 1 0 0 0
0.5 1.0 60
0 90 180
0
10 20 30
"""
    p = ies.parse_ies(text)
    np.testing.assert_allclose(p.candela, [[10.0, 20.0, 30.0]])   # 2.0 multiplier x 0.5 ballast factor
    assert p.input_watts == 60


@pytest.mark.parametrize("text, match", [
    ("IESNA:LM-63-2002\n1 2 3\n", "TILT="),
    ("TILT=lamp.tlt\n1 -1 1 2 1 1 1 0 0 0\n1 1 0\n0 90\n0\n1 1\n", "separate tilt file"),
    ("TILT=NONE\n1 -1 1 2 1 2 1 0 0 0\n1 1 0\n0 90\n0\n1 1\n", "type B"),
    ("TILT=NONE\n1 -1 1 3 1 1 1 0 0 0\n1 1 0\n0 90\n0\n1 1\n", "expected"),
    ("TILT=NONE\n1 -1 1 2 1 1 1 0 0 0\n1 1 0\n90 0\n0\n1 1\n", "increasing"),
])
def test_bad_files_name_the_problem(text, match):
    with pytest.raises(ValueError, match=match):
        ies.parse_ies(text)


def test_iesl_light_errors_and_scene_file(tmp_path):
    with pytest.raises(pyrt.LightError, match="not found"):
        pyrt.IESLight((0, 0, 0), str(tmp_path / "missing.ies"))
    bad = tmp_path / "bad.ies"
    bad.write_text("TILT=NONE\n1 -1 1 2 1 3 1 0 0 0\n1 1 0\n0 90\n0\n1 1\n")
    with pytest.raises(pyrt.LightError, match="bad.ies.*type A"):
        pyrt.IESLight((0, 0, 0), str(bad))
    (tmp_path / "lamp.ies").write_text(open(ASSET).read())
    scene_file = tmp_path / "s.toml"
    scene_file.write_text("""
[camera]
position = [0, 2, 3]
target = [0, 0, 0]
width = 8
height = 8
[materials.white]
type = "lambert"
[[meshes]]
primitive = "plane"
size = 4
material = "white"
[[lights]]
type = "ies"
position = [0, 1, 0]
profile = "lamp.ies"
temperature = 3000
""")
    scene, _ = pyrt.load_scene(str(scene_file))
    light = scene.lights[0]
    assert isinstance(light, pyrt.IESLight) and light.path == str(tmp_path / "lamp.ies")
    img = pyrt.render(scene)
    assert np.all(np.isfinite(img)) and img.max() > 0
