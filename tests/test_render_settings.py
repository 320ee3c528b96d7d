"""The render options as objects (pyrt.render.settings): integrator objects or ``{"type": ...}`` dicts with their own
validated parameters, sampling / output / execution groups, the same in Python, scene dicts and the command line;
the flat keywords of earlier releases still render the same image, with a DeprecationWarning naming the new
spelling."""
import argparse
import warnings

import numpy as np
import pytest

import pyrt
from pyrt.apps.cli import integrator_spec
from pyrt.render import settings

NUMPY = pyrt.Execution(threads=1, backend="numpy", progress=False)


def _scene():
    cam = pyrt.Camera(position=(0, 1, 4), target=(0, 0.5, 0), fov=40, width=24, height=16, spp=2)
    s = pyrt.Scene(cam, background=(0.2, 0.3, 0.4))
    s.add_plane((0, 0, 0), 4.0, pyrt.Lambert(albedo=pyrt.CheckerTexture(0.2, 0.8, scale=8)))
    s.add_sphere((-0.6, 0.5, 0), 0.5, pyrt.Glass(ior=1.5), subdivisions=2)
    s.add_sphere((0.6, 0.5, 0), 0.5, pyrt.CookTorrance(metal="gold", roughness=0.3), subdivisions=2)
    s.add_light(pyrt.PointLight((2, 3, 2), intensity=20.0))
    return s


def _new_spelling_quietly(**kw):
    with warnings.catch_warnings():
        warnings.simplefilter("error")
        return pyrt.render_full(_scene(), **kw)


def test_old_keywords_render_the_same_image_with_a_warning_naming_the_new_spelling():
    new = _new_spelling_quietly(spp=2, seed=3, integrator=pyrt.Glossy(samples=2, max_depth=3),
                                output=pyrt.Output(aovs=True), execution=NUMPY)
    with pytest.warns(DeprecationWarning) as rec:
        old = pyrt.render_full(_scene(), spp=2, seed=3, integrator="glossy", glossy_samples=2, max_depth=3,
                               aovs=True, threads=1, backend="numpy", progress=False)
    np.testing.assert_array_equal(old.image, new.image)
    np.testing.assert_array_equal(old.aovs["depth"], new.aovs["depth"])
    msg = str(rec[0].message)
    assert msg.startswith(settings.DEPRECATED)
    assert "integrator=pyrt.Glossy(samples=2, max_depth=3)" in msg
    assert "output=pyrt.Output(aovs=True)" in msg and "execution=pyrt.Execution(threads=1" in msg
    assert rec[0].filename == __file__           # the warning points at the caller's line


def test_pyrt_render_with_spp_and_seed_does_not_warn():
    with warnings.catch_warnings():
        warnings.simplefilter("error")
        img = pyrt.render(_scene(), spp=1, seed=2, execution=NUMPY)
    assert img.shape == (16, 24, 3)


def test_dict_spelling_equals_object_spelling():
    a = _new_spelling_quietly(spp=2, integrator={"type": "glossy", "samples": 2, "clamp": 4.0},
                              sampling={"sampler": "independent"}, execution={"threads": 1, "backend": "numpy"})
    b = _new_spelling_quietly(spp=2, integrator=pyrt.Glossy(samples=2, clamp=4.0),
                              sampling=pyrt.Sampling(sampler="independent"), execution=NUMPY)
    np.testing.assert_array_equal(a.image, b.image)


def test_integrator_parameters_reach_the_render():
    base = _new_spelling_quietly(spp=2, execution=NUMPY).image
    direct = _new_spelling_quietly(spp=2, integrator=pyrt.Whitted(max_depth=0), execution=NUMPY).image
    glossy1 = _new_spelling_quietly(spp=2, integrator=pyrt.Glossy(samples=1), execution=NUMPY).image
    glossy4 = _new_spelling_quietly(spp=2, integrator=pyrt.Glossy(samples=4), execution=NUMPY).image
    assert not np.array_equal(base, direct)       # no glass rays: the glass sphere shows the background no more
    assert not np.array_equal(glossy1, glossy4)
    assert not np.array_equal(base, glossy4)


def test_adaptive_sampling_object():
    res = _new_spelling_quietly(sampling=pyrt.Sampling(target_error=1e-2, max_spp=8, min_spp=2), execution=NUMPY)
    assert res.passes >= 1 and res.film.weight.max() <= 8


