"""OFF files (pyrt.io.assets.off): polygons into fans, ModelNet's glued header, COFF vertex and face colours,
NOFF normals, and errors naming the file and the line."""
import numpy as np
import pytest

from pyrt.io.assets import AssetError, load_asset
from pyrt.shaders import color

SQUARE_PYRAMID = """OFF
# a square pyramid: one quad and four triangles
5 5 0
0 0 0
1 0 0
1 1 0
0 1 0
0.5 0.5 1
4 3 2 1 0
3 0 1 4
3 1 2 4
3 2 3 4
3 3 0 4
"""


def _write(tmp_path, name, text):
    p = tmp_path / name
    p.write_text(text)
    return str(p)


def test_off_polygons_become_fans(tmp_path):
    a = load_asset(_write(tmp_path, "pyr.off", SQUARE_PYRAMID))
    (m,) = a.meshes
    assert a.format == "off" and m.vertices.shape == (5, 3)
    # the quad (3 2 1 0) -> (3 2 1), (3 1 0); then the four triangles as written
    assert m.faces.tolist() == [[3, 2, 1], [3, 1, 0], [0, 1, 4], [1, 2, 4], [2, 3, 4], [3, 0, 4]]
    assert m.colors is None and m.face_colors is None and m.normals is None and not a.warnings


def test_off_counts_glued_to_the_keyword_as_modelnet_writes_them(tmp_path):
    text = SQUARE_PYRAMID.replace("OFF\n# a square pyramid: one quad and four triangles\n5 5 0\n", "OFF5 5 0\n")
    a = load_asset(_write(tmp_path, "glued.off", text))
    b = load_asset(_write(tmp_path, "pyr.off", SQUARE_PYRAMID))
    assert np.array_equal(a.meshes[0].faces, b.meshes[0].faces)
    assert np.array_equal(a.meshes[0].vertices, b.meshes[0].vertices)


def test_coff_vertex_colours_are_linearised(tmp_path):
    text = ("COFF\n3 1 0\n"
            "0 0 0 255 0 0 255\n"
            "1 0 0 0 128 0 255\n"
            "0 1 0 0 0 64 255\n"
            "3 0 1 2\n")
    (m,) = load_asset(_write(tmp_path, "c.off", text)).meshes
    expect = color.srgb_decode(np.array([[255, 0, 0], [0, 128, 0], [0, 0, 64]]) / 255.0)
    assert np.allclose(m.colors, expect, rtol=0, atol=1e-12)
    # floats (a decimal point) are 0..1
    text_f = text.replace("255 0 0 255", "1.0 0 0 1").replace("0 128 0 255", "0 0.5 0 1").replace("0 0 64 255",
                                                                                                 "0 0 0.25 1")
    (mf,) = load_asset(_write(tmp_path, "cf.off", text_f)).meshes
    assert np.allclose(mf.colors, color.srgb_decode(np.array([[1, 0, 0], [0, 0.5, 0], [0, 0, 0.25]])), atol=1e-12)


def test_off_face_colours_follow_their_polygon_into_every_triangle(tmp_path):
    text = SQUARE_PYRAMID.replace("4 3 2 1 0", "4 3 2 1 0 255 255 255")
    for k, c in zip(range(4), ("255 0 0", "0 255 0", "0 0 255", "10 20 30")):
        text = text.replace(f"3 {k} {(k + 1) % 4} 4\n", f"3 {k} {(k + 1) % 4} 4 {c}\n")
    (m,) = load_asset(_write(tmp_path, "fc.off", text)).meshes
    rgb = np.array([[255, 255, 255]] * 2 + [[255, 0, 0], [0, 255, 0], [0, 0, 255], [10, 20, 30]]) / 255.0
    assert m.face_colors.shape == (6, 3)
    assert np.allclose(m.face_colors, color.srgb_decode(rgb), atol=1e-12)


