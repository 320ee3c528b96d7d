"""Coverage (pyrt.integrators.coverage): alpha cut-outs, blending, back-face culling, against exact masks.

The scenes: a camera looking down -z at a quad (z = 0, side 1) in front of a Lambertian wall (z = -1) or a
mirror, lit by a directional light. Ground truth per pixel centre from the analytic ray-plane intersections
in float64: which texel of the quad the camera ray crosses, where it meets the wall (or, off the mirror, the
back of the quad), and whether the wall point's shadow ray crosses an opaque texel. Pixels whose crossing
points lie within 1e-3 texel of a texel edge are left out (float32 geometry decides them); everything else
must be exact to float32 rounding (the Lambert values are closed forms).
"""
from __future__ import annotations

import base64
import io
import json

import numpy as np
import pytest
import trimesh

import pyrt
from pyrt.integrators.coverage import MAX_LAYERS, CoverageTable
from pyrt.integrators.prepared import PreparedScene

H = 0.5                                   # quad half-size
N_TEX = 8                                 # checker texels per side
CHECKER = ((np.arange(N_TEX)[:, None] + np.arange(N_TEX)[None, :]) % 2 == 0).astype(np.float64)  # 1 = opaque
E = 3.0                                   # W/m^2
LIGHT_DIR = np.array([0.3, 0.2, -1.0])    # direction the light travels
L_TO = -LIGHT_DIR / np.linalg.norm(LIGHT_DIR)
RHO_Q, RHO_W = 0.5, np.array([0.6, 0.3, 0.2])
BG = np.array([0.1, 0.2, 0.9])
BAND = 1e-3                               # texels


def _quad(z=0.0, flip=False, size=H):
    v = np.array([[-size, -size, z], [size, -size, z], [size, size, z], [-size, size, z]])
    f = np.array([[0, 2, 1], [0, 3, 2]]) if flip else np.array([[0, 1, 2], [0, 2, 3]])
    m = trimesh.Trimesh(vertices=v, faces=f, process=False)
    m.visual = trimesh.visual.TextureVisuals(uv=(v[:, :2] + size) / (2 * size))
    return m


def _camera(width=96, height=96):
    return pyrt.Camera(position=(0, 0, 3), target=(0, 0, 0), up=(0, 1, 0), fov=40, width=width, height=height,
                       spp=1, jitter=False)


def _scene(quad_material, *, back="wall", flip=False, ambient=0.0):
    cam = _camera()
    scene = pyrt.Scene(cam, background=BG, ambient=ambient)
    scene.add_mesh(_quad(flip=flip), quad_material, smooth=False, name="quad")
    back_mat = pyrt.Lambert(albedo=RHO_W) if back == "wall" else pyrt.Mirror(reflectance=1.0)
    scene.add_mesh(_quad(z=-1.0, size=20.0), back_mat, smooth=False, name=back)
    scene.add_light(pyrt.DirectionalLight(LIGHT_DIR, irradiance=E))
    return scene


def _rays(cam):
    row, col = np.divmod(np.arange(cam.width * cam.height), cam.width)
    d = cam.directions(col + 0.5, row + 0.5)
    return np.broadcast_to(np.asarray(cam.position, dtype=np.float64), d.shape), d


def _cross_quad(o, d):
    """Where the lines o + t d cross the quad's plane z = 0: (inside, opaque texel, safe from texel edges)."""
    t = -o[:, 2] / d[:, 2]
    p = o + t[:, None] * d
    u, v = (p[:, 0] + H) / (2 * H), (p[:, 1] + H) / (2 * H)
    inside = (u >= 0) & (u < 1) & (v >= 0) & (v < 1)
    col = np.clip(np.floor(u * N_TEX).astype(int), 0, N_TEX - 1)
    row = np.clip(np.floor((1 - v) * N_TEX).astype(int), 0, N_TEX - 1)
    opaque = inside & (CHECKER[row, col] > 0.5)
    fu, fv = u * N_TEX, v * N_TEX
    margin = np.minimum(np.abs(fu - np.round(fu)), np.abs(fv - np.round(fv)))
    return inside, opaque, margin > BAND


def _lambert(rho, cos):
    return np.asarray(rho)[None, :] / np.pi * E * np.maximum(cos, 0.0)[:, None] * np.ones((1, 3))


