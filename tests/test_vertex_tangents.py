"""Vertex tangents (glTF ``TANGENT``, :meth:`pyrt.Scene.add_mesh`'s ``tangents``): normal maps and anisotropic lobes
use the mesh's interpolated tangents and their handedness where it has them, the UV tangents elsewhere.

Ground truth: the interpolated frame is the barycentric sum of the vertex frames (exact); end to end, a glTF plane
whose ``TANGENT`` is the UV tangent renders as the file without it, and a file whose ``TANGENT`` is turned by 90 deg
(or mirrored, w = -1) renders as the file without it whose UVs are turned (mirrored) the same way, so that their
``dpdu``, ``dpdv`` are that frame; a wrong frame gives another image (the checks can fail).
"""
import json

import numpy as np
import pytest
from PIL import Image

import pyrt
from pyrt.core.transforms import transform_tangents
from pyrt.geometry.mesh_data import GeometryError
from pyrt.geometry.surface import surface_from_hits
from pyrt.integrators import PreparedScene
from pyrt.io.assets import load_asset
from pyrt.io.assets.gltf_write import embedded_gltf


def _grid(n=6):
    """A (2 n^2 triangles) square in z = 0, [-1, 1]^2."""
    x, y = np.meshgrid(np.linspace(-1, 1, n + 1), np.linspace(-1, 1, n + 1))
    v = np.column_stack([x.ravel(), y.ravel(), np.zeros(x.size)])
    i = np.arange(n * (n + 1)).reshape(n, n + 1)[:, :n].ravel()
    f = np.concatenate([np.column_stack([i, i + 1, i + n + 2]), np.column_stack([i, i + n + 2, i + n + 1])])
    return v, f


def test_transform_tangents_turns_xyz_and_flips_w_under_a_mirror():
    t = np.array([[1.0, 0, 0, 1], [0, 0, 0, -1], [0, 2.0, 0, -1]])
    rot = np.array([[0.0, -1, 0], [1, 0, 0], [0, 0, 1]])                # 90 deg about z
    out = transform_tangents(t, rot)
    np.testing.assert_allclose(out, [[0, 1, 0, 1], [0, 0, 0, -1], [-1, 0, 0, -1]], atol=1e-15)
    out = transform_tangents(t, np.diag([-3.0, 1.0, 1.0]))             # a mirror with a scale
    np.testing.assert_allclose(out, [[-1, 0, 0, -1], [0, 0, 0, 1], [0, 1, 0, 1]], atol=1e-15)


def test_add_mesh_checks_tangents():
    v, f = _grid(2)
    scene = pyrt.Scene(pyrt.Camera(width=4, height=4))
    n = np.tile([0.0, 0, 1], (len(v), 1))
    with pytest.raises(GeometryError, match="tangents must be finite with shape"):
        scene.add_mesh((v, f), pyrt.Lambert(0.5), normals=n, tangents=np.zeros((len(v), 3)))
    bad = np.tile([1.0, 0, 0, 1], (len(v), 1))
    bad[2, 0] = np.nan
    with pytest.raises(GeometryError, match="mesh 'grid'"):
        scene.add_mesh((v, f), pyrt.Lambert(0.5), normals=n, tangents=bad, name="grid")
    # crease normals re-index the vertices: the tangents are dropped (the UV tangents are used)
    scene.add_mesh((v, f), pyrt.Lambert(0.5), tangents=np.tile([1.0, 0, 0, 1], (len(v), 1)))
    assert scene.meshes[-1].tangents is None


def _hits(scene):
    cam = scene.camera
    ps = PreparedScene(scene)
    rays = cam.generate_rays(0, cam.width * cam.height, np.random.default_rng(0))
    idx, hits = ps.accel.intersect_hits(rays.origins, rays.directions)
    return ps, hits, surface_from_hits(ps.geo, hits, rays.origins[idx], rays.directions[idx])


