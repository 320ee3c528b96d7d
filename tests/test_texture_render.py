"""End-to-end texture tests through the renderer: footprints from ray differentials, MIP level
selection, lazy pyramids, filters, procedural textures and normal maps in real renders.

Lighting is the constant ambient term (L = albedo * ambient) unless a test needs a light, so a
pixel's radiance is exactly the filtered texture value.
"""
import numpy as np
import pytest

import pyrt
from pyrt import textures as T
from pyrt.shaders import ewa as E
from pyrt.shaders import textures as K


class Recording(T.Texture):
    """Delegating texture that keeps the uv and footprints it was evaluated with."""

    def __init__(self, inner):
        self.inner = inner
        self.channels = inner.channels
        self.calls = []

    def evaluate(self, ctx):
        self.calls.append((ctx.uv.copy(), ctx.duvdx.copy(), ctx.duvdy.copy(), ctx.p.copy()))
        return self.inner.evaluate(ctx)


def _plane_scene(tex, cam, *, size=(40.0, 60.0), center=(0, 0, -20), tile=None):
    scene = pyrt.Scene(cam, ambient=(1.0, 1.0, 1.0))
    scene.add_plane(center, size, pyrt.Lambert(albedo=tex), name="floor")
    return scene


def _tilted_camera(dist, theta_deg, fov, n):
    """Camera at ``dist`` from the origin, ``theta`` from the +y normal of a plane at y = 0, looking
    at the origin; ``n`` x ``n`` pixels (odd: the centre pixel's ray is the optical axis)."""
    th = np.deg2rad(theta_deg)
    pos = (0.0, dist * np.cos(th), dist * np.sin(th))
    up = (0, 0, -1) if theta_deg == 0 else (0, 1, 0)
    return pyrt.Camera(position=pos, target=(0, 0, 0), up=up, fov=fov, width=n, height=n, spp=1, jitter=False)


@pytest.mark.parametrize("dist,theta_deg", [(3.0, 0.0), (5.0, 45.0), (8.0, 70.0)])
def test_render_footprint_and_mip_level_match_the_analytic_plane(dist, theta_deg):
    n, fov, size, res = 33, 30.0, 4.0, 256
    cam = _tilted_camera(dist, theta_deg, fov, n)
    rec = Recording(T.ImageTexture(np.full((res, res, 3), 0.5), filter="trilinear"))
    scene = pyrt.Scene(cam, ambient=(1, 1, 1))
    scene.add_plane((0, 0, 0), size, pyrt.Lambert(albedo=rec))
    pyrt.render(scene)
    uv, dx, dy, p = (np.concatenate([c[i] for c in rec.calls]) for i in range(4))
    centre = np.argmin(np.linalg.norm(p, axis=1))
    assert np.linalg.norm(p[centre]) < 1e-6  # the centre pixel's ray hits the origin (float32 Embree)
    # Analytic derivative footprint at the centre: a pixel subtends a = 2 tan(fov/2) / n radians;
    # on the plane that is dist * a across and dist * a / cos(theta) along the tilt, in uv / size.
    a = 2 * np.tan(np.deg2rad(fov) / 2) / n
    across = dist * a / size
    along = across / np.cos(np.deg2rad(theta_deg))
    got_x, got_y = np.linalg.norm(dx[centre]), np.linalg.norm(dy[centre])
    # The engine differences over one whole pixel (forward), the analytic value is the derivative:
    # relative difference ~ a * tan(theta) (< 1.5% here).
    tol = 1.5 * a * np.tan(np.deg2rad(theta_deg)) + 1e-5  # + float32 hit-point rounding
    assert abs(got_x / across - 1) < tol
    assert abs(got_y / along - 1) < tol
    lam = K.mip_level_isotropic(dx[centre:centre + 1], dy[centre:centre + 1], (res, res))[0]
    assert abs(lam - np.log2(along * res)) < tol * 1.5