def _wall_point(o, d):
    t = (-1.0 - o[:, 2]) / d[:, 2]
    return o + t[:, None] * d


def _opacity_texture():
    return pyrt.ImageTexture(CHECKER, filter="nearest", srgb=False, name="checker")


def _expected_masked_wall(o, d, shadow_opaque):
    """Radiance and safe mask over a wall seen through (or beside) the quad; ``shadow_opaque(inside, opaque)``
    gives the wall's transmittance toward the light."""
    P = _wall_point(o, d)
    s_in, s_op, s_safe = _cross_quad(P, np.broadcast_to(L_TO, P.shape))
    return _lambert(RHO_W, np.full(P.shape[0], L_TO[2])) * shadow_opaque(s_in, s_op)[:, None], s_safe


def _flat(img):
    return img.reshape(-1, 3).astype(np.float64)


@pytest.mark.parametrize("integrator, backend", [("whitted", "compiled"), ("whitted", "numpy"), ("glossy", "auto")])
def test_mask_camera_and_shadow_rays_are_exact(integrator, backend):
    mat = pyrt.Lambert(albedo=RHO_Q).set_coverage(opacity=_opacity_texture(), alpha_mode="mask")
    scene = _scene(mat)
    img = _flat(pyrt.render(scene, seed=0, integrator=integrator, backend=backend))
    o, d = _rays(scene.camera)
    q_in, q_op, q_safe = _cross_quad(o, d)
    wall, w_safe = _expected_masked_wall(o, d, lambda i, op: np.where(op, 0.0, 1.0))
    expected = np.where(q_op[:, None], _lambert([RHO_Q] * 3, np.full(o.shape[0], L_TO[2])), wall)
    safe = q_safe & (q_op | w_safe)
    np.testing.assert_allclose(img[safe], expected[safe], rtol=1e-5, atol=1e-7)
    # the mask is really exercised: quad texels, holes with the wall lit and shadowed behind them
    through = safe & q_in & ~q_op
    assert (safe & q_op).sum() > 700 and through.sum() > 700
    assert (through & (expected[:, 0] == 0)).sum() > 200 and (through & (expected[:, 0] > 0)).sum() > 200
    assert safe.sum() > 0.9 * safe.size


@pytest.mark.parametrize("backend", ["compiled", "numpy"])
def test_mask_secondary_rays_see_the_cutouts(backend):
    """Through a hole: the mirror behind reflects the ray back onto the quad's back (ambient only) or its holes."""
    mat = pyrt.Lambert(albedo=RHO_Q).set_coverage(opacity=_opacity_texture(), alpha_mode="mask")
    ambient = 0.2
    scene = _scene(mat, back="mirror", ambient=ambient)
    img = _flat(pyrt.render(scene, seed=0, backend=backend))
    o, d = _rays(scene.camera)
    q_in, q_op, q_safe = _cross_quad(o, d)
    P = _wall_point(o, d)
    r = d * np.array([1.0, 1.0, -1.0])
    b_in, b_op, b_safe = _cross_quad(P, r)
    front = _lambert([RHO_Q] * 3, np.full(o.shape[0], L_TO[2])) + RHO_Q * ambient
    behind = np.where(b_op[:, None], RHO_Q * ambient, BG[None, :])
    expected = np.where(q_op[:, None], front, behind)
    safe = q_safe & (q_op | b_safe)
    np.testing.assert_allclose(img[safe], expected[safe], rtol=1e-5, atol=1e-7)
    reflected = safe & ~q_op & q_in
    assert (reflected & b_op).sum() > 70 and (reflected & ~b_op).sum() > 70


@pytest.mark.parametrize("integrator", ["whitted", "glossy"])
def test_blend_is_alpha_front_plus_one_minus_alpha_back(integrator):
    a = 0.3
    mat = pyrt.Lambert(albedo=RHO_Q).set_coverage(opacity=a, alpha_mode="blend")
    scene = _scene(mat)
    img = _flat(pyrt.render(scene, seed=0, integrator=integrator))
    o, d = _rays(scene.camera)
    q_in, _, q_safe = _cross_quad(o, d)
    wall, w_safe = _expected_masked_wall(o, d, lambda inside, op: np.where(inside, 1.0 - a, 1.0))
    P = _wall_point(o, d)
    s_in, _, _ = _cross_quad(P, np.broadcast_to(L_TO, P.shape))
    front = _lambert([RHO_Q] * 3, np.full(o.shape[0], L_TO[2]))
    expected = np.where(q_in[:, None], a * front + (1 - a) * wall, wall)
    safe = q_safe & w_safe       # (the checker's texel edges are left out too: a superset of the quad's outline)
    np.testing.assert_allclose(img[safe], expected[safe], rtol=1e-5, atol=1e-7)
    assert (safe & q_in & s_in).sum() > 500 and (safe & q_in & ~s_in).sum() > 100   # blend over a dimmed wall
    assert (safe & ~q_in & s_in).sum() > 70                                         # the wall's 0.7 shadow


