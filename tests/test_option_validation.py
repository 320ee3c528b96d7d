"""Every scene-file and render option is checked whatever path would use it, with a message naming the key and
the file; a mirror-like microfacet material under the Whitted integrator is warned about."""
import warnings

import numpy as np
import pytest

import pyrt
from pyrt.io.scene_file import SceneFileError, load_scene
from pyrt.render.options import SmoothLobeWarning

BASE = """
[camera]
position = [0, 1, 4]
target = [0, 0.5, 0]
width = 8
height = 6
[materials.red]
type = "lambert"
albedo = [0.7, 0.1, 0.1]
"""
SPHERE = """
[[meshes]]
primitive = "sphere"
material = "red"
"""


def _scene_file(tmp_path, text):
    p = tmp_path / "s.toml"
    p.write_text(BASE + text)
    return str(p)


@pytest.mark.parametrize("text, message", [
    ("[render]\nglossy_samples = -1\n" + SPHERE, r"\[render\]: glossy_samples must be a positive integer, got -1"),
    ("[render]\nseed = \"abc\"\n" + SPHERE, r"\[render\]: seed must be an integer >= 0, got 'abc'"),
    ("[render]\nmax_depth = 2.5\n" + SPHERE, r"\[render\]: max_depth must be an integer >= 0, got 2.5"),
    ("[render]\nthroughput_cutoff = -1.0\n" + SPHERE, r"\[render\]: throughput_cutoff must be a finite number >= 0"),
    ("[render]\ntransparent_shadows = \"yes\"\n" + SPHERE, r"\[render\] transparent_shadows must be true or false"),
    (SPHERE + "radius = -0.5\n", r"\[\[meshes\]\] #0: radius must be a finite number > 0, got -0.5"),
    (SPHERE + "radius = 0\n", r"\[\[meshes\]\] #0: radius must be a finite number > 0, got 0"),
    (SPHERE + "subdivisions = -1\n", r"\[\[meshes\]\] #0: subdivisions must be an integer >= 0, got -1"),
    (SPHERE + "subdivisions = 40\n", r"\[\[meshes\]\] #0: subdivisions must be at most 8"),
    ("[[meshes]]\nprimitive = \"box\"\nmaterial = \"red\"\nextents = [1, -1, 1]\n", r"extents must be 3 finite numbers > 0"),
    ("[[meshes]]\nprimitive = \"cylinder\"\nmaterial = \"red\"\nsections = 2\n", r"sections must be an integer >= 3"),
    ("[meshes]\nprimitive = \"sphere\"\nmaterial = \"red\"\n",
     r"meshes must be an array of tables \(\[\[meshes\]\] in TOML.*got a single table \(\[meshes\] in TOML\)"),
    ("[lights]\ntype = \"point\"\n" + SPHERE, r"lights must be an array of tables"),
    ("[render]\noffset = \"bogus\"\n" + SPHERE, r"\[render\] offset must be one of \["),
    ("[render]\nmin_spp = 3\n" + SPHERE, r"\[render\] min_spp must be even"),
    ("[render]\ntarget_error = 0.0\n" + SPHERE, r"\[render\] target_error must be > 0"),
    ("[render]\nshading_normal_fallback = \"x\"\n" + SPHERE, r"shading_normal_fallback must be True or False"),
    (SPHERE + "crease_angle = -5\n", r"#0.*crease_angle must be a number of degrees in \[0, 180\], got -5"),
    (SPHERE + "crease_angle = nan\n", r"crease_angle must be a number of degrees in \[0, 180\], got nan"),
    (SPHERE + "name = 3\n", r"name must be a string, got int"),
    ("[[meshes]]\nprimitive = \"cylinder\"\nmaterial = \"red\"\nsections = 2.5\n",
     r"#0: sections must be an integer >= 3, got 2.5$"),
])
def test_a_bad_scene_file_key_names_the_key_and_the_file(tmp_path, text, message):
    path = _scene_file(tmp_path, text)
    with pytest.raises(SceneFileError, match=message) as e:
        load_scene(path)
    assert str(e.value).startswith(path)


@pytest.mark.parametrize("kw, message", [
    ({"seed": "abc"}, "seed must be an integer >= 0, got 'abc'"), ({"seed": -3}, "seed must be an integer >= 0"),
    ({"glossy_samples": -1}, r"Glossy: samples must be a positive integer, got -1 \(from the keywords glossy_samples\)"),
    ({"glossy_depth": -1}, r"Glossy: depth must be an integer >= 0.*glossy_depth"),
    ({"glossy_threshold": float("nan")}, r"Glossy: threshold must be a finite number.*glossy_threshold"),
    ({"glossy_samples": 0, "target_error": 0.1}, r"samples must be a positive integer.*glossy_samples"),
])
def test_render_options_are_checked_even_when_the_integrator_does_not_read_them(kw, message):
    scene, _ = pyrt.load_dict({"camera": {"width": 4, "height": 3},
                               "materials": {"m": {"type": "lambert"}},
                               "meshes": [{"primitive": "sphere", "material": "m"}]})
    with pytest.raises(pyrt.RenderError, match=message):
        pyrt.render(scene, integrator="whitted", **kw)


def test_camera_jitter_must_be_a_boolean():
    with pytest.raises(pyrt.Error, match="Camera: jitter must be True or False, got 'no'"):
        pyrt.Camera(jitter="no")


def _metal_scene(roughness):
    scene = pyrt.Scene(pyrt.Camera((0, 0, 3), (0, 0, 0), width=8, height=6), background=(0.5, 0.5, 0.5))
    scene.add_sphere((0, 0, 0), 1.0, pyrt.CookTorrance(metal="gold", roughness=roughness, name="polished"))
    scene.add_light(pyrt.PointLight((2, 2, 2), intensity=10.0))
    return scene


def test_a_mirror_like_microfacet_material_under_whitted_is_named_in_a_warning():
    with pytest.warns(SmoothLobeWarning, match=r"material CookTorrance\(polished\) is a mirror-like microfacet lobe "
                                               r"\(alpha 0 <= 0.01\).*integrator='glossy'"):
        pyrt.render(_metal_scene(0.0))
    with warnings.catch_warnings():
        warnings.simplefilter("error", SmoothLobeWarning)
        pyrt.render(_metal_scene(0.0), integrator="glossy")     # traced: no warning
        pyrt.render(_metal_scene(0.5))                           # a rough lobe: lit by light sampling, no warning
