"""glTF's pose without animations (pyrt.io.assets.gltf_pose): morph targets at their default weights, skins at their
joints' transforms. Exact values on generated files: positions are sums of known vectors, joint matrices products of
known rotations and translations."""
import math

import numpy as np
import pytest

from pyrt.io.assets import AssetError, load_asset, pack_glb
from pyrt.io.assets.gltf_pose import all_node_transforms, skin

TRI = np.array([[0, 0, 0], [1, 0, 0], [0, 1, 0]], dtype=np.float32)
NRM = np.array([[0, 0, 1]] * 3, dtype=np.float32)


class _Builder:
    """A glTF header and its binary buffer, one accessor per array."""

    def __init__(self):
        self.blob = bytearray()
        self.h = {"asset": {"version": "2.0"}, "buffers": [], "bufferViews": [], "accessors": []}

    def acc(self, arr, type_, ctype=5126, normalized=False):
        arr = np.ascontiguousarray(arr)
        self.blob += b"\0" * (-len(self.blob) % 4)
        self.h["bufferViews"].append({"buffer": 0, "byteOffset": len(self.blob), "byteLength": arr.nbytes})
        self.blob += arr.tobytes()
        a = {"bufferView": len(self.h["bufferViews"]) - 1, "componentType": ctype, "count": int(arr.shape[0]),
             "type": type_}
        if normalized:
            a["normalized"] = True
        if type_ == "VEC3" and ctype == 5126:
            a["min"], a["max"] = arr.min(axis=0).tolist(), arr.max(axis=0).tolist()
        self.h["accessors"].append(a)
        return len(self.h["accessors"]) - 1

    def write(self, path):
        self.h["buffers"] = [{"byteLength": len(self.blob)}]
        path.write_bytes(pack_glb(self.h, bytes(self.blob)))
        return str(path)


def _morph_file(tmp_path, node_weights=None, mesh_weights=(0.25, 0.5)):
    b = _Builder()
    t0 = np.array([[0, 0, 1]] * 3, dtype=np.float32)              # lifts the triangle along +z
    t1 = np.array([[1, 0, 0], [0, 0, 0], [0, 0, 0]], dtype=np.float32)   # moves vertex 0 along +x
    n1 = np.array([[1, 0, 0]] * 3, dtype=np.float32)               # tilts the normals toward +x
    prim = {"attributes": {"POSITION": b.acc(TRI, "VEC3"), "NORMAL": b.acc(NRM, "VEC3")},
            "targets": [{"POSITION": b.acc(t0, "VEC3")}, {"POSITION": b.acc(t1, "VEC3"), "NORMAL": b.acc(n1, "VEC3")}]}
    mesh = {"primitives": [prim]}
    if mesh_weights is not None:
        mesh["weights"] = list(mesh_weights)
    node = {"mesh": 0}
    if node_weights is not None:
        node["weights"] = list(node_weights)
    b.h.update(meshes=[mesh], nodes=[node], scenes=[{"nodes": [0]}], scene=0)
    return b.write(tmp_path / "morph.glb")


def _posed(asset):
    (inst,) = asset.instances
    m = asset.meshes[inst.mesh]
    v = np.c_[m.vertices, np.ones(len(m.vertices))] @ inst.world_from_object.T
    return v[:, :3], m


def test_morph_targets_at_the_mesh_weights(tmp_path):
    a = load_asset(_morph_file(tmp_path))
    v, m = _posed(a)
    want = TRI + 0.25 * np.array([0, 0, 1]) + 0.5 * np.array([[1, 0, 0], [0, 0, 0], [0, 0, 0]])
    np.testing.assert_allclose(v, want, atol=1e-12)
    n = np.array([0.5, 0, 1]) / math.hypot(0.5, 1)
    np.testing.assert_allclose(m.normals, np.tile(n, (3, 1)), atol=1e-12)
    assert not [w for w in a.warnings if "morph" in w]


def test_node_weights_override_the_mesh_weights_and_zero_is_the_base(tmp_path):
    v, _ = _posed(load_asset(_morph_file(tmp_path, node_weights=(1.0, 0.0))))
    np.testing.assert_allclose(v, TRI + [0, 0, 1], atol=1e-12)
    v, m = _posed(load_asset(_morph_file(tmp_path, mesh_weights=None)))
    np.testing.assert_allclose(v, TRI, atol=0)
    np.testing.assert_allclose(m.normals, NRM, atol=0)