@pytest.mark.parametrize("backend", ["compiled", "numpy"])
def test_double_sided_false_culls_back_faces_but_still_casts_shadows(backend):
    culled = pyrt.Lambert(albedo=RHO_Q).set_coverage(double_sided=False)
    scene = _scene(culled, flip=True)             # the quad's winding normal faces away from the camera
    img = _flat(pyrt.render(scene, seed=0, backend=backend))
    o, d = _rays(scene.camera)
    q_in, _, q_safe = _cross_quad(o, d)
    wall, w_safe = _expected_masked_wall(o, d, lambda inside, op: np.where(inside, 0.0, 1.0))
    np.testing.assert_allclose(img[w_safe], wall[w_safe], rtol=1e-5, atol=1e-7)
    assert (q_in & w_safe & (wall[:, 0] == 0)).sum() > 300      # the wall is seen through the culled quad ...
    # ... double-sided (the default), the same back face is seen, shaded with the normal turned to the viewer
    img2 = _flat(pyrt.render(_scene(pyrt.Lambert(albedo=RHO_Q), flip=True), seed=0, backend=backend))
    front = _lambert([RHO_Q] * 3, np.full(o.shape[0], L_TO[2]))
    np.testing.assert_allclose(img2[q_in & q_safe], front[q_in & q_safe], rtol=1e-5, atol=1e-7)


def test_opaque_double_sided_scene_builds_no_coverage_table():
    scene = _scene(pyrt.Lambert(albedo=RHO_Q))
    with PreparedScene(scene) as ps:
        assert ps.coverage is None
    scene = _scene(pyrt.Lambert(albedo=RHO_Q).set_coverage(alpha_mode="mask", opacity=0.2))
    with PreparedScene(scene) as ps:
        assert ps.coverage is not None and ps.coverage.shadows
    culled = CoverageTable.for_scene([pyrt.Lambert().set_coverage(double_sided=False), pyrt.Glass()])
    assert not culled.shadows and culled.cull.tolist() == [True, False]
    glass = pyrt.Glass().set_coverage(double_sided=False)            # dielectrics are never culled
    assert CoverageTable.for_scene([glass]) is None


def test_coverage_parameters_are_validated():
    with pytest.raises(pyrt.Error, match="alpha_mode"):
        pyrt.Lambert().set_coverage(alpha_mode="cutout")
    with pytest.raises(pyrt.Error, match="opacity"):
        pyrt.Lambert().set_coverage(opacity=1.5)
    with pytest.raises(pyrt.Error, match="1 channel"):
        pyrt.Lambert().set_coverage(opacity=pyrt.ImageTexture(np.ones((2, 2, 3))))
    m = pyrt.Lambert()
    m.alpha_cutoff = 2.0
    with pytest.raises(pyrt.Error, match="alpha_cutoff"):
        m.validate()


def test_scene_file_coverage_keys():
    scene, _ = pyrt.load_dict({
        "camera": {"position": [0, 0, 3], "target": [0, 0, 0], "width": 8, "height": 8},
        "materials": {"leaf": {"type": "lambert", "albedo": 0.5, "alpha_mode": "blend", "opacity": 0.3,
                               "double_sided": False}},
        "meshes": [{"primitive": "plane", "size": 1.0, "material": "leaf"}],
    })
    m = scene.materials[0]
    assert (m.alpha_mode, m.opacity, m.double_sided, m.alpha_cutoff) == ("blend", 0.3, False, 0.5)
    with pytest.raises(pyrt.Error, match=r"\[materials.leaf\].*alpha_mode"):
        pyrt.load_dict({"camera": {}, "materials": {"leaf": {"type": "lambert", "alpha_mode": "cut"}}})


