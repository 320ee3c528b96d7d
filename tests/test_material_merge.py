"""glTF materials that differ only in their base colour factor are merged into one (pyrt.io.assets.merge): the plan
groups exactly those, and a render of the merged scene equals the unmerged one (a deterministic Whitted render: the
products factor x texture x colour are the same numbers up to the last bit)."""
import numpy as np
import trimesh
from trimesh.visual.material import PBRMaterial

import pyrt
from pyrt.io.assets import load_asset
from pyrt.io.assets.common import PBRParams
from pyrt.io.assets.merge import merge_key, merge_plan


def _params(**kw):
    p = PBRParams(name=kw.pop("name", "m"))
    for k, v in kw.items():
        setattr(p, k, np.asarray(v, dtype=np.float64) if isinstance(v, (list, tuple)) else v)
    return p


def test_plan_merges_only_materials_that_differ_in_base_colour():
    tex = object()
    mats = [_params(base_color_factor=[1, 0, 0, 1]), _params(base_color_factor=[0, 1, 0, 0.5]),   # opaque: alpha unread
            _params(base_color_factor=[0, 0, 1, 1], roughness_factor=0.3),                        # other roughness
            _params(base_color_factor=[1, 1, 0, 0.5], alpha_mode="BLEND"),
            _params(base_color_factor=[1, 0, 1, 0.25], alpha_mode="BLEND"),                       # other alpha
            _params(base_color_factor=[1, 1, 1, 0.5], alpha_mode="BLEND", name="x"),
            _params(base_color_factor=[0.2, 0.2, 0.2, 1], emissive_texture=tex),
            _params(base_color_factor=[0.3, 0.3, 0.3, 1], emissive_texture=tex),                  # the same texture
            _params(base_color_factor=[0.4, 0.4, 0.4, 1], emissive_texture=object())]             # another one
    plan = merge_plan(mats, range(len(mats)))
    assert sorted(plan) == [0, 1, 3, 5, 6, 7]
    assert plan[0][1] == plan[1][1] and plan[3][1] == plan[5][1] and plan[6][1] == plan[7][1]
    assert len({plan[i][1] for i in plan}) == 3
    merged, _, factor = plan[1]
    np.testing.assert_array_equal(factor, [0, 1, 0])
    np.testing.assert_array_equal(merged.base_color_factor, [1, 1, 1, 1])
    assert merged.name == "m (+1 merged)" and merged is plan[0][0]
    np.testing.assert_array_equal(plan[5][0].base_color_factor, [1, 1, 1, 0.5])
    assert merge_plan(mats, [0, 2]) == {}                       # only the used materials count
    assert merge_key(mats[0]) == merge_key(mats[1]) != merge_key(mats[2])


def _parts_file(tmp_path, colors, roughness=0.5):
    s = trimesh.Scene()
    for i, c in enumerate(colors):
        b = trimesh.creation.box(extents=(0.4, 0.4, 0.4))
        b.visual = trimesh.visual.TextureVisuals(material=PBRMaterial(
            baseColorFactor=list(c) + [255], metallicFactor=0.0, roughnessFactor=roughness, name=f"part{i}"))
        s.add_geometry(b, node_name=f"n{i}", geom_name=f"g{i}",
                       transform=trimesh.transformations.translation_matrix((0.6 * i - 0.6, 0.2, 0.1 * i)))
    path = tmp_path / "parts.glb"
    s.export(str(path))
    return str(path)


def _render(asset):
    cam = pyrt.Camera(position=(0.3, 1.2, 2.5), target=(0, 0.2, 0), fov=45, width=48, height=36, spp=2)
    scene = pyrt.Scene(cam, background=(0.1, 0.1, 0.1))
    asset.add_to_scene(scene)
    scene.add_plane((0, 0, 0), 4.0, pyrt.Lambert(albedo=0.5))
    scene.add_light(pyrt.PointLight((1, 3, 2), intensity=10.0))
    scene.add_light(pyrt.DirectionalLight((-0.3, -1, -0.5), irradiance=1.0))
    # one path for both sides (a merged material reads vertex colours, which only the NumPy path does): the images
    # are then equal to rounding, the same random numbers on the same hits
    img = pyrt.render(scene, seed=3, progress=False, backend="numpy")
    return img, len({id(m) for m in scene.materials})


def test_merged_render_equals_the_unmerged_one(tmp_path):
    path = _parts_file(tmp_path, [(200, 30, 30), (30, 200, 30), (30, 30, 200)])
    merged = load_asset(path)
    separate = load_asset(path)
    separate.merge_materials = False
    a, n_a = _render(merged)
    b, n_b = _render(separate)
    assert n_b - n_a == 2                  # three part materials became one
    assert a.mean() > 0.01
    np.testing.assert_allclose(a, b, rtol=1e-12, atol=1e-15)