def test_constant_texture_renders_identically_through_every_filter():
    cam = pyrt.Camera(position=(0, 1.0, 6), target=(0, 0, -4), fov=40, width=48, height=32, spp=1, jitter=False)
    images = {}
    for filt in T.FILTERS:
        tex = T.ImageTexture(np.full((37, 53, 3), [0.2, 0.5, 0.7]), filter=filt, scale=(8, 8))
        images[filt] = pyrt.render(_plane_scene(tex, cam))
    for filt, img in images.items():
        np.testing.assert_allclose(img, images["nearest"], atol=1e-6, err_msg=filt)
    assert np.isclose(images["nearest"].max(), 0.7, atol=1e-6)


def test_mip_levels_only_built_when_minified_and_all_read():
    img = np.random.default_rng(1).random((128, 128, 3))
    # Magnified: an 8x8 texture over ~15x15 pixels (several pixels per texel) -> no pyramid at all.
    cam = pyrt.Camera(position=(0, 2.0, 0), target=(0, 0, 0), up=(0, 0, -1), fov=30, width=32, height=32, spp=1,
                      jitter=False)
    tex = T.ImageTexture(img[:8, :8], filter="trilinear")
    scene = pyrt.Scene(cam, ambient=(1, 1, 1))
    scene.add_plane((0, 0, 0), 0.5, pyrt.Lambert(albedo=tex))
    pyrt.render(scene, backend="numpy")          # the NumPy path's lazy pyramid (the compiled path packs every level)
    assert tex.mip_levels_built == []
    # Minified at a grazing angle: exactly the levels the recorded footprints read are built.
    for filt in ("trilinear", "anisotropic"):
        inner = T.ImageTexture(img, filter=filt, scale=(8, 8))
        rec = Recording(inner)
        cam = pyrt.Camera(position=(0, 1.0, 6), target=(0, 0, -4), fov=40, width=48, height=32, spp=1, jitter=False)
        pyrt.render(_plane_scene(rec, cam))
        _, dx, dy, _ = (np.concatenate([c[i] for c in rec.calls]) for i in range(4))
        dx, dy = dx * 8, dy * 8  # the uv transform's scale
        if filt == "trilinear":
            lam = K.mip_level_isotropic(dx, dy, img.shape, inner.footprint_scale)
        else:
            _, _, lam = E.ewa_axes(dx, dy, img.shape, inner.footprint_scale, inner.max_anisotropy)
            lam = lam[np.isfinite(lam) & (lam < K.n_mip_levels(img.shape) - 1)]
        expected = [lv for lv in K.levels_needed(*K.trilinear_levels(lam, K.n_mip_levels(img.shape))) if lv > 0]
        assert inner.mip_levels_built == expected
        assert len(expected) >= 3


def test_procedural_checker_in_object_space_and_uv_space():
    cam = pyrt.Camera(position=(0, 3.0, 0), target=(0, 0, 0), up=(0, 0, -1), fov=60, width=40, height=40, spp=1,
                      jitter=False)
    for space, scale in (("uv", 4.0), ("object", 1.0)):
        tex = T.CheckerTexture(0.1, 0.9, scale=scale, space=space, filtered=False)
        scene = pyrt.Scene(cam, ambient=(1, 1, 1))
        scene.add_plane((0, 0, 0), 4.0, pyrt.Lambert(albedo=tex))
        img = pyrt.render(scene)[..., 0]
        # Expected from the exact hit points of the pixel-centre rays.
        ys, xs = np.mgrid[0:40, 0:40]
        d = cam.directions(xs.ravel() + 0.5, ys.ravel() + 0.5)
        hit = cam.position + (-cam.position[1] / d[:, 1])[:, None] * d
        if space == "uv":
            q = np.stack([(hit[:, 0] + 2) / 4, (2 - hit[:, 2]) / 4], axis=1) * scale
        else:
            q = hit * scale
        want = np.where(np.sum(np.floor(q), axis=1) % 2 == 1, 0.9, 0.1).reshape(40, 40)
        # Pixels whose centre lies within 1e-6 of a cell edge may round either way.
        near_edge = np.min(np.abs(q - np.round(q))[:, [0, -1]], axis=1).reshape(40, 40) < 1e-6
        assert np.all(np.isclose(img, want, atol=1e-6) | near_edge)