def test_wrong_number_of_weights_is_an_error_naming_the_mesh(tmp_path):
    with pytest.raises(AssetError, match=r"mesh 0 .*3 morph weights for 2 targets"):
        load_asset(_morph_file(tmp_path, mesh_weights=(0.1, 0.2, 0.3)))


def _quat_z(deg):
    h = math.radians(deg) / 2
    return [0.0, 0.0, math.sin(h), math.cos(h)]


def _skin_file(tmp_path, *, ibm=True, mesh_node_matrix=True, weights_u8=False):
    """Two joints: j0 at the origin, j1 a child of j0 at (2, 0, 0) rotated 90 degrees about z. Vertex 0 follows j0,
    vertex 1 j1, vertex 2 half each. The mesh node has a transform of its own, which glTF says to ignore."""
    b = _Builder()
    pos = np.array([[0, 0, 0], [2, 1, 0], [1, 1, 0]], dtype=np.float32)
    joints = np.array([[0, 0, 0, 0], [1, 0, 0, 0], [0, 1, 0, 0]], dtype=np.uint8)
    w = np.array([[1, 0, 0, 0], [1, 0, 0, 0], [0.5, 0.5, 0, 0]], dtype=np.float32)
    wacc = b.acc((w * 255).round().astype(np.uint8), "VEC4", 5121, normalized=True) if weights_u8 else b.acc(w, "VEC4")
    prim = {"attributes": {"POSITION": b.acc(pos, "VEC3"), "NORMAL": b.acc(NRM, "VEC3"),
                           "JOINTS_0": b.acc(joints, "VEC4", 5121), "WEIGHTS_0": wacc}}
    skin = {"joints": [1, 2]}
    if ibm:   # bind pose: j0 at the origin, j1 at (2, 0, 0) unrotated -> inverse bind = translate(-2, 0, 0)
        m = np.stack([np.eye(4), np.eye(4)]).astype(np.float32)
        m[1, :3, 3] = (-2, 0, 0)
        skin["inverseBindMatrices"] = b.acc(m.transpose(0, 2, 1).reshape(2, 16), "MAT4")
    mesh_node = {"mesh": 0, "skin": 0}
    if mesh_node_matrix:
        mesh_node["translation"] = [100.0, 0.0, 0.0]
    nodes = [mesh_node, {"children": [2]}, {"translation": [2.0, 0.0, 0.0], "rotation": _quat_z(90)}]
    b.h.update(meshes=[{"primitives": [prim]}], nodes=nodes, skins=[skin], scenes=[{"nodes": [0, 1]}], scene=0)
    return b.write(tmp_path / "skin.glb")


def test_skin_poses_vertices_by_the_joints_and_ignores_the_mesh_node(tmp_path):
    a = load_asset(_skin_file(tmp_path))
    v, m = _posed(a)
    # vertex 1 = (2, 1, 0) is (0, 1, 0) from j1's bind position; rotated 90 about z: (-1, 0, 0); plus j1 (2, 0, 0)
    R = np.array([[0, -1, 0], [1, 0, 0], [0, 0, 1]])
    v2 = 0.5 * np.array([1, 1, 0]) + 0.5 * (R @ (np.array([1, 1, 0]) - [2, 0, 0]) + [2, 0, 0])
    np.testing.assert_allclose(v, [[0, 0, 0], [1, 0, 0], v2], atol=1e-6)
    np.testing.assert_allclose(m.normals, NRM, atol=1e-6)      # rotations about z keep the z normal
    assert not any("skin" in w for w in a.warnings)


def test_normalised_integer_weights_and_no_inverse_bind_matrices(tmp_path):
    v, _ = _posed(load_asset(_skin_file(tmp_path, ibm=False, weights_u8=True)))
    # without inverse bind matrices the joints' world matrices apply to the mesh coordinates as they are
    R = np.array([[0, -1, 0], [1, 0, 0], [0, 0, 1]])
    np.testing.assert_allclose(v[1], R @ [2, 1, 0] + [2, 0, 0], atol=1e-6)
    np.testing.assert_allclose(v[2], 0.5 * np.array([1, 1, 0]) + 0.5 * (R @ [1, 1, 0] + [2, 0, 0]), atol=1e-2)