def test_mirroring_transform_keeps_the_winding_normal_outward():
    scene = pyrt.Scene(_camera(8, 8))
    scene.add_mesh(_quad(), pyrt.Lambert(), transform=np.diag([-1.0, 1.0, 1.0, 1.0]), smooth=False)
    fn = scene.geometry_table().face_normals
    np.testing.assert_allclose(fn, [[0, 0, 1], [0, 0, 1]], atol=1e-12)


# ---------------------------------------------------------------------------------- glTF

def _png_rgba(rgba8):
    from PIL import Image
    buf = io.BytesIO()
    Image.fromarray(rgba8, mode="RGBA").save(buf, format="PNG")
    return buf.getvalue()


def _write_gltf(path, material, *, rgba=None, vertex_alpha=None):
    """One quad (z = 0, side 2 H, facing +z) with UVs (glTF top-left), a material and optionally an RGBA image
    (nearest sampler) as its base colour and COLOR_0 with the given alpha."""
    v = np.array([[-H, -H, 0], [H, -H, 0], [H, H, 0], [-H, H, 0]], dtype=np.float32)
    uv = np.array([[0, 1], [1, 1], [1, 0], [0, 0]], dtype=np.float32)
    idx = np.array([0, 1, 2, 0, 2, 3], dtype=np.uint16)
    nrm = np.tile(np.array([0, 0, 1], dtype=np.float32), (4, 1))
    parts = [v, nrm, uv, idx]
    if vertex_alpha is not None:
        parts.append(np.column_stack([np.ones((4, 3)), np.full(4, vertex_alpha)]).astype(np.float32))
    blob, views, accessors = b"", [], []
    kinds = [("VEC3", 5126), ("VEC3", 5126), ("VEC2", 5126), ("SCALAR", 5123)] + [("VEC4", 5126)] * (len(parts) - 4)
    for arr, (typ, comp) in zip(parts, kinds):
        b = arr.tobytes()
        views.append({"buffer": 0, "byteOffset": len(blob), "byteLength": len(b)})
        acc = {"bufferView": len(views) - 1, "componentType": comp, "count": arr.shape[0], "type": typ}
        if arr is v:
            acc.update(min=v.min(axis=0).tolist(), max=v.max(axis=0).tolist())
        accessors.append(acc)
        blob += b + b"\0" * (-len(b) % 4)
    attrs = {"POSITION": 0, "NORMAL": 1, "TEXCOORD_0": 2}
    if vertex_alpha is not None:
        attrs["COLOR_0"] = 4
    doc = {"asset": {"version": "2.0"}, "scene": 0, "scenes": [{"nodes": [0]}], "nodes": [{"mesh": 0}],
           "meshes": [{"primitives": [{"attributes": attrs, "indices": 3, "material": 0}]}],
           "materials": [material], "accessors": accessors, "bufferViews": views,
           "buffers": [{"byteLength": len(blob),
                        "uri": "data:application/octet-stream;base64," + base64.b64encode(blob).decode()}]}
    if rgba is not None:
        doc["images"] = [{"uri": "data:image/png;base64," + base64.b64encode(_png_rgba(rgba)).decode()}]
        doc["samplers"] = [{"magFilter": 9728, "minFilter": 9728}]
        doc["textures"] = [{"source": 0, "sampler": 0}]
        material.setdefault("pbrMetallicRoughness", {})["baseColorTexture"] = {"index": 0}
    path.write_text(json.dumps(doc))
    return path


def _gltf_scene(path):
    scene = pyrt.Scene(_camera(), background=BG)
    pyrt.load_asset(str(path)).add_to_scene(scene, lights=False)
    scene.add_mesh(_quad(z=-1.0, size=20.0), pyrt.Lambert(albedo=RHO_W), smooth=False, name="wall")
    scene.add_light(pyrt.DirectionalLight(LIGHT_DIR, irradiance=E))
    return scene