def test_shading_tangents_are_the_interpolated_vertex_frames_and_the_uv_tangents_elsewhere():
    v, f = _grid()
    uv = (v[:, :2] + 1) / 2
    theta = 0.7 * v[:, 0] + 0.3 * v[:, 1]                               # a tangent field turning across the mesh
    tan = np.column_stack([np.cos(theta), np.sin(theta), np.zeros(len(v)), np.where(v[:, 0] < 0, -1.0, 1.0)])
    cam = pyrt.Camera(position=(0.1, -0.2, 3), target=(0, 0, 0), fov=45, width=24, height=20)
    scene = pyrt.Scene(cam)
    scene.add_mesh((v, f), pyrt.Lambert(0.5), normals=np.tile([0.0, 0, 1], (len(v), 1)), uv=uv, tangents=tan)
    # a second mesh without tangents, in front of part of the first
    scene.add_mesh((v * [0.3, 0.3, 1] + [-0.5, 0, 0.5], f), pyrt.Lambert(0.5), smooth=False, uv=uv)
    ps, hits, surf = _hits(scene)
    t, b = surf.shading_tangents(0)
    first = hits.mesh_id == 0
    assert first.sum() > 50 and (~first).sum() > 20
    tri = ps.geo.faces[ps.geo.face_offset[hits.mesh_id] + hits.prim_id][first]     # mesh 0's vertices come first
    bary = np.column_stack([1 - hits.u - hits.v, hits.u, hits.v])[first]
    bit = tan[:, 3:] * np.cross([0.0, 0, 1], tan[:, :3])
    np.testing.assert_allclose(t[first], np.einsum("nk,nkc->nc", bary, tan[tri, :3]), atol=1e-12)
    np.testing.assert_allclose(b[first], np.einsum("nk,nkc->nc", bary, bit[tri]), atol=1e-12)
    du, dv = surf.uv_tangents(0)
    np.testing.assert_array_equal(t[~first], du[~first])
    np.testing.assert_array_equal(b[~first], dv[~first])
    # a view of the batch gathers the same rows
    sub = surf.subset(np.flatnonzero(first)[::3])
    np.testing.assert_array_equal(sub.shading_tangents(0)[0], t[np.flatnonzero(first)[::3]])


# ------------------------------------------------------------------------------------------- glTF end to end

def _write(path, uv, tangent=None):
    """A .gltf of the grid square (normal +z) with glTF UVs ``uv``, an optional constant ``TANGENT`` and a normal
    map tilted toward tangent-space +x and -y (so that both the tangent and the bitangent's side matter)."""
    v, f = _grid()
    attrs = {"POSITION": v.astype(np.float32), "NORMAL": np.tile(np.float32([0, 0, 1]), (len(v), 1)),
             "TEXCOORD_0": np.asarray(uv, np.float32)}
    if tangent is not None:
        attrs["TANGENT"] = np.tile(np.float32(tangent), (len(v), 1))
    material = {"pbrMetallicRoughness": {"baseColorFactor": [0.8, 0.8, 0.8, 1], "metallicFactor": 0.0,
                                         "roughnessFactor": 0.6},
                "normalTexture": {"index": 0}}
    path.write_text(json.dumps(embedded_gltf(attrs, f, material, [np.tile(np.uint8([205, 80, 200]), (8, 8, 1))])))
    return str(path)


def _render(path, generate_tangents=True):
    """``generate_tangents=False``: a file without TANGENT renders with each triangle's UV tangents, the reference
    the file's tangents are compared with (with generated ones both sides would be vertex tangents). On the NumPy
    path, as their references (one path, the same random numbers: compared pixel by pixel; the compiled path's
    vertex tangents: tests/test_compiled_vertex_attrs.py)."""
    cam = pyrt.Camera(position=(0.2, -0.3, 3), target=(0, 0, 0), fov=40, width=32, height=24, spp=2)
    scene = pyrt.Scene(cam, background=(0, 0, 0))
    asset = load_asset(path, generate_tangents=generate_tangents)
    asset.add_to_scene(scene, lights=False)
    scene.add_light(pyrt.DirectionalLight((0.5, 0.4, -1.0), irradiance=3.0))
    return asset, pyrt.render(scene, seed=3, backend="numpy")


@pytest.fixture(scope="module")
def uv_frames():
    """glTF UVs (top-left origin) whose dpdu, dpdv are (+x, +y), (+y, -x) and (+y, +x) in pyrt's bottom-left UVs."""
    v, _ = _grid()
    x, y = v[:, 0], v[:, 1]
    gl = lambda u, vv: np.column_stack([u, 1.0 - vv])                 # noqa: E731 - pyrt (u, v) -> glTF
    return {"x": gl((x + 1) / 2, (y + 1) / 2), "turned": gl((y + 1) / 2, (1 - x) / 2),
            "mirrored": gl((y + 1) / 2, (x + 1) / 2)}


