"""pyrt.load_dict: a scene from a dict is the scene from the same file; errors name the key; paths resolve."""
import copy
import pathlib
import subprocess
import sys
import tomllib

import numpy as np
import pytest

import pyrt

ROOT = pathlib.Path(__file__).resolve().parents[1]
ASSETS = ROOT / "assets"


def _small(spec, width=48, height=36):
    spec = copy.deepcopy(spec)
    spec.setdefault("camera", {}).update(width=width, height=height, spp=1)
    return spec


def _render(scene, options):
    return pyrt.render(scene, spp=1, threads=1, **options)


@pytest.mark.parametrize("name", ["default_scene.toml", "ibl_scene.toml"])
def test_dict_scene_renders_identically_to_the_toml_file(name, tmp_path):
    """The asset scenes, read as dicts (paths relative to assets/), give bit-identical pixels."""
    spec = _small(tomllib.loads((ASSETS / name).read_text()))
    scene_d, opts_d = pyrt.load_dict(spec, base_dir=ASSETS)
    # the same (reduced) scene as a file in a folder that links the assets, so relative paths resolve alike
    for entry in ASSETS.iterdir():
        (tmp_path / entry.name).symlink_to(entry)
    toml_path = tmp_path / f"small_{name}"
    toml_path.write_text(_to_toml(spec))
    scene_f, opts_f = pyrt.load_scene(toml_path)
    assert opts_d == opts_f
    a, b = _render(scene_d, opts_d), _render(scene_f, opts_f)
    assert a.dtype == b.dtype and a.shape == (36, 48, 3)
    assert np.array_equal(a, b)
    assert float(a.max()) > 0


def _to_toml(spec):
    """A minimal TOML writer for scene dicts (tables of scalars / lists, arrays of tables, inline tables)."""
    def value(v):
        if isinstance(v, bool):
            return "true" if v else "false"
        if isinstance(v, (int, float)):
            return repr(v)
        if isinstance(v, str):
            return '"' + v.replace("\\", "\\\\").replace('"', '\\"') + '"'
        if isinstance(v, (list, tuple)):
            return "[" + ", ".join(value(x) for x in v) + "]"
        if isinstance(v, dict):
            return "{" + ", ".join(f"{k} = {value(x)}" for k, x in v.items()) + "}"
        raise TypeError(v)

    lines = []
    for key, table in spec.items():
        if key == "materials":
            for name, mat in table.items():
                lines.append(f"[materials.{name}]")
                lines += [f"{k} = {value(v)}" for k, v in mat.items()]
        elif isinstance(table, list):
            for item in table:
                lines.append(f"[[{key}]]")
                lines += [f"{k} = {value(v)}" for k, v in item.items()]
        else:
            lines.append(f"[{key}]")
            lines += [f"{k} = {value(v)}" for k, v in table.items()]
    return "\n".join(lines) + "\n"


SIMPLE = {
    "camera": {"position": (0, 1, 4), "target": (0, 0.5, 0), "width": 32, "height": 24},
    "render": {"seed": 3, "integrator": {"max_depth": 4}},
    "materials": {"red": {"type": "lambert", "albedo": np.array([0.8, 0.2, 0.2])},
                  "chrome": {"type": "mirror", "reflectance": 0.9}},
    "meshes": [{"primitive": "sphere", "radius": 0.5, "translate": (0, 0.5, 0), "material": "red"},
               {"primitive": "plane", "size": 6, "material": "chrome"}],
    "lights": [{"type": "point", "position": (2, 3, 2), "intensity": 20.0}],
}


def test_load_dict_takes_tuples_and_arrays_and_leaves_the_spec_alone():
    before = copy.deepcopy(SIMPLE)
    scene, options = pyrt.load_dict(SIMPLE)
    assert options == {"seed": 3, "integrator": {"max_depth": 4}}
    assert isinstance(scene, pyrt.Scene) and len(scene.meshes) == 2 and len(scene.lights) == 1
    assert SIMPLE.keys() == before.keys() and SIMPLE["materials"]["red"].keys() == before["materials"]["red"].keys()
    assert SIMPLE["meshes"] == before["meshes"] and SIMPLE["lights"] == before["lights"]
    assert _render(scene, options).shape == (24, 32, 3)


def test_load_dict_is_public():
    assert pyrt.load_dict is pyrt.io.scene_file.load_dict
    assert {"load_dict", "load_asset", "Error"} <= set(pyrt.__all__)
    assert issubclass(pyrt.SceneFileError, pyrt.Error)


def _with(**changes):
    spec = copy.deepcopy(SIMPLE)
    for dotted, v in changes.items():
        *path, last = dotted.split("__")
        d = spec
        for k in path:
            d = d[int(k)] if isinstance(d, list) else d[k]
        d[int(last) if isinstance(d, list) else last] = v
    return spec