def test_filtered_checker_converges_to_grey_far_away():
    cam = pyrt.Camera(position=(0, 0.5, 0), target=(0, 0.0, -40), fov=30, width=64, height=32, spp=1, jitter=False)
    tex = T.CheckerTexture(0.0, 1.0, scale=400.0)
    img = pyrt.render(_plane_scene(tex, cam, size=(200, 200), center=(0, 0, -90)))[..., 0]
    far = img[img.shape[0] // 2 + 1]  # the row just under the horizon: many cells per pixel
    assert np.all(np.abs(far[far > 0] - 0.5) < 0.05)


def _lit_plane(normal_map, albedo=0.5):
    cam = pyrt.Camera(position=(0, 2.0, 0), target=(0, 0, 0), up=(0, 0, -1), fov=40, width=24, height=24, spp=1,
                      jitter=False)
    scene = pyrt.Scene(cam)
    mat = pyrt.Lambert(albedo=albedo)
    mat.normal_map = normal_map
    scene.add_plane((0, 0, 0), 4.0, mat)
    light_dir = np.array([1.0, -1.0, 0.0]) / np.sqrt(2)  # travelling toward -y, +x
    scene.add_light(pyrt.DirectionalLight(direction=light_dir, irradiance=2.0))
    return scene, light_dir


def test_flat_normal_map_render_is_identical():
    base, _ = _lit_plane(None)
    flat, _ = _lit_plane(T.NormalMap(T.flat_normal_map()))
    np.testing.assert_array_equal(pyrt.render(flat), pyrt.render(base))


def test_tilted_normal_map_gives_analytic_lambert_radiance():
    # Tangent-space normal tilted by 30 degrees toward +u (= +x on this plane); the light comes
    # from (-1, 1, 0)/sqrt2 (45 degrees from the normal, on the -x side).
    a = np.deg2rad(30.0)
    img = np.broadcast_to((np.array([np.sin(a), 0.0, np.cos(a)]) + 1) / 2, (4, 4, 3)).copy()
    scene, light_dir = _lit_plane(T.NormalMap(img))
    n = np.array([np.sin(a), np.cos(a), 0.0])
    cos_i = max(0.0, float(np.dot(n, -light_dir)))
    want = 0.5 / np.pi * 2.0 * cos_i
    got = pyrt.render(scene)
    np.testing.assert_allclose(got, want, rtol=1e-6)
    assert np.isclose(cos_i, np.cos(np.deg2rad(75)))  # 30 + 45 degrees apart
    # Tilting toward the light (toward -u) brightens it: 45 - 30 = 15 degrees apart.
    img2 = np.broadcast_to((np.array([-np.sin(a), 0.0, np.cos(a)]) + 1) / 2, (4, 4, 3)).copy()
    scene2, _ = _lit_plane(T.NormalMap(img2))
    np.testing.assert_allclose(pyrt.render(scene2), 0.5 / np.pi * 2.0 * np.cos(np.deg2rad(15)), rtol=1e-6)


def test_texture_seen_in_a_mirror_gets_the_mirrored_cameras_footprint():
    # A mirror in the plane z = 0 (facing +z) and a textured floor (y = 0, z in [4, 12]) behind the
    # camera. Seen through the mirror, the floor is what the camera's mirror image (z -> -z) sees
    # directly, along paths of the same length: the reflected ray differentials must give the
    # same uv footprints as the direct view (a plane mirror is exact, no curvature term).
    res = 64
    target = (0.0, 1.0 - 3.0 / 11.0, 0.0)  # the mirror point that reflects onto the floor centre
    recs = []
    for cam_z, mirror in ((3.0, True), (-3.0, False)):
        rec = Recording(T.ImageTexture(np.full((res, res, 3), 0.5), filter="trilinear"))
        cam = pyrt.Camera(position=(0.0, 1.0, cam_z), target=target, fov=20, width=17, height=17, spp=1,
                          jitter=False)
        scene = pyrt.Scene(cam, ambient=(1, 1, 1))
        scene.add_plane((0, 0, 8.0), (8.0, 8.0), pyrt.Lambert(albedo=rec))
        if mirror:
            scene.add_plane((0, 1.0, 0.0), (20.0, 20.0), pyrt.Mirror(reflectance=1.0), normal=(0, 0, 1))
        pyrt.render(scene)
        recs.append([np.concatenate([c[i] for c in rec.calls]) for i in range(4)])
    via, direct = recs
    assert len(via[0]) > 50 and len(via[0]) == len(direct[0])
    # The two images are left-right mirrored: match hits by position (nearest neighbour).
    from scipy.spatial import cKDTree

    dist, match = cKDTree(direct[3]).query(via[3])
    assert dist.max() < 1e-4
    for k in (1, 2):
        ld = np.linalg.norm(direct[k][match], axis=1)
        lv = np.linalg.norm(via[k], axis=1)
        np.testing.assert_allclose(lv, ld, rtol=1e-4)


def test_trilinear_render_error_against_supersampled_reference():
    # Same property as tests/test_textures.py's kernel-level test, through the renderer (~1.5 s).
    # Measured: nearest 0.275, bilinear 0.259, trilinear 0.084, anisotropic 0.045 (RMS, linear).
    yy, xx = np.mgrid[0:256, 0:256]
    img = (((xx // 16) + (yy // 16)) % 2).astype(np.float32)[..., None].repeat(3, axis=2)
    cam = pyrt.Camera(position=(0, 1.0, 6), target=(0, 0, -4), fov=40, width=64, height=40, spp=1, jitter=False)

    def run(filt, spp):
        tex = T.ImageTexture(img, filter=filt, scale=(8, 8), srgb=False)
        return pyrt.render(_plane_scene(tex, cam), spp=spp)

    ref = run("bilinear", 256)
    err = {f: float(np.sqrt(np.mean((run(f, 1) - ref) ** 2))) for f in ("nearest", "trilinear", "anisotropic")}
    assert err["trilinear"] < 0.1
    assert err["trilinear"] < 0.4 * err["nearest"]
    assert err["anisotropic"] < err["trilinear"]


def test_scene_file_textures_and_normal_map(tmp_path):
    from skimage import io as skio

    skio.imsave(tmp_path / "albedo.png", np.full((4, 4, 3), 188, np.uint8), check_contrast=False)
    skio.imsave(tmp_path / "flat.png", np.tile(np.array([128, 128, 255], np.uint8), (4, 4, 1)), check_contrast=False)
    (tmp_path / "scene.toml").write_text("""
[camera]
position = [0, 2, 0]
target = [0, 0, 0]
up = [0, 0, -1]
width = 8
height = 8
jitter = false
[render]
ambient = [1, 1, 1]
[materials.floor]
type = "lambert"
albedo = { type = "image", path = "albedo.png", filter = "bilinear" }
normal_map = "flat.png"
[materials.checker]
type = "lambert"
albedo = { type = "checker", color0 = 0.2, color1 = [0.9, 0.1, 0.1], scale = 4 }
[[meshes]]
primitive = "plane"
size = 4
material = "floor"
""")
    scene, opts = pyrt.load_scene(tmp_path / "scene.toml")
    floor = scene.materials[0]
    assert isinstance(floor.albedo_value, T.ImageTexture) and isinstance(floor.normal_map, T.NormalMap)
    img = pyrt.render(scene, **opts)
    from pyrt.shaders.color import srgb_decode
    np.testing.assert_allclose(img, srgb_decode(np.array(188 / 255.0)), rtol=1e-5)
    (tmp_path / "bad.toml").write_text("""
[materials.m]
type = "lambert"
albedo = { type = "image", path = "missing.png" }
[[meshes]]
primitive = "plane"
material = "m"
""")
    with pytest.raises(pyrt.SceneFileError, match=r"materials.m\]\.albedo.*missing.png"):
        pyrt.load_scene(tmp_path / "bad.toml")
