"""pyrt imports trimesh only where it needs it (OBJ / PLY / STL files, spheres, boxes, area-light meshes): a glTF
preview never does, and the matrices pyrt builds itself (pyrt.core.transforms) are bit-identical to trimesh's."""
import subprocess
import sys
import textwrap

import numpy as np
import pytest
import trimesh

import pyrt
from pyrt.core import transforms as T


def test_matrices_are_bit_identical_to_trimeshs():
    rng = np.random.default_rng(5)
    for _ in range(300):
        angle, axis = rng.normal() * 4, rng.normal(size=3)
        np.testing.assert_array_equal(T.rotation_matrix(angle, axis),
                                      trimesh.transformations.rotation_matrix(angle, axis))
        q = rng.normal(size=4)
        np.testing.assert_array_equal(T.quaternion_matrix(q), trimesh.transformations.quaternion_matrix(q))
        t = rng.normal(size=3)
        np.testing.assert_array_equal(T.translation_matrix(t), trimesh.transformations.translation_matrix(t))
        a, b = rng.normal(size=3), rng.normal(size=3)
        np.testing.assert_array_equal(T.align_vectors(a, b), trimesh.geometry.align_vectors(a, b))
    np.testing.assert_array_equal(T.quaternion_matrix([0, 0, 0, 0]), np.eye(4))
    with pytest.raises(ValueError, match=r"\(3,\)"):
        T.align_vectors([1, 0], [0, 1, 0])


def test_a_gltf_preview_does_not_import_trimesh(tmp_path):
    code = textwrap.dedent(f"""
        import sys
        import numpy as np
        from pyrt.apps.preview.cli import main
        from pyrt.io.assets import pack_glb
        assert "trimesh" not in sys.modules, "import"
        v = np.array([[0, 0, 0], [1, 0, 0], [1, 1, 0], [0, 1, 0]], dtype=np.float32)
        f = np.array([0, 1, 2, 0, 2, 3], dtype=np.uint16)
        gltf = {{"asset": {{"version": "2.0"}}, "scenes": [{{"nodes": [0]}}], "scene": 0,
                 "nodes": [{{"mesh": 0, "rotation": [0, 0.3826834, 0, 0.9238795]}}],
                 "meshes": [{{"primitives": [{{"attributes": {{"POSITION": 0}}, "indices": 1}}]}}],
                 "buffers": [{{"byteLength": 60}}],
                 "bufferViews": [{{"buffer": 0, "byteOffset": 0, "byteLength": 48}},
                                 {{"buffer": 0, "byteOffset": 48, "byteLength": 12}}],
                 "accessors": [{{"bufferView": 0, "componentType": 5126, "count": 4, "type": "VEC3",
                                "min": [0, 0, 0], "max": [1, 1, 0]}},
                               {{"bufferView": 1, "componentType": 5123, "count": 6, "type": "SCALAR"}}]}}
        open(r"{tmp_path / 'quad.glb'}", "wb").write(pack_glb(gltf, v.tobytes() + f.tobytes()))
        rc = main([r"{tmp_path / 'quad.glb'}", "-o", r"{tmp_path / 'quad.png'}", "--width", "32", "--height", "24",
                   "--quiet"])
        assert rc in (0, None), rc
        assert "trimesh" not in sys.modules, "preview"
    """)
    out = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True)
    assert out.returncode == 0, out.stderr[-2000:]
    assert (tmp_path / "quad.png").stat().st_size > 0


def test_trimesh_input_still_works_and_a_pair_takes_its_uvs():
    scene = pyrt.Scene(pyrt.Camera(position=(0, 0, 3), target=(0, 0, 0), width=8, height=8))
    tm = trimesh.creation.box(extents=(1, 1, 1))
    scene.add_mesh(tm, pyrt.Lambert(0.5), smooth=False)
    v = np.array([[0, 0, 0], [1, 0, 0], [1, 1, 0.0]])
    uv = np.array([[0, 0], [1, 0], [1, 1.0]])
    k = scene.add_mesh((v, [[0, 1, 2]]), pyrt.Lambert(0.5), uv=uv, smooth=False)
    np.testing.assert_array_equal(scene.meshes[k].uv, uv)
    with pytest.raises(pyrt.SceneError, match="expected trimesh.Trimesh"):
        scene.add_mesh(object(), pyrt.Lambert(0.5))
    # whole-number float indices are indices (a Trimesh took them so); fractional ones are refused
    k = scene.add_mesh((v, np.array([[0.0, 1.0, 2.0]])), pyrt.Lambert(0.5), smooth=False)
    np.testing.assert_array_equal(scene.meshes[k].faces, [[0, 1, 2]])
    with pytest.raises(pyrt.GeometryError, match="integer"):
        scene.add_mesh((v, np.array([[0.0, 1.5, 2.0]])), pyrt.Lambert(0.5), smooth=False)
