"""Normal maps whose mirror reflection goes below the geometric surface (the black rims of glossy bumps):
``NormalMap(reflection="bend")`` (default) tilts such normals toward the geometric one
(:func:`pyrt.shaders.vec.valid_reflection_normal`), ``"drop"`` keeps them (their reflections are dropped).

Ground truth: a mirror of reflectance 1 under a uniform environment of radiance 1 is exactly 1 wherever its
reflection leaves the surface (no sampling: delta lobe, constant background), so "bend" must give 1 on every pixel
and "drop" 0 on the rim band; a GGX conductor with F = 1 in the same furnace may not exceed 1 (4 standard errors).
"""
import numpy as np
import pytest
import trimesh

import pyrt
from pyrt.lights import ConstantEnvironment, set_environment
from pyrt.shaders.vec import reflect, valid_reflection_normal
from pyrt.textures import NormalMap, TextureError


def _unit(a):
    return a / np.linalg.norm(a, axis=1, keepdims=True)


def test_bent_normals_reflect_above_the_surface_and_valid_ones_are_kept(rng):
    n_rows = 20000
    ng = _unit(rng.normal(size=(n_rows, 3)))
    wo = _unit(rng.normal(size=(n_rows, 3)))
    wo = np.where((np.einsum("ij,ij->i", wo, ng) < 0)[:, None], -wo, wo)     # the viewer's side of ng
    n = _unit(ng + 1.5 * rng.normal(size=(n_rows, 3)))                       # strongly perturbed normals
    out = valid_reflection_normal(ng, wo, n)
    assert out.dtype == np.float64 and np.all(np.isfinite(out))
    np.testing.assert_allclose(np.linalg.norm(out, axis=1), 1.0, atol=1e-12)
    r_old = reflect(wo, n)
    cos_old = np.einsum("ij,ij->i", n, wo)
    valid = (cos_old > 0) & (np.einsum("ij,ij->i", r_old, ng) >= np.minimum(0.9 * np.einsum("ij,ij->i", ng, wo), 0.01))
    assert 0.2 < valid.mean() < 0.8                                          # both kinds of rows occur
    np.testing.assert_array_equal(out[valid], n[valid])
    r_new = reflect(wo, out)
    assert np.all(np.einsum("ij,ij->i", r_new[~valid], ng[~valid]) > 0)      # the reflection leaves the surface
    assert np.all(np.einsum("ij,ij->i", out, wo) >= 0)                        # and the normal faces the viewer


def test_reflection_mode_is_checked():
    with pytest.raises(TextureError, match="reflection must be one of"):
        NormalMap(np.full((2, 2, 3), 0.5), reflection="clamp")


def _tilt_map(deg_lo=-32.0, deg_hi=8.0, rows=64):
    """A map tilting the normal along +u (toward a viewer on +x) by an angle ramping over the rows."""
    a = np.deg2rad(np.linspace(deg_lo, deg_hi, rows))
    n_ts = np.stack([np.sin(a), np.zeros_like(a), np.cos(a)], axis=1)
    return np.repeat(((n_ts + 1.0) / 2.0)[:, None, :], 4, axis=1)


def _plane_scene(material, width=40, height=30):
    cam = pyrt.Camera(position=(4.0, 2.2, 0.0), target=(0.0, 0.0, 0.0), fov=30, width=width, height=height,
                      jitter=False)
    sc = pyrt.Scene(cam)
    v = np.array([[-4.0, 0, -4], [4, 0, -4], [4, 0, 4], [-4, 0, 4]])
    tm = trimesh.Trimesh(v, [[0, 2, 1], [0, 3, 2]], process=False)
    tm.visual = trimesh.visual.TextureVisuals(uv=(v[:, [0, 2]] + 4.0) / 8.0)   # u along +x: dpdu = +x
    sc.add_mesh(tm, material, smooth=False)
    return sc


@pytest.mark.parametrize("mode", ["bend", "drop"])
def test_mirror_furnace_is_one_everywhere_when_bent(mode):
    mirror = pyrt.Mirror(1.0)
    mirror.normal_map = NormalMap(_tilt_map(), reflection=mode, filter="nearest")
    sc = _plane_scene(mirror)
    set_environment(sc, ConstantEnvironment(1.0), lighting=None)
    img = pyrt.render(sc, spp=1, seed=0, progress=False)
    dark = np.mean(img[..., 0] < 0.5)
    if mode == "bend":
        np.testing.assert_allclose(img, 1.0, atol=1e-6)
    else:          # the rim band: reflections about the tilted normal go below the plane and are dropped
        assert dark > 0.1, dark
        np.testing.assert_allclose(img[img[..., 0] >= 0.5], 1.0, atol=1e-6)


def test_glossy_furnace_with_a_bent_normal_map_does_not_exceed_one_and_recovers_the_rim():
    means = {}
    for mode in ("drop", "bend"):
        mat = pyrt.CookTorrance(ks=1.0, roughness=0.25, fresnel="none")
        mat.normal_map = NormalMap(_tilt_map(), reflection=mode, filter="nearest")
        sc = _plane_scene(mat, width=24, height=18)
        set_environment(sc, ConstantEnvironment(1.0), lighting="mis", n_samples=2)
        img = pyrt.render(sc, spp=4, seed=1, integrator="glossy", progress=False).reshape(-1, 3).astype(np.float64)
        lum = img.mean(axis=1)
        se = lum.std(ddof=1) / np.sqrt(lum.size)
        means[mode] = (lum.mean(), se)
        print(f"{mode}: mean {lum.mean():.4f} +- {se:.4f} (1 SE)")
        assert lum.mean() <= 1.0 + 4 * se                   # no gain in a white furnace
    (m_drop, s_drop), (m_bend, s_bend) = means["drop"], means["bend"]
    assert m_bend > m_drop + 4 * np.hypot(s_drop, s_bend)