def _obj_parts(tmp_path, kds, ks=0.1):
    lines, mtl = ["mtllib parts.mtl"], []
    for i, kd in enumerate(kds):
        x = 0.6 * i - 0.6
        mtl += [f"newmtl part{i}", "Kd " + " ".join(map(str, kd)), f"Ks {ks} {ks} {ks}", "Ns 40"]
        b = trimesh.creation.box(extents=(0.4, 0.4, 0.4))
        base = len(lines) and sum(1 for ln in lines if ln.startswith("v "))
        lines += [f"v {v[0] + x} {v[1] + 0.2} {v[2]}" for v in b.vertices]
        lines += [f"usemtl part{i}"] + [f"f {a + 1 + base} {c + 1 + base} {d + 1 + base}" for a, c, d in b.faces]
    (tmp_path / "parts.mtl").write_text("\n".join(mtl) + "\n")
    (tmp_path / "parts.obj").write_text("\n".join(lines) + "\n")
    return str(tmp_path / "parts.obj")


def test_obj_materials_that_differ_in_kd_merge_and_render_the_same(tmp_path):
    path = _obj_parts(tmp_path, [(0.7, 0.1, 0.1), (0.1, 0.6, 0.1), (0.2, 0.2, 0.8)])
    merged = load_asset(path)
    assert len(merge_plan(merged.materials, range(3))) == 3
    separate = load_asset(path)
    separate.merge_materials = False
    a, n_a = _render(merged)
    b, n_b = _render(separate)
    assert n_b - n_a == 2 and a.mean() > 0.01
    np.testing.assert_allclose(a, b, rtol=1e-12, atol=1e-15)


def test_obj_materials_whose_ks_pyrt_scales_are_not_merged(tmp_path):
    # Kd 0.95 + Ks 0.2 > 1: pyrt scales that Ks down, by a factor the merged material would not share
    mats = load_asset(_obj_parts(tmp_path, [(0.95, 0.1, 0.1), (0.1, 0.6, 0.1)], ks=0.2)).materials
    assert merge_plan(mats, range(2)) == {}
    # the scaled member stays apart, the unscaled ones merge
    mats = load_asset(_obj_parts(tmp_path, [(0.7, 0.1, 0.1), (0.1, 0.6, 0.1), (0.1, 0.1, 0.9)], ks=0.2)).materials
    assert sorted(merge_plan(mats, range(3))) == [0, 1]
    # two members scaled by the same factor (the same scaled Ks) still do not merge: the factor depends on Kd
    mats = load_asset(_obj_parts(tmp_path, [(0.9, 0.1, 0.1), (0.1, 0.9, 0.1)], ks=0.2)).materials
    assert merge_plan(mats, range(2)) == {}
    mats = load_asset(_obj_parts(tmp_path, [(0.75, 0.1, 0.1), (0.1, 0.75, 0.1)], ks=0.2)).materials
    assert len(merge_plan(mats, range(2))) == 2


def test_many_instances_are_joined_per_material_and_render_the_same(tmp_path, monkeypatch):
    """Models of at least FLATTEN_MIN_INSTANCES instances add one world-space mesh per material (and attribute set):
    the same image as one scene mesh per instance, mirrored instances (negative scale) included."""
    from pyrt.io.assets import asset as A
    rng = np.random.default_rng(1)
    s = trimesh.Scene()
    for i in range(70):
        b = trimesh.creation.icosphere(subdivisions=1, radius=0.08) if i % 2 else trimesh.creation.box(extents=(0.1,) * 3)
        b.visual = trimesh.visual.TextureVisuals(material=PBRMaterial(
            baseColorFactor=rng.integers(0, 255, 3).tolist() + [255], metallicFactor=0.0,
            roughnessFactor=0.7 if i % 3 else 0.5, name=f"m{i}"))
        t = trimesh.transformations.translation_matrix(rng.uniform(-1, 1, 3) * (1, 0.3, 1) + (0, 0.4, 0))
        if i % 5 == 0:
            t = t @ np.diag([-1.0, 1.0, 1.0, 1.0])        # a mirrored instance: its winding must be reversed
        s.add_geometry(b, node_name=f"n{i}", geom_name=f"g{i}", transform=t)
    path = str(tmp_path / "many.glb")
    s.export(path)
    joined, n_joined = _render(load_asset(path))
    monkeypatch.setattr(A, "FLATTEN_MIN_INSTANCES", 10 ** 9)
    separate, n_sep = _render(load_asset(path))
    assert joined.mean() > 0.01
    np.testing.assert_array_equal(joined, separate)
    cam = pyrt.Camera(position=(0, 1, 3), target=(0, 0.3, 0), width=8, height=8)
    scene = pyrt.Scene(cam)
    monkeypatch.setattr(A, "FLATTEN_MIN_INSTANCES", 64)
    added = load_asset(path).add_to_scene(scene)
    assert len(added) == 2                     # two roughnesses, each one joined mesh of its merged material
    assert "joined" in scene.meshes[added[0]].name