def test_gltf_tangent_equal_to_the_uv_tangent_renders_as_without_it(tmp_path, uv_frames):
    asset, with_t = _render(_write(tmp_path / "t.gltf", uv_frames["x"], tangent=[1, 0, 0, 1]))
    assert asset.meshes[0].tangents is not None and asset.warnings == []
    _, without = _render(_write(tmp_path / "n.gltf", uv_frames["x"]), generate_tangents=False)
    np.testing.assert_allclose(with_t, without, rtol=1e-5, atol=1e-7)


@pytest.mark.parametrize("tangent, frame", [([0, 1, 0, 1], "turned"), ([0, 1, 0, -1], "mirrored")])
def test_gltf_tangent_sets_the_normal_maps_frame(tmp_path, uv_frames, tangent, frame):
    """TANGENT (0, 1, 0) with w = 1 is the frame (t, b) = (+y, -x), with w = -1 (+y, +x): the same image as the
    file without TANGENT whose UVs have that dpdu, dpdv; not the image of its own UVs' frame."""
    _, with_t = _render(_write(tmp_path / "t.gltf", uv_frames["x"], tangent=tangent))
    _, same_frame = _render(_write(tmp_path / "f.gltf", uv_frames[frame]), generate_tangents=False)
    _, uv_frame = _render(_write(tmp_path / "x.gltf", uv_frames["x"]), generate_tangents=False)
    np.testing.assert_allclose(with_t, same_frame, rtol=1e-5, atol=1e-7)
    assert np.abs(with_t - uv_frame).mean() > 0.02 * uv_frame.mean()


def test_joined_instances_carry_their_tangents_to_the_world(monkeypatch):
    """A model of many instances is joined into world-space meshes (pyrt.io.assets.asset._flattened): the joined
    mesh's tangents are each instance's, moved as Scene.add_mesh moves them (mirrored instances' w flipped)."""
    from pyrt.io.assets import asset as A
    v, f = _grid(2)
    rng = np.random.default_rng(4)
    theta = rng.uniform(0, 2 * np.pi, len(v))
    tan = np.column_stack([np.cos(theta), np.sin(theta), np.zeros(len(v)), np.where(theta > 3, -1.0, 1.0)])
    mesh = A.AssetMesh(name="tile", vertices=v, faces=f, normals=np.tile([0.0, 0, 1], (len(v), 1)),
                       uv=(v[:, :2] + 1) / 2, tangents=tan)
    insts = []
    for i in range(70):
        m = np.eye(4)
        m[:3, :3] = np.linalg.qr(rng.normal(size=(3, 3)))[0] * rng.uniform(0.5, 2)   # rotations and scales
        if i % 2:
            m[:3, :3] = m[:3, :3] @ np.diag([-1.0, 1.0, 1.0])                      # half of them mirrored
        m[:3, 3] = rng.uniform(-3, 3, 3)
        insts.append(A.AssetInstance(mesh=0, world_from_object=m, node=f"n{i}"))

    def world_tangents(min_instances):
        monkeypatch.setattr(A, "FLATTEN_MIN_INSTANCES", min_instances)
        scene = pyrt.Scene(pyrt.Camera(width=4, height=4))
        A.Asset(path="tiles", format="gltf", meshes=[mesh], instances=insts).add_to_scene(scene, lights=False)
        return len(scene.meshes), np.concatenate([m.tangents for m in scene.meshes])

    n_joined, joined = world_tangents(64)
    n_sep, separate = world_tangents(10 ** 9)
    assert n_joined == 1 and n_sep == 70
    np.testing.assert_allclose(joined, separate, atol=1e-12)
    assert (separate[:, 3] != np.tile(tan[:, 3], 70)).any()        # the mirrors flipped some w: the check can fail


# ------------------------------------------------------------------------------------------- generated tangents

def _cylinder(segments=8, distort=0.0):
    """An open cylinder (radius 1, height 1) with outward normals, u around it (optionally distorted: u = s +
    distort s^2, v = y + distort sin(2 pi s)), v up."""
    s = np.linspace(0.0, 1.0, segments + 1)
    a = 2 * np.pi * s
    ring = np.column_stack([np.cos(a), np.zeros_like(a), -np.sin(a)])
    v = np.concatenate([ring, ring + [0, 1, 0]])
    n = np.concatenate([ring, ring])
    uv = np.concatenate([np.column_stack([s + distort * s * s, distort * np.sin(a)]),
                         np.column_stack([s + distort * s * s, 1 + distort * np.sin(a)])])
    k = segments + 1
    i = np.arange(segments)
    f = np.concatenate([np.column_stack([i, i + 1, i + 1 + k]), np.column_stack([i, i + 1 + k, i + k])])
    return v, f, n, uv