@pytest.mark.parametrize("spec, match", [
    (_with(materials__red={"type": "lamber"}), r"\[materials\.red\].*unknown material type 'lamber'"),
    (_with(materials__red={"albedo": 0.5}), r"\[materials\.red\] needs a 'type'"),
    (_with(materials__red={"type": "lambert", "albdo": 0.5}), r"\[materials\.red\].*albdo"),
    (_with(materials__red={"type": "lambert", "albedo": {"type": "wood"}}),
     r"\[materials\.red\]\.albedo.*texture type.*'wood'"),
    (_with(lights__0={"type": "laser"}), r"\[\[lights\]\] #0.*unknown light type 'laser'"),
    (_with(lights__0={"type": "point", "intensty": 1.0}), r"\[\[lights\]\] #0.*intensty"),
    (_with(camera__fvo=40), r"unknown key\(s\) \['fvo'\] in \[camera\]"),
    (_with(render__spp=4), r"unknown key\(s\) \['spp'\] in \[render\]"),
    (_with(meshes__0__colour=1), r"unknown key\(s\) \['colour'\] in \[\[meshes\]\] #0"),
    (_with(meshes__1__material="gold"), r"\[\[meshes\]\] #1: unknown material 'gold'"),
    (_with(meshes__0__primitive="torus"), r"\[\[meshes\]\] #0.*unknown primitive 'torus'"),
    (_with(environment={"type": "hdri"}), r"\[environment\] needs a 'type'.*latlong"),
    (_with(environment={"type": "constant", "colour": 1}), r"unknown key\(s\) \['colour'\] in \[environment\]"),
    (dict(SIMPLE, lens={}), r"unknown key\(s\) \['lens'\] in the top level"),
])
def test_load_dict_errors_name_the_key(spec, match):
    with pytest.raises(pyrt.SceneFileError, match=match):
        pyrt.load_dict(spec)


def test_load_dict_refuses_a_non_dict():
    with pytest.raises(pyrt.SceneFileError, match="the top level must be a table"):
        pyrt.load_dict([("camera", {})])


CRATE = {
    "camera": {"position": (0, 1, 4), "target": (0, 0.5, 0), "width": 32, "height": 24},
    "materials": {"wood": {"type": "lambert", "albedo": {"type": "image", "path": "models/crate_wood.png"}}},
    "meshes": [{"file": "models/crate.obj", "material": "wood"}],
    "lights": [{"type": "directional", "direction": (-1, -2, -1), "irradiance": 3.0}],
    "environment": {"type": "latlong", "file": "sky.exr"},
}


def test_relative_paths_resolve_against_base_dir(tmp_path, monkeypatch):
    monkeypatch.chdir(tmp_path)  # nothing resolves against the working directory when base_dir is given
    scene, options = pyrt.load_dict(CRATE, base_dir=ASSETS)
    assert len(scene.meshes) == 1 and scene.environment is not None
    img = _render(scene, options)
    assert np.isfinite(img).all() and float(img.max()) > 0
    # the same files given by absolute path render the same
    absolute = copy.deepcopy(CRATE)
    absolute["materials"]["wood"]["albedo"]["path"] = str(ASSETS / "models/crate_wood.png")
    absolute["meshes"][0]["file"] = str(ASSETS / "models/crate.obj")
    absolute["environment"]["file"] = str(ASSETS / "sky.exr")
    scene_abs, options_abs = pyrt.load_dict(absolute, base_dir=tmp_path)
    assert np.array_equal(_render(scene_abs, options_abs), img)


def test_relative_paths_default_to_the_working_directory(tmp_path, monkeypatch):
    monkeypatch.chdir(ASSETS)
    scene, _ = pyrt.load_dict(CRATE)
    assert len(scene.meshes) == 1
    monkeypatch.chdir(tmp_path)
    with pytest.raises(pyrt.SceneFileError, match=r"\[materials\.wood\]\.albedo: .*not found.*models/crate_wood.png"):
        pyrt.load_dict(CRATE)
    plain = dict(CRATE, materials={"wood": {"type": "lambert"}})
    with pytest.raises(pyrt.SceneFileError, match=r"\[\[meshes\]\] #0: mesh file not found: .*models/crate.obj"):
        pyrt.load_dict(plain)
    with pytest.raises(pyrt.SceneFileError, match=r"\[environment\]: file not found: .*sky.exr"):
        pyrt.load_dict(dict(plain, meshes=[]))


def test_load_asset_after_a_plain_import():
    """``import pyrt`` is enough for ``pyrt.load_asset`` and ``pyrt.io.assets`` (fresh interpreter)."""
    code = ("import pyrt; a = pyrt.load_asset('assets/models/crate.obj'); "
            "assert pyrt.io.assets.load_asset is pyrt.load_asset; "
            "assert issubclass(pyrt.AssetError, pyrt.Error); print(type(a).__name__)")
    r = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, cwd=ROOT)
    assert r.returncode == 0, r.stderr
    assert r.stdout.strip() == "Asset"


def test_shading_normal_fallback_is_a_render_key():
    spec = {"camera": {"width": 8, "height": 6}, "materials": {"m": {"type": "lambert"}},
            "meshes": [{"primitive": "sphere", "material": "m"}], "render": {"shading_normal_fallback": False}}
    scene, _ = pyrt.load_dict(spec)
    assert scene.shading_normal_fallback is False
    spec["render"]["shading_normal_fallback"] = True
    assert pyrt.load_dict(spec)[0].shading_normal_fallback is True
