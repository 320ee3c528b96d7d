"""The glossy integrator's clamp (``glossy_clamp``): the direct light at hits of glossy rays, limited per sample.

What is exact here: the clamp's arithmetic (rows over the limit end at the limit, colour kept, the others
untouched); no clamp and an unreachable one give the same image bit for bit; a clamp can only lower a pixel
(the random streams are the same, every sample's contribution is at most what it was, and rounded float sums are
monotone); scenes without glossy rays do not change; the previewer's radiance scale for known lights.
"""
from __future__ import annotations

import math

import numpy as np
import pytest
import trimesh

import pyrt
from pyrt.apps.preview import PreviewOptions
from pyrt.apps.preview.options import PreviewError
from pyrt.apps.preview.rig import lit_white_radiance
from pyrt.core.errors import RenderError
from pyrt.integrators.whitted import clamp_sampled
from pyrt.lights import ConstantEnvironment, DirectionalLight, set_environment


def test_clamp_sampled_scales_rows_over_the_limit_to_it():
    rng = np.random.default_rng(3)
    Ld = rng.uniform(0.0, 10.0, (200, 3))
    thr = rng.uniform(0.0, 1.0, (200, 3))
    sampled = rng.random(200) < 0.7
    out = clamp_sampled(Ld, thr, sampled, 2.0)
    contrib = np.max(thr * Ld, axis=1)
    over = sampled & (contrib > 2.0)
    assert over.any() and (~over).any()
    np.testing.assert_array_equal(out[~over], Ld[~over])                       # untouched, bit for bit
    np.testing.assert_allclose(np.max(thr[over] * out[over], axis=1), 2.0, rtol=1e-12)
    np.testing.assert_allclose(out[over] / Ld[over], (2.0 / contrib[over])[:, None] * np.ones(3), rtol=1e-12)
    assert clamp_sampled(Ld, thr, sampled, 1e9) is Ld                          # nothing over: the same array


def _firefly_scene(n=24):
    """A glossy floor reflecting a near-mirror sphere lit by a directional light: the floor's glossy rays that
    reach the sphere's highlight are the rare bright samples the clamp is for."""
    cam = pyrt.Camera(position=(0.0, 1.2, 4.0), target=(0.0, 0.0, 0.0), fov=30, width=n, height=n)
    sc = pyrt.Scene(cam)
    floor = trimesh.Trimesh(vertices=[[-4, -1, -4], [4, -1, -4], [4, -1, 4], [-4, -1, 4]],
                            faces=[[0, 2, 1], [0, 3, 2]])
    sc.add_mesh(floor, pyrt.CookTorrance(kd=(0.2, 0.2, 0.2), ks=(0.8, 0.8, 0.8), roughness=0.25))
    sphere = trimesh.creation.icosphere(subdivisions=3, radius=0.6)
    sc.add_mesh(sphere, pyrt.CookTorrance(kd=(0.0, 0.0, 0.0), ks=(1.0, 1.0, 1.0), roughness=0.1))
    # from behind the sphere, low: its highlights seen from the floor (the floor's glossy rays carry up to ~2.8)
    sc.lights.append(DirectionalLight(direction=(0.0, -0.5, 1.0), irradiance=3.0))
    return sc


def _render(sc, **kw):
    """The NumPy reference path (the compiled path's clamp: tests/test_compiled_glossy.py)."""
    return pyrt.render_full(sc, spp=4, integrator="glossy", seed=2, progress=False, threads=1, backend="numpy",
                            **kw).image


def test_no_clamp_and_an_unreachable_clamp_are_the_same_image():
    sc = _firefly_scene()
    np.testing.assert_array_equal(_render(sc), _render(sc, glossy_clamp=1e30))


def test_a_clamp_only_lowers_pixels_and_takes_the_outliers():
    sc = _firefly_scene()
    free = _render(sc)
    clamped = _render(sc, glossy_clamp=0.5)
    assert np.all(clamped <= free)                      # exact: same samples, each at most what it was
    assert np.any(clamped < free)                       # it acts: the floor's reflection of the highlight


def test_scenes_without_glossy_rays_are_unchanged():
    """Lambertian surfaces spawn no glossy rays: even a clamp of almost 0 changes nothing."""
    cam = pyrt.Camera(position=(0.0, 0.0, 4.0), target=(0.0, 0.0, 0.0), fov=30, width=16, height=16)
    sc = pyrt.Scene(cam)
    sc.add_mesh(trimesh.creation.icosphere(subdivisions=2), pyrt.Lambert((0.7, 0.5, 0.3)))
    sc.lights.append(DirectionalLight(direction=(0.0, -1.0, -1.0), irradiance=2.0))
    np.testing.assert_array_equal(_render(sc), _render(sc, glossy_clamp=1e-9))


def test_clamp_must_be_a_non_negative_number():
    with pytest.raises(RenderError, match="glossy_clamp"):
        _render(_firefly_scene(4), glossy_clamp=-1.0)
    with pytest.raises(PreviewError, match="glossy_clamp"):
        PreviewOptions(glossy_clamp=0).validate()
    PreviewOptions(glossy_clamp=None).validate()


def test_preview_cli_glossy_clamp_off_and_value():
    from pyrt.apps.preview.cli import _parser
    assert _parser().parse_args(["m.glb", "--glossy-clamp", "off"]).glossy_clamp is None
    assert _parser().parse_args(["m.glb", "--glossy-clamp", "2.5"]).glossy_clamp == 2.5
    assert _parser().parse_args(["m.glb"]).glossy_clamp == PreviewOptions.glossy_clamp


def test_lit_white_radiance_of_known_lights():
    """A directional light of irradiance E lights a white Lambertian surface facing it to E / pi; a constant
    environment of radiance L adds L (its mean over the sphere)."""
    sun = DirectionalLight(direction=(0.0, -1.0, 0.0), irradiance=2.0 * math.pi, color=(1.0, 0.5, 0.25))
    assert lit_white_radiance([sun]) == pytest.approx(2.0, rel=1e-12)
    cam = pyrt.Camera(position=(0.0, 0.0, 4.0), target=(0.0, 0.0, 0.0), fov=30, width=4, height=4)
    sc = pyrt.Scene(cam)
    set_environment(sc, ConstantEnvironment(0.75), lighting="mis", n_samples=1)
    assert lit_white_radiance(list(sc.lights) + [sun]) == pytest.approx(2.75, rel=1e-12)
    assert lit_white_radiance([]) == 0.0