def test_generated_tangents_of_a_cylinder_are_its_circles_tangents():
    from pyrt.geometry.tangents import vertex_tangents
    v, f, n, uv = _cylinder()
    t = vertex_tangents(v, f, n, uv)
    a = np.linspace(0.0, 2 * np.pi, 9)
    want = np.column_stack([-np.sin(a), np.zeros_like(a), -np.cos(a)])     # d ring / d u, normalised
    np.testing.assert_allclose(t[:9, :3], want, atol=1e-12)
    np.testing.assert_allclose(t[9:, :3], want, atol=1e-12)
    bitangent = t[:, 3:] * np.cross(n, t[:, :3])
    np.testing.assert_allclose(bitangent, np.tile([0.0, 1.0, 0.0], (18, 1)), atol=1e-12)   # +v is up


def test_generated_tangents_match_a_brute_force_mikktspace_sum():
    """Each vertex: the angle-weighted sum of its triangles' dpdu projected onto its normal's plane, normalised;
    zero where its triangles disagree on the handedness (the shared seam of a mirrored UV map)."""
    from pyrt.geometry.tangents import vertex_tangents
    v, f, n, uv = _cylinder(segments=12, distort=0.4)
    rng = np.random.default_rng(2)
    n = n + rng.normal(0, 0.05, n.shape)
    n /= np.linalg.norm(n, axis=1, keepdims=True)
    uv = uv.copy()
    uv[:, 0] = np.abs(uv[:, 0] - 0.7)            # mirrored about u = 0.7: a vertex column of mixed handedness
    got = vertex_tangents(v, f, n, uv)
    sums = {}
    for tri in f:
        p, q = v[tri], uv[tri]
        e1, e2, d1, d2 = p[1] - p[0], p[2] - p[0], q[1] - q[0], q[2] - q[0]
        det = d1[0] * d2[1] - d1[1] * d2[0]
        dpdu, dpdv = (d2[1] * e1 - d1[1] * e2) / det, (d1[0] * e2 - d2[0] * e1) / det
        for c in range(3):
            a, b = p[(c + 1) % 3] - p[c], p[(c + 2) % 3] - p[c]
            ang = np.arctan2(np.linalg.norm(np.cross(a, b)), a @ b)
            nv = n[tri[c]]
            t = dpdu - nv * (nv @ dpdu)
            hand = 1.0 if np.cross(nv, dpdu) @ dpdv >= 0 else -1.0
            sums.setdefault(tri[c], {}).setdefault(hand, np.zeros(3))
            sums[tri[c]][hand] += ang * t / np.linalg.norm(t)
    mixed = 0
    for vi, by_hand in sums.items():
        if len(by_hand) == 2:
            mixed += 1
            np.testing.assert_array_equal(got[vi], 0.0)
            continue
        (hand, t), = by_hand.items()
        t = t - n[vi] * (n[vi] @ t)
        np.testing.assert_allclose(got[vi, :3], t / np.linalg.norm(t), atol=1e-12)
        assert got[vi, 3] == hand
    assert mixed >= 2                            # the seam is in the mesh: the zero rule was exercised


def test_gltf_without_tangent_uses_generated_ones_and_the_switch_turns_them_off(tmp_path):
    """A normal-mapped glTF without TANGENT renders as the same file carrying the generated tangents; with
    load_asset(generate_tangents=False) its normal map uses each triangle's UV tangents: another image on a mesh
    whose UV map is distorted (the check can fail)."""
    from pyrt.geometry.tangents import vertex_tangents
    v, f, n, uv = _cylinder(segments=10, distort=0.5)
    gl_uv = np.column_stack([uv[:, 0], 1.0 - uv[:, 1]])                # glTF's top-left UVs
    asset = load_asset(_write_mesh(tmp_path / "gen.gltf", v, f, n, gl_uv))
    assert asset.generate_tangents and asset.meshes[0].tangents is None     # generated as the mesh is added
    scene = pyrt.Scene(pyrt.Camera(width=4, height=4))
    asset.add_to_scene(scene, lights=False)
    np.testing.assert_allclose(scene.meshes[0].tangents, vertex_tangents(v, f, n, uv), atol=1e-6)
    generated = _render_mesh(asset)
    given = _render_mesh(load_asset(_write_mesh(tmp_path / "tan.gltf", v, f, n, gl_uv,
                                                tangents=vertex_tangents(v, f, n, uv))))
    np.testing.assert_allclose(generated, given, rtol=1e-5, atol=1e-7)
    off = load_asset(str(tmp_path / "gen.gltf"), generate_tangents=False)
    scene = pyrt.Scene(pyrt.Camera(width=4, height=4))
    off.add_to_scene(scene, lights=False)
    assert scene.meshes[0].tangents is None
    per_triangle = _render_mesh(off)
    assert np.abs(per_triangle - generated).mean() > 0.01 * generated.mean()


