"""The previewer's procedural studio environment (issue 14 item 4): metals reflect it, it replaces the constant
ambient term with the same mean radiance (no double counting), it turns with the camera and can be turned off."""
import math

import numpy as np
import pytest
import trimesh

from pyrt.apps import preview as P
from pyrt.apps.preview.studio import SOFT_BOXES, camera_rotation, studio_environment_image
from pyrt.io.assets.asset import Asset, AssetInstance, AssetMesh
from pyrt.io.assets.common import PBRParams
from pyrt.shaders import envmap, metals


def _sphere_asset(base, metallic, roughness):
    s = trimesh.creation.icosphere(subdivisions=5, radius=1.0)
    return Asset(path="sphere.glb", format="gltf", up_axis="+y",
                 meshes=[AssetMesh("s", s.vertices.copy(), s.faces.copy(), normals=s.vertex_normals.copy(), material=0)],
                 instances=[AssetInstance(0, np.eye(4))],
                 materials=[PBRParams(base_color_factor=np.r_[base, 1.0], metallic_factor=metallic,
                                      roughness_factor=roughness)])


def test_studio_map_is_normalised_grey_and_has_its_soft_boxes():
    img = studio_environment_image()
    assert img.shape == (128, 256, 3) and img.dtype == np.float32
    assert np.all(img[..., 0] == img[..., 1]) and np.all(img[..., 1] == img[..., 2]) and img.min() > 0
    d_omega = envmap.latlong_texel_solid_angle(128, 256)[:, None]
    assert math.isclose(float(np.sum(img[..., 0] * d_omega)), 4 * math.pi, rel_tol=1e-6)   # mean radiance 1
    for az, el, _, _, share in SOFT_BOXES:   # each box's centre is brighter than the walls, in share order
        a, e = math.radians(az), math.radians(el)
        c = np.array([[math.sin(a) * math.cos(e), math.sin(e), math.cos(a) * math.cos(e)]])
        L = envmap.latlong_lookup(img, c)[0, 0]
        assert L > 3 * img[64:, :, 0].max() * share


@pytest.mark.parametrize("roughness", [0.0, 0.01, 0.05])
def test_gold_sphere_reflects_the_studio(roughness):
    """A gold metal (base colour = the exact conductor F0 of gold, metallic 1) is never black, and near normal
    incidence its pixels are F0 x the environment radiance in the mirror direction.

    Ground truth per pixel: the pixel-centre ray against the analytic unit sphere, mirror direction ``r``,
    Schlick ``F(cos)`` with ``F0`` (what the glTF material evaluates; ``F = F0`` to 1e-7 at these angles) times
    ``environment.radiance(r)``. Pixels whose normal is within 18 degrees of the view (cos > 0.95) and whose
    reflection points up (r_y > 0.15, away from the ground, which the map does not hold). The image averages
    4 jittered samples over each pixel and the GGX lobe (alpha = roughness^2 <= 0.0025) blurs a little:
    measured 0.02 % / 0.3 % on the mean; tolerances 2 % on the mean and 5 % on the median pixel ratio."""
    eta, k = metals.metal_eta_k("gold")
    F0 = ((eta - 1) ** 2 + k ** 2) / ((eta + 1) ** 2 + k ** 2)
    o = P.PreviewOptions(width=96, height=72, spp=4)
    ps = P.PreviewScene(_sphere_asset(F0, 1.0, roughness), o)
    try:
        assert ps.studio_environment and np.all(ps.scene.ambient == 0)
        img = ps.render_view(ps.azimuth).image.astype(np.float64)
        mask = ps.model_mask()
        assert np.all(img[mask] > 0)
        cam = ps.scene.camera
        ys, xs = np.nonzero(mask)
        d = cam.directions(xs + 0.5, ys + 0.5)
        oc = cam.position - ps.center
        b = d @ oc
        t = -b - np.sqrt(np.maximum(b * b - (oc @ oc - 1.0), 0.0))
        n = cam.position + t[:, None] * d - ps.center
        n /= np.linalg.norm(n, axis=1)[:, None]
        cos = -np.einsum("ij,ij->i", d, n)
        r = d + 2 * cos[:, None] * n
        want = (F0 + (1 - F0) * (1 - cos[:, None]) ** 5) * ps.environment.radiance(r)
        sel = (cos > 0.95) & (r[:, 1] > 0.15)
        assert sel.sum() > 100
        got = img[ys, xs][sel]
        np.testing.assert_allclose(got.mean(axis=0), want[sel].mean(axis=0), rtol=0.02)
        np.testing.assert_allclose(np.median(got / want[sel], axis=0), 1.0, atol=0.05)
    finally:
        ps.close()