def test_gltf_mask_from_the_base_color_alpha(tmp_path):
    rgba = np.zeros((N_TEX, N_TEX, 4), dtype=np.uint8)
    rgba[..., 0] = 255
    rgba[..., 3] = (CHECKER * 255).astype(np.uint8)
    mat = {"alphaMode": "MASK", "doubleSided": True, "pbrMetallicRoughness": {"metallicFactor": 0.0}}
    path = _write_gltf(tmp_path / "mask.gltf", mat, rgba=rgba)
    asset = pyrt.load_asset(str(path))
    assert not any("opaque" in w for w in asset.warnings)
    scene = _gltf_scene(path)
    m = scene.materials[0]
    assert (m.alpha_mode, m.alpha_cutoff, m.double_sided) == ("mask", 0.5, True)
    img = _flat(pyrt.render(scene, seed=0))
    o, d = _rays(scene.camera)
    q_in, q_op, q_safe = _cross_quad(o, d)
    wall, w_safe = _expected_masked_wall(o, d, lambda i, op: np.where(op, 0.0, 1.0))
    holes = q_safe & w_safe & ~q_op
    np.testing.assert_allclose(img[holes], wall[holes], rtol=1e-5, atol=1e-7)   # the wall, shadow holes included
    solid = q_safe & q_op
    assert np.all(img[solid, 0] > 10 * img[solid, 2])                          # the red quad
    assert holes.sum() > 2000 and solid.sum() > 700


def test_gltf_blend_factor_alpha_cull_and_vertex_alpha(tmp_path):
    blend = {"alphaMode": "BLEND", "pbrMetallicRoughness": {"baseColorFactor": [1, 1, 1, 0.3]}}
    scene = _gltf_scene(_write_gltf(tmp_path / "blend.gltf", blend))
    m = scene.materials[0]
    assert (m.alpha_mode, m.opacity, m.double_sided) == ("blend", 0.3, False)   # glTF default: single-sided
    # COLOR_0 alpha 0 multiplies the coverage: every texel cut out, the wall and its full light remain
    masked = {"alphaMode": "MASK", "doubleSided": True}
    scene = _gltf_scene(_write_gltf(tmp_path / "va.gltf", masked, vertex_alpha=0.0))
    img = _flat(pyrt.render(scene, seed=0))
    o, d = _rays(scene.camera)
    wall, _ = _expected_masked_wall(o, d, lambda i, op: np.ones(i.shape))
    np.testing.assert_allclose(img, wall, rtol=1e-5, atol=1e-7)
    # OPAQUE ignores every alpha (the spec): the quad hides the wall
    opaque = {"pbrMetallicRoughness": {"baseColorFactor": [1, 1, 1, 0.0]}}
    scene = _gltf_scene(_write_gltf(tmp_path / "opaque.gltf", opaque, vertex_alpha=0.0))
    assert scene.materials[0].alpha_mode == "opaque"
    q_in, _, q_safe = _cross_quad(o, d)
    img = _flat(pyrt.render(scene, seed=0))
    assert not np.allclose(img[q_in & q_safe], wall[q_in & q_safe], rtol=1e-3)


def test_normal_map_on_a_back_face_is_the_front_normal_reversed():
    """A double-sided surface seen from behind shows the same micro-surface from its other side: the perturbed
    normal of a back face (ns turned toward the viewer, front False) is minus the front face's."""
    from pyrt.geometry.surface import SurfaceBatch

    n_ts = np.array([0.3, -0.2, 0.9])
    n_ts /= np.linalg.norm(n_ts)
    nm = pyrt.NormalMap(np.broadcast_to((n_ts + 1) / 2, (2, 2, 3)).copy())

    def shading_normal(ns, front):
        k = 3
        ctx = SurfaceBatch(p=np.zeros((k, 3)), uv=np.full((k, 2), 0.5), duvdx=np.zeros((k, 2)),
                           duvdy=np.zeros((k, 2)), ns=np.tile(ns, (k, 1)), dpdu=np.tile([2.0, 0, 0], (k, 1)),
                           dpdv=np.tile([0, 3.0, 0], (k, 1)), front=np.full(k, front))
        return pyrt.textures.perturb_normal(ctx, nm)

    n_front = shading_normal([0, 0, 1.0], True)
    np.testing.assert_allclose(n_front, np.tile(n_ts, (3, 1)), atol=1e-6)   # float32 texels
    np.testing.assert_allclose(shading_normal([0, 0, -1.0], False), -n_front, atol=1e-12)