def test_skin_mirrors_flip_the_winding_and_normals_follow_the_inverse_transpose():
    pos = np.array([[0.0, 0, 0], [1, 0, 0], [0, 1, 0]])
    nrm = np.array([[0.0, 0, 1]] * 3)
    faces = np.array([[0, 1, 2]])
    shear = np.eye(4)
    shear[0, 1] = 1.0           # x += y: a shear, whose normals are not the transformed normals
    mirror = np.diag([-1.0, 1, 1, 1])
    jm = np.stack([shear, mirror])
    n_in = np.array([[1.0, 0, 0]] * 3)
    _, n_out, f = skin(pos, n_in, faces, np.zeros((3, 1)), np.ones((3, 1)), jm, "test", [])
    # the plane x = 0 goes to x = y: its normal (1, 0, 0) to (1, -1, 0) / sqrt 2 (the inverse transpose), not to the
    # sheared vector (1, 0, 0)
    np.testing.assert_allclose(n_out, np.tile([1, -1, 0], (3, 1)) / math.sqrt(2), atol=1e-12)
    np.testing.assert_array_equal(f, faces)
    p, n_out, f = skin(pos, nrm, faces, np.ones((3, 1)), np.ones((3, 1)), jm, "test", [])
    np.testing.assert_allclose(p, pos * [-1, 1, 1], atol=0)
    np.testing.assert_allclose(n_out, nrm, atol=0)       # a mirror in x keeps the z normal
    np.testing.assert_array_equal(f, [[0, 2, 1]])        # and reverses the winding


def test_unweighted_vertices_stay_and_are_named():
    warnings = []
    p, _, _ = skin(np.eye(3), None, np.array([[0, 1, 2]]), np.zeros((3, 1)), np.array([[1.0], [0.0], [1.0]]),
                   np.stack([np.diag([2.0, 2, 2, 1])]), "node 7", warnings)
    np.testing.assert_allclose(p, [[2, 0, 0], [0, 1, 0], [0, 0, 2]])
    assert warnings and "node 7" in warnings[0] and "1 of 3" in warnings[0]


def test_joint_outside_the_scene_and_bad_joint_index(tmp_path):
    b = _Builder()
    prim = {"attributes": {"POSITION": b.acc(TRI, "VEC3"), "JOINTS_0": b.acc(np.array([[0, 0, 0, 0], [0, 0, 0, 0], [3, 0, 0, 0]], np.uint8), "VEC4", 5121),
                           "WEIGHTS_0": b.acc(np.array([[1, 0, 0, 0]] * 3, np.float32), "VEC4")}}
    nodes = [{"mesh": 0, "skin": 0}, {"translation": [0.0, 5.0, 0.0]}]     # the joint is not in the scene
    b.h.update(meshes=[{"primitives": [prim]}], nodes=nodes, skins=[{"joints": [1]}], scenes=[{"nodes": [0]}])
    with pytest.raises(AssetError, match=r"node 0 .*joint 3, the skin has 1"):
        load_asset(b.write(tmp_path / "bad.glb"))


def test_all_node_transforms_follows_parents_and_refuses_cycles():
    nodes = [{"children": [1], "translation": [1.0, 0, 0]}, {"translation": [0, 2.0, 0]}, {"scale": [3.0, 3, 3]}]
    local = {0: np.eye(4), 1: np.eye(4), 2: np.diag([3.0, 3, 3, 1])}
    local[0][:3, 3] = (1, 0, 0)
    local[1][:3, 3] = (0, 2, 0)
    w = all_node_transforms({"nodes": nodes}, lambda n: local[nodes.index(n)])
    np.testing.assert_allclose(w[1][:3, 3], [1, 2, 0])
    np.testing.assert_allclose(w[2], local[2])
    with pytest.raises(AssetError, match="cycle|two parents"):
        all_node_transforms({"nodes": [{"children": [1]}, {"children": [0]}]}, lambda n: np.eye(4))