def test_studio_replaces_the_ambient_with_the_same_mean_radiance():
    """No double counting: with the studio on the constant ambient is 0 and the map's mean radiance is the ambient
    radiance it replaces, so a Lambertian surface averaged over all orientations receives the same light
    (the SH irradiance over a Fibonacci sphere of normals / pi = the mean radiance, to 1 %)."""
    o = P.PreviewOptions(width=24, height=18, spp=1)
    on = P.PreviewScene(_sphere_asset(np.full(3, 0.8), 0.0, 0.5), o)
    off = P.PreviewScene(_sphere_asset(np.full(3, 0.8), 0.0, 0.5), P.PreviewOptions(width=24, height=18, spp=1,
                                                                                      studio_env=False))
    try:
        La = o.ambient * o.key / math.pi
        assert np.all(on.scene.ambient == 0) and np.allclose(off.scene.ambient, La)
        assert off.environment is None and not off.studio_environment
        assert math.isclose(on.environment.intensity, La, rel_tol=1e-12)
        i = np.arange(2000) + 0.5
        z = 1 - 2 * i / 2000
        phi = math.pi * (1 + 5 ** 0.5) * i
        nrm = np.stack([np.sqrt(1 - z * z) * np.cos(phi), z, np.sqrt(1 - z * z) * np.sin(phi)], axis=1)
        E = on.environment.irradiance_sh(nrm)
        assert math.isclose(float(E[:, 0].mean()) / math.pi, La, rel_tol=0.01)
    finally:
        on.close()
        off.close()


def test_studio_turns_with_the_camera_and_keeps_the_backdrop():
    o = P.PreviewOptions(width=24, height=18, spp=1)
    ps = P.PreviewScene(_sphere_asset(np.full(3, 0.8), 1.0, 0.1), o)
    try:
        for az in (0.0, 35.0, 200.0):
            ps._set_view(az)
            np.testing.assert_allclose(ps.environment.rotation, camera_rotation(az))
            key = P.studio_rig(az, o)[0]                         # the key light's soft box is where the key is
            a, e = math.radians(SOFT_BOXES[0][0]), math.radians(SOFT_BOXES[0][1])
            local = np.array([math.sin(a) * math.cos(e), math.sin(e), math.cos(a) * math.cos(e)])
            np.testing.assert_allclose(ps.environment.to_world(local[None])[0], -key.direction, atol=1e-12)
            assert ps.environment.hide_background
        img = ps.render_view(35.0).image
        mask = ps.model_mask()
        corner = img[0, 0]                                       # the backdrop, not the map
        np.testing.assert_allclose(corner, ps.scene.background, rtol=1e-5)
        assert not mask[0, 0]
    finally:
        ps.close()


def test_studio_env_option_and_cli():
    from pyrt.apps.preview.cli import _parser

    assert _parser().parse_args(["m.glb"]).studio_env == "on"
    assert _parser().parse_args(["m.glb", "--studio-env", "off"]).studio_env == "off"
    with pytest.raises(SystemExit):
        _parser().parse_args(["m.glb", "--studio-env", "maybe"])


def test_studio_prefilter_matches_the_engine_stack(rng):
    """The studio's cheaper prefilter (one channel, half width, 64 samples) against the engine's stack for the
    same map (_prefilter_stack: three channels, full width, 128 samples): within 3 % of the map's maximum at
    every GGX width, on 5000 random directions (measured 2.6 %)."""
    from pyrt.lights.environment import PREFILTER_ALPHAS, _prefilter_stack
    from pyrt.apps.preview.studio import StudioEnvironment

    env = StudioEnvironment()
    cheap, ref = env._build_prefiltered(), _prefilter_stack(env.image)
    d = rng.normal(size=(5000, 3))
    d /= np.linalg.norm(d, axis=1)[:, None]
    for a in PREFILTER_ALPHAS:
        x = envmap.roughness_map_lookup(cheap, PREFILTER_ALPHAS, d, np.full(len(d), a))
        y = envmap.roughness_map_lookup(ref, PREFILTER_ALPHAS, d, np.full(len(d), a))
        assert np.abs(x - y).max() <= 0.03 * env.image.max(), a


def test_shipped_prefiltered_stack_equals_a_fresh_build(tmp_path, monkeypatch):
    """pyrt/apps/preview/studio_prefiltered.npz (tools/make_tables.py) is the default studio map's stack as built
    today (float32: within 1e-6 relative); a changed map or a missing file falls back to building it."""
    from pyrt.apps.preview import studio as S
    env = S.StudioEnvironment()
    grey = np.asarray(env.image[..., :1], dtype=np.float64)
    shipped = S.shipped_prefiltered(grey)
    assert shipped is not None, "studio_prefiltered.npz is stale: run python tools/make_tables.py"
    fresh = S.build_studio_prefiltered(grey)
    assert len(shipped) == len(fresh) == len(S.PREFILTER_ALPHAS) - 1
    for a, b in zip(shipped, fresh):
        assert a.shape == b.shape
        np.testing.assert_allclose(a, b, rtol=1e-6, atol=0)
    assert S.shipped_prefiltered(grey * 1.01) is None          # another map: not used
    monkeypatch.setattr(S, "PREFILTERED_FILE", tmp_path / "missing.npz")
    assert S.shipped_prefiltered(grey) is None
    maps = S.StudioEnvironment()._build_prefiltered()
    np.testing.assert_allclose(maps[1][..., :1], fresh[0], rtol=0, atol=0)