def test_off_triangles_with_face_colours_keep_their_order_and_colours(tmp_path):
    text = "OFF\n3 2 0\n0 0 0\n1 0 0\n0 1 0\n3 0 1 2 255 0 0\n3 0 2 1 0 0 255\n"
    (m,) = load_asset(_write(tmp_path, "t.off", text)).meshes
    assert m.faces.tolist() == [[0, 1, 2], [0, 2, 1]]
    assert np.allclose(m.face_colors, [[1, 0, 0], [0, 0, 1]])


def test_noff_normals_are_used(tmp_path):
    text = "NOFF\n3 1 0\n0 0 0 0 0 2\n1 0 0 0 0 1\n0 1 0 0 0 1\n3 0 1 2\n"
    (m,) = load_asset(_write(tmp_path, "n.off", text)).meshes
    assert np.allclose(m.normals, [[0, 0, 1]] * 3)


def test_off_short_polygons_and_colour_map_indices_are_warnings(tmp_path):
    text = "OFF\n4 3 0\n0 0 0\n1 0 0\n0 1 0\n0 0 1\n2 0 1 7\n3 0 1 2 7\n3 0 1 3 7\n"
    a = load_asset(_write(tmp_path, "w.off", text))
    assert a.meshes[0].faces.tolist() == [[0, 1, 2], [0, 1, 3]]
    assert any("fewer than 3 vertices" in w for w in a.warnings)
    assert any("colour-map indices" in w for w in a.warnings)
    assert a.meshes[0].face_colors is None


@pytest.mark.parametrize("text, message", [
    ("PLY\n3 1 0\n", "not an OFF header"),
    ("OFF\n3 1 0\n0 0 0\n1 0 0\n", "truncated"),
    ("OFF\n3 1 0\n0 0 0\n1 0 0\n0 1 0\n3 0 1 3\n", "line 6: face '3 0 1 3' refers to a vertex that does not exist"),
    ("OFF\n4 2 0\n0 0 0\n1 0 0\n0 1 0\n0 0 1\n3 0 1 2\n4 0 1 2 9\n", "line 8: face '4 0 1 2 9' refers"),
    ("OFF\n3 1 0\n0 0 0\n1 x 0\n0 1 0\n3 0 1 2\n", "line 4: vertex"),
    ("OFF\n3 1 0\n0 0 0\n1 nan 0\n0 1 0\n3 0 1 2\n", "line 4: vertex 1 is not finite"),
    ("OFF\n3 1 0\n0 0 0\n1 0 0\n0 1 0\n4 0 1 2\n", "announces 4 vertices but lists 3"),
    ("OFF\n3 1 0\n0 0 0\n1 0 0\n0 1 0\n2 0 1\n", "no faces with 3 or more vertices"),
    ("4OFF\n3 1 0\n", "4D and n-dimensional"),
    ("OFF BINARY\n", "binary OFF"),
    ("# only a comment\n", "empty OFF file"),
])
def test_broken_off_files_name_the_file_and_the_line(tmp_path, text, message):
    path = _write(tmp_path, "bad.off", text)
    with pytest.raises(AssetError, match=message) as exc:
        load_asset(path)
    assert path in str(exc.value)


def test_the_previewer_renders_an_off_file_with_face_colours(tmp_path):
    from pyrt.apps import preview as P
    text = SQUARE_PYRAMID.replace("4 3 2 1 0", "4 3 2 1 0 200 200 200")
    for k in range(4):
        text = text.replace(f"3 {k} {(k + 1) % 4} 4\n", f"3 {k} {(k + 1) % 4} 4 255 0 0\n")
    res = P.render_preview(_write(tmp_path, "red.off", text), P.PreviewOptions(width=48, height=36, spp=1,
                                                                             azimuth=0, elevation=20))
    img = res.images[0]
    assert np.all(np.isfinite(img))
    centre = img[14:22, 20:28].reshape(-1, 3).mean(axis=0)    # a red side of the pyramid faces the camera
    assert centre[0] > 3 * max(centre[1], centre[2]) > 0