def _write_mesh(path, v, f, n, uv, tangents=None):
    """A .gltf of one normal-mapped, double-sided primitive (float32 attributes)."""
    attrs = {"POSITION": v.astype(np.float32), "NORMAL": n.astype(np.float32), "TEXCOORD_0": uv.astype(np.float32)}
    if tangents is not None:
        attrs["TANGENT"] = tangents.astype(np.float32)
    material = {"pbrMetallicRoughness": {"baseColorFactor": [0.8, 0.8, 0.8, 1], "metallicFactor": 0.0,
                                         "roughnessFactor": 0.7},
                "normalTexture": {"index": 0}, "doubleSided": True}
    path.write_text(json.dumps(embedded_gltf(attrs, f, material, [np.tile(np.uint8([215, 70, 190]), (8, 8, 1))])))
    return str(path)


def _render_mesh(asset):
    cam = pyrt.Camera(position=(2.2, 1.6, 2.6), target=(0, 0.5, 0), fov=45, width=40, height=32, spp=2)
    scene = pyrt.Scene(cam, background=(0, 0, 0))
    asset.add_to_scene(scene, lights=False)
    scene.add_light(pyrt.DirectionalLight((-0.6, -0.5, -0.7), irradiance=3.0))
    return pyrt.render(scene, seed=5)


def test_obj_normal_map_gets_generated_tangents(tmp_path):
    """An OBJ whose MTL names a normal map (``norm``): its mesh gets vertex tangents as it is added to a scene (the
    same rule as glTF files without TANGENT), none without the map or with generate_tangents=False."""
    v, f, n, uv = _cylinder(segments=6, distort=0.3)
    Image.fromarray(np.tile(np.uint8([200, 128, 230]), (4, 4, 1))).save(tmp_path / "n.png")
    lines = ["mtllib m.mtl", "usemtl bumpy"] + [f"v {x} {y} {z}" for x, y, z in v] + \
        [f"vt {a} {b}" for a, b in uv] + [f"vn {x} {y} {z}" for x, y, z in n] + \
        [f"f {a + 1}/{a + 1}/{a + 1} {b + 1}/{b + 1}/{b + 1} {c + 1}/{c + 1}/{c + 1}" for a, b, c in f]
    (tmp_path / "c.obj").write_text("\n".join(lines) + "\n")
    for mtl, generate, has in (("newmtl bumpy\nKd 0.8 0.8 0.8\nnorm n.png\n", True, True),
                               ("newmtl bumpy\nKd 0.8 0.8 0.8\nnorm n.png\n", False, False),
                               ("newmtl bumpy\nKd 0.8 0.8 0.8\n", True, False)):
        (tmp_path / "m.mtl").write_text(mtl)
        scene = pyrt.Scene(pyrt.Camera(width=4, height=4))
        load_asset(str(tmp_path / "c.obj"), generate_tangents=generate).add_to_scene(scene, lights=False)
        assert (scene.meshes[0].tangents is not None) == has
        if has:
            t = scene.meshes[0].tangents
            assert np.all(np.abs(np.linalg.norm(t[:, :3], axis=1) - 1) < 1e-9) and np.all(np.abs(t[:, 3]) == 1)


def test_generated_tangents_do_not_depend_on_the_face_chunks(monkeypatch):
    from pyrt.geometry import tangents as T
    v, f, n, uv = _cylinder(segments=12, distort=0.4)
    whole = T.vertex_tangents(v, f, n, uv)
    monkeypatch.setattr(T, "FACE_CHUNK", 7)
    np.testing.assert_allclose(T.vertex_tangents(v, f, n, uv), whole, atol=1e-14)