@pytest.mark.parametrize("make, names", [
    (lambda: settings.integrator_from({"type": "whitted", "samples": 4}), ["'samples'", "pyrt.Glossy(samples=...)"]),
    (lambda: settings.integrator_from({"type": "path"}), ["integrator must be one of", "'path'"]),
    (lambda: pyrt.Glossy(depth=-1), ["Glossy", "depth"]),
    (lambda: pyrt.Whitted(max_depth=2.5), ["max_depth"]),
    (lambda: pyrt.Sampling(min_spp=4), ["min_spp", "target_error"]),
    (lambda: pyrt.Sampling(spp=4, target_error=1e-3), ["exclude"]),
    (lambda: pyrt.Output(fill_budget=1.0), ["fill_budget", "fill=True"]),
    (lambda: pyrt.Execution(dask_workers=3), ["dask_workers", "dask=True"]),
    (lambda: settings.group_from("sampling", {"max_depth": 3}), ["'max_depth'", "integrator=pyrt.Whitted(max_depth"]),
    (lambda: pyrt.render(_scene(), foo=1), ["'foo'"]),
    (lambda: pyrt.render(_scene(), samples=2), ["'samples'", "pyrt.Glossy(samples=...)"]),
    (lambda: pyrt.render(_scene(), integrator=pyrt.Whitted(), max_depth=2), ["max_depth", "integrator object"]),
    (lambda: pyrt.render(_scene(), spp=2, sampling=pyrt.Sampling(spp=2)), ["spp given twice"]),
    (lambda: pyrt.render(_scene(), spp=2, sampling=pyrt.Sampling(target_error=1e-3)), ["exclude"]),
])
def test_an_option_that_is_not_used_or_wrong_is_an_error_naming_it(make, names):
    with pytest.raises(pyrt.RenderError) as exc:
        make()
    for name in names:
        assert name in str(exc.value)


def test_an_integrator_refuses_another_integrators_parameter():
    with pytest.raises(pyrt.RenderError, match=r"Whitted: no option 'samples' \(samples is integrator=pyrt.Glossy"):
        pyrt.Whitted(samples=4)
    with pytest.raises(pyrt.RenderError, match=r"Output: no option 'threads' \(threads is execution=pyrt.Execution"):
        pyrt.Output(threads=2)
    assert pyrt.Glossy(samples=2) == pyrt.Glossy(samples=2) != pyrt.Glossy(samples=3)


def test_old_glossy_keywords_beside_whitted_are_checked_and_named_unused():
    with pytest.warns(DeprecationWarning, match="glossy_samples: options of integrator='glossy', unused"):
        pyrt.render(_scene(), spp=1, glossy_samples=2, execution=NUMPY)
    with pytest.raises(pyrt.RenderError, match="glossy_samples"):
        pyrt.render(_scene(), spp=1, glossy_samples=0, execution=NUMPY)


_SPEC = {"camera": {"position": [0, 0, 4], "width": 8, "height": 8},
         "materials": {"gold": {"type": "cook_torrance", "ks": [1.0, 0.78, 0.34], "roughness": 0.2}},
         "meshes": [{"primitive": "sphere", "material": "gold"}],
         "environment": {"type": "constant", "color": 1.0}}


def test_scene_dict_option_tables_and_the_old_flat_keys():
    new = {"seed": 2, "integrator": {"type": "glossy", "samples": 2, "max_depth": 3},
           "sampling": {"sampler": "independent"}, "execution": {"backend": "numpy", "threads": 1}}
    with warnings.catch_warnings():
        warnings.simplefilter("error")
        scene, opts = pyrt.load_dict(dict(_SPEC, render=new))
    assert opts == new
    with pytest.warns(DeprecationWarning, match="glossy_samples -> \\[render.integrator\\] samples"):
        _, old = pyrt.load_dict(dict(_SPEC, render={"seed": 2, "integrator": "glossy", "glossy_samples": 2,
                                                    "max_depth": 3, "sampler": "independent",
                                                    "execution": {"backend": "numpy", "threads": 1}}))
    assert old == new
    assert pyrt.render(scene, spp=1, **opts).shape == (8, 8, 3)
    with pytest.raises(pyrt.SceneFileError, match="'samples'"):
        pyrt.load_dict(dict(_SPEC, render={"integrator": {"type": "whitted", "samples": 2}}))
    with pytest.raises(pyrt.SceneFileError, match="render.sampling"):
        pyrt.load_dict(dict(_SPEC, render={"sampling": {"max_depth": 2}}))


def test_command_line_integrator_spec():
    assert integrator_spec("glossy:samples=8,clamp=none,threshold=0.3") == (
        "glossy", {"samples": 8, "clamp": None, "threshold": 0.3})
    assert integrator_spec("whitted") == ("whitted", {})
    for bad in ("path", "glossy:samples"):
        with pytest.raises(argparse.ArgumentTypeError):
            integrator_spec(bad)
