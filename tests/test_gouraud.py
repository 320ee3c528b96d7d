"""Gouraud shading: lighting at the vertices, radiance interpolated with the barycentrics."""
import math

import numpy as np
import pytest
import trimesh

import pyrt
from render_helpers import pixel_centre_hits_on_plane_y0

RHO = 0.6
V = np.array([[-2.0, 0, 2], [2, 0, 2], [2, 0, -2], [-2, 0, -2]])
F = np.array([[0, 1, 2], [0, 2, 3]])


def _plane_scene(shading, material=None, size=40):
    cam = pyrt.Camera(position=(0, 3, 0), target=(0, 0, 0), up=(0, 0, -1), fov=60, width=size, height=size, spp=1,
                      jitter=False)
    scene = pyrt.Scene(cam)
    scene.add_mesh((V, F), material or pyrt.Lambert(albedo=RHO), smooth=False, shading=shading)
    return scene


def _barycentrics(p):
    """Triangle index and barycentrics of points on y = 0 inside the square (faces F)."""
    out = np.zeros(p.shape[:-1] + (3,))
    tri = np.where(p[..., 0] >= -p[..., 2], 0, 1)   # diagonal from v0 (-2, 2) to v2 (2, -2)
    for k in range(2):
        a, b, c = V[F[k]]
        m = np.stack([b - a, c - a], axis=-1)[[0, 2]]   # x, z rows
        rhs = (p - a)[..., [0, 2]]
        uv = np.linalg.solve(m, rhs.reshape(-1, 2).T).T.reshape(p.shape[:-1] + (2,))
        bk = np.concatenate([1 - uv.sum(-1, keepdims=True), uv], axis=-1)
        out = np.where((tri == k)[..., None], bk, out)
    return tri, out


def test_gouraud_is_the_interpolation_of_exact_vertex_radiance():
    scene = _plane_scene("gouraud")
    lp = np.array([0.3, 0.8, -0.4])
    I = 5.0
    scene.add_light(pyrt.PointLight(lp, I))
    img = pyrt.render(scene)[..., 0].astype(np.float64)
    p = pixel_centre_hits_on_plane_y0(scene.camera)
    d = lp - V
    r2 = (d ** 2).sum(-1)
    Lv = RHO / math.pi * I * (d[:, 1] / np.sqrt(r2)) / r2        # exact Lambert radiance at the vertices
    tri, b = _barycentrics(p)
    expected = np.einsum("...c,...c->...", b, Lv[F[tri]])
    inside = (np.abs(p[..., 0]) < 1.99) & (np.abs(p[..., 2]) < 1.99)
    assert inside.sum() > 0.5 * inside.size
    np.testing.assert_allclose(img[inside], expected[inside], rtol=1e-5)
    # and it is not per-pixel (Phong/flat) lighting: the point light's falloff is not linear
    flat = pyrt.render(_with_light(_plane_scene("flat"), lp, I))[..., 0]
    assert np.abs(flat[inside] - img[inside]).max() > 0.1 * img[inside].max()


def _with_light(scene, lp, I):
    scene.add_light(pyrt.PointLight(lp, I))
    return scene


def test_gouraud_equals_flat_under_directional_light():
    imgs = []
    for shading in ("flat", "gouraud", "phong"):
        scene = _plane_scene(shading)
        scene.add_light(pyrt.DirectionalLight((0.2, -1, 0.3), 2.0))
        imgs.append(pyrt.render(scene))
    np.testing.assert_allclose(imgs[1], imgs[0], rtol=1e-6)
    np.testing.assert_allclose(imgs[2], imgs[0], rtol=1e-6)


def test_gouraud_misses_a_highlight_inside_a_triangle():
    mat = pyrt.BlinnPhong(kd=0.2, ks=0.5, exponent=200.0)
    peaks = {}
    for shading in ("phong", "gouraud"):
        scene = _plane_scene(shading, mat)
        scene.add_light(pyrt.PointLight((0.5, 1.0, 0.5), 3.0))
        peaks[shading] = pyrt.render(scene)[..., 0].max()
    assert peaks["phong"] > 3 * peaks["gouraud"]


def test_gouraud_sphere_is_smooth_and_finite():
    cam = pyrt.Camera(position=(0, 0, 4), target=(0, 0, 0), fov=35, width=32, height=32)
    out = {}
    for shading in ("flat", "gouraud", "phong"):
        scene = pyrt.Scene(cam)
        scene.add_mesh(trimesh.creation.icosphere(subdivisions=1), pyrt.Lambert(0.7), shading=shading, smooth=True)
        scene.add_light(pyrt.PointLight((2, 2, 3), 20.0))
        out[shading] = pyrt.render(scene)
        assert np.all(np.isfinite(out[shading]))
    # Gouraud and Phong agree at the vertices only, so they are close but not equal; flat differs more
    g, p, f = (out[s][..., 0] for s in ("gouraud", "phong", "flat"))
    assert 0 < np.abs(g - p).mean() < np.abs(f - p).mean()


def test_shading_option_is_validated():
    scene = pyrt.Scene()
    with pytest.raises(pyrt.SceneError, match="shading must be"):
        scene.add_mesh((V, F), pyrt.Lambert(), shading="toon")


def test_scene_file_shading_key(tmp_path):
    f = tmp_path / "s.toml"
    f.write_text("""
[camera]
width = 8
height = 8
[materials.red]
type = "lambert"
albedo = [0.8, 0.1, 0.1]
[[meshes]]
primitive = "sphere"
subdivisions = 1
material = "red"
shading = "gouraud"
[[lights]]
type = "point"
position = [2, 2, 3]
intensity = 10
""")
    scene, _ = pyrt.load_scene(str(f))
    assert scene.gouraud_meshes == {0}
    assert np.all(np.isfinite(pyrt.render(scene)))