@pytest.mark.parametrize("backend", ["auto", "numpy"])
@pytest.mark.parametrize("kind", ["mask", "cull"])
@pytest.mark.parametrize("layers", [MAX_LAYERS, MAX_LAYERS + 1])
def test_layer_bound_is_what_the_docs_say(layers, kind, backend):
    """Up to MAX_LAYERS cut-out (camera and shadow rays) or culled surfaces are skipped; a ray meeting one more
    is dropped. (Culled faces still cast shadows: that scene is lit by the ambient term.) ``auto``: culling on the
    compiled path."""
    cam = pyrt.Camera(position=(0, 0, 3), target=(0, 0, 0), fov=10, width=4, height=4, spp=1, jitter=False)
    scene = pyrt.Scene(cam, background=BG, ambient=0.0 if kind == "mask" else 0.2)
    if kind == "mask":
        gone = pyrt.Lambert(albedo=RHO_Q).set_coverage(opacity=0.0, alpha_mode="mask")
    else:
        gone = pyrt.Lambert(albedo=RHO_Q).set_coverage(double_sided=False)
    for i in range(layers):
        scene.add_mesh(_quad(z=-0.01 * i, flip=kind == "cull"), gone, smooth=False)
    scene.add_mesh(_quad(z=-1.0, size=20.0), pyrt.Lambert(albedo=RHO_W), smooth=False)
    if kind == "mask":
        scene.add_light(pyrt.DirectionalLight((0, 0, -1), irradiance=E))
    img = _flat(pyrt.render(scene, seed=0, backend=backend))
    if layers > MAX_LAYERS:
        assert np.all(img == 0.0)
    elif kind == "mask":
        np.testing.assert_allclose(img, _lambert(RHO_W, np.ones(16)), rtol=1e-5)
    else:
        np.testing.assert_allclose(img, np.tile(RHO_W * 0.2, (16, 1)), rtol=1e-6)


def test_aovs_see_the_nearest_kept_surface():
    """Depth and albedo AOVs: the blend surface itself (not its continuation); through a cut-out, the wall."""
    blend = pyrt.Lambert(albedo=RHO_Q).set_coverage(opacity=0.3, alpha_mode="blend")
    res = pyrt.render_full(_scene(blend), seed=0, aovs=True)
    cam = _camera()
    o, d = _rays(cam)
    q_in, q_op, q_safe = _cross_quad(o, d)
    depth, albedo = res.aovs["depth"].reshape(-1), res.aovs["albedo"].reshape(-1, 3)
    t_quad, t_wall = -o[:, 2] / d[:, 2], (-1.0 - o[:, 2]) / d[:, 2]
    sel = q_in & q_safe
    np.testing.assert_allclose(depth[sel], t_quad[sel], rtol=1e-5)
    np.testing.assert_allclose(albedo[sel], RHO_Q, rtol=1e-6)
    mask = pyrt.Lambert(albedo=RHO_Q).set_coverage(opacity=_opacity_texture(), alpha_mode="mask")
    res = pyrt.render_full(_scene(mask), seed=0, aovs=True)
    depth = res.aovs["depth"].reshape(-1)
    holes = q_in & q_safe & ~q_op
    np.testing.assert_allclose(depth[holes], t_wall[holes], rtol=1e-5)
    assert holes.sum() > 700 and depth.size == cam.width * cam.height


def test_mask_with_nested_media_on():
    """With interface stacks (an absorbing glass in the scene) the camera rays still skip the cut-outs exactly."""
    mat = pyrt.Lambert(albedo=RHO_Q).set_coverage(opacity=_opacity_texture(), alpha_mode="mask")
    scene = _scene(mat)
    scene.add_sphere((1.5, 1.5, 0), 0.2, pyrt.Glass(ior=1.5, absorption=0.5))   # off screen's quad region
    with PreparedScene(scene) as ps:
        assert ps.media is not None
    img = _flat(pyrt.render(scene, seed=0))
    o, d = _rays(scene.camera)
    q_in, q_op, q_safe = _cross_quad(o, d)
    wall, w_safe = _expected_masked_wall(o, d, lambda i, op: np.where(op, 0.0, 1.0))
    expected = np.where(q_op[:, None], _lambert([RHO_Q] * 3, np.full(o.shape[0], L_TO[2])), wall)
    safe = q_safe & (q_op | w_safe) & q_in
    np.testing.assert_allclose(img[safe], expected[safe], rtol=1e-5, atol=1e-7)
    assert safe.sum() > 1500
