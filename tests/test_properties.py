"""Property-based tests (Hypothesis) over the scene-file schema and the public constructors.

Properties: any generated scene dict either loads and renders (8 x 6, spp 1) an image whose values are all finite,
or raises a ``pyrt.Error``; any generated call of a public constructor either returns an object or raises a
``pyrt.Error``. Never another exception, a NaN pixel or a hang (a per-example deadline).

Budget: 25 examples per property in the default run (derandomized: the same examples every run, seconds in
all); 500 under ``pytest -m slow`` (random, so each slow run explores new ground).

The engine bugs these tests first found (string/dict parameter values reaching ``float()``, ``Camera`` width or
height NaN/inf, geometry beyond the float32 range, ``Scene.add_plane`` with a 3-vector size or a non-finite
normal) are fixed and the generators now produce those values too. They still stay away from sizes that are
slow rather than wrong (integers are small: an icosphere of subdivisions 12 or 10^6 light samples would be a
long render, not a bug).
"""
import inspect
import math
import warnings

import numpy as np
import pytest
from hypothesis import HealthCheck, given, settings
from hypothesis import strategies as st

import pyrt
from pyrt.lights import REGISTRY as LIGHTS
from pyrt.materials import REGISTRY as MATERIALS

FAST = settings(max_examples=25, derandomize=True, deadline=None, database=None,
                suppress_health_check=[HealthCheck.too_slow, HealthCheck.data_too_large])
SLOW = settings(max_examples=500, deadline=None, database=None,
                suppress_health_check=[HealthCheck.too_slow, HealthCheck.data_too_large])
RENDERED = []   # how many generated scenes got as far as an image (reported by the exploration runs)

# ----------------------------------------------------------------------------- value strategies

FLOAT = st.one_of(st.floats(allow_nan=True, allow_infinity=True, width=64),
                  st.sampled_from([0.0, -0.0, 1.0, -1.0, 0.5, 1e-300, 1e300, 1e20, -1e20, math.nan, math.inf]),
                  st.floats(-10, 10))
SMALL_INT = st.integers(-3, 8)
VEC3 = st.lists(FLOAT, min_size=3, max_size=3)
NICE = st.floats(-5, 5, allow_nan=False)
# sizes and transforms, up to and beyond what float32 ray tracing resolves (1e39 overflows float32)
BOUNDED = st.one_of(st.floats(-1e30, 1e30), st.sampled_from([math.nan, math.inf, -math.inf, 0.0, -1.0, 1e-300,
                                                             1e39, -1e39, 1e300]))
BOUNDED_VEC3 = st.lists(BOUNDED, min_size=3, max_size=3)
NICE_VEC3 = st.lists(NICE, min_size=3, max_size=3)
UNIT = st.floats(0, 1)
HOSTILE = st.one_of(FLOAT, SMALL_INT, VEC3, st.booleans(), st.none(), st.lists(FLOAT, max_size=5),
                    st.text(max_size=4), st.just({}), st.lists(st.text(max_size=2), min_size=3, max_size=3))
PLAUSIBLE = st.one_of(UNIT, st.lists(UNIT, min_size=3, max_size=3), st.floats(0, 100), NICE_VEC3)
# mostly plausible values (so that many scenes get as far as a render), hostile ones a third of the time
VALUE = st.one_of(UNIT, st.lists(UNIT, min_size=3, max_size=3), st.floats(0, 100), NICE_VEC3, HOSTILE, HOSTILE)


def _params(cls, required=False):
    """Keyword parameters of a registered class (what a scene file may set); only those without a default
    with ``required``."""
    sig = inspect.signature(cls.__init__)
    return [n for n, p in sig.parameters.items()
            if n != "self" and p.kind in (p.KEYWORD_ONLY, p.POSITIONAL_OR_KEYWORD)
            and not (required and p.default is not p.empty)]


@st.composite
def typed_table(draw, registry, exclude=(), all_required=False, values=None, typo=True):
    """``{"type": name, some of its parameters: random values}``; sometimes one unknown key. With
    ``all_required`` every parameter without a default is among them (a Python call that can bind)."""
    name = draw(st.sampled_from(sorted(n for n in registry if n not in exclude)))
    params = [p for p in _params(registry[name]) if p != "name"]
    chosen = draw(st.lists(st.sampled_from(params), unique=True, max_size=min(4, len(params)))) if params else []
    if all_required:
        chosen = sorted(set(chosen) | set(_params(registry[name], required=True)))
    table = {"type": name}
    for p in chosen:
        table[p] = draw(VALUE if values is None else values)
    if typo and draw(st.integers(0, 9)) == 0:
        table["colour"] = 1.0  # a typo
    return table


@st.composite
def mesh_table(draw, materials):
    prim = draw(st.sampled_from(["sphere", "box", "plane", "cylinder"]))
    t = {"primitive": prim, "material": draw(st.sampled_from(materials))}
    keys = {"sphere": ["radius", "subdivisions"], "box": ["extents"], "plane": ["size", "normal"],
            "cylinder": ["radius", "height", "sections"]}[prim] + ["translate", "scale", "rotate", "smooth"]
    for k in draw(st.lists(st.sampled_from(keys), unique=True, max_size=3)):
        if k in ("subdivisions", "sections"):
            t[k] = draw(SMALL_INT)
        elif k == "rotate":
            t[k] = [draw(FLOAT), draw(NICE_VEC3)]
        elif k == "smooth":
            t[k] = draw(st.one_of(st.booleans(), st.just("auto"), st.text(max_size=3)))
        elif k in ("translate", "extents", "normal"):
            t[k] = draw(st.one_of(BOUNDED_VEC3, NICE_VEC3))
        else:
            t[k] = draw(st.one_of(BOUNDED, NICE))
    return t


@st.composite
def scene_dict(draw):
    hostile = draw(st.booleans())  # half the scenes plausible throughout, so that many get as far as a render
    values = VALUE if hostile else PLAUSIBLE
    cam = {"width": 8, "height": 6, "spp": 1}
    if hostile:
        for k in draw(st.lists(st.sampled_from(["position", "target", "up", "fov"]), unique=True, max_size=3)):
            cam[k] = draw(st.one_of(FLOAT, NICE)) if k == "fov" else draw(st.one_of(VEC3, NICE_VEC3))
    else:
        cam.update(position=[draw(NICE), draw(NICE), draw(st.floats(3, 8))], target=[0, 0, 0],
                   fov=draw(st.floats(10, 120)))
    n_mat = draw(st.integers(1, 3))
    materials = {f"m{i}": draw(typed_table(MATERIALS, values=values, typo=hostile)) for i in range(n_mat)}
    meshes = [draw(mesh_table(sorted(materials))) for _ in range(draw(st.integers(0 if hostile else 1, 3)))]
    lights = [draw(typed_table(LIGHTS, all_required=True, values=values, typo=hostile))
              for _ in range(draw(st.integers(0, 2)))]
    spec = {"camera": cam, "materials": materials, "meshes": meshes, "lights": lights,
            "render": {"max_depth": draw(st.integers(0, 3)), "seed": 1}}
    if draw(st.booleans()):
        spec["render"]["background"] = draw(st.one_of(VEC3, NICE_VEC3) if hostile else st.lists(UNIT, min_size=3,
                                                                                                   max_size=3))
    return spec


def _render_or_error(spec):
    """The property: a finite image, or a pyrt.Error; anything else fails the test."""
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        try:
            scene, options = pyrt.load_dict(spec)
            img = pyrt.render(scene, spp=1, **options)
            RENDERED.append(1)
        except pyrt.Error:
            return None
    img = np.asarray(img)
    assert img.shape == (6, 8, 3)
    assert np.all(np.isfinite(img)), f"non-finite pixels for {spec!r}"
    return img


# ----------------------------------------------------------------------------- (a) the scene-file schema

@FAST
@given(scene_dict())
def test_any_scene_dict_renders_finite_or_raises_pyrt_error(spec):
    _render_or_error(spec)


@pytest.mark.slow
@SLOW
@given(scene_dict())
def test_any_scene_dict_renders_finite_or_raises_pyrt_error_many(spec):
    _render_or_error(spec)


# ----------------------------------------------------------------------------- (b) the public constructors

@st.composite
def constructor_call(draw):
    """(callable, kwargs) over every registered material and light, the camera and the Scene primitives."""
    kind = draw(st.sampled_from(["material", "light", "camera", "sphere", "box", "plane"]))
    if kind in ("material", "light"):
        table = draw(typed_table(MATERIALS if kind == "material" else LIGHTS, all_required=True))
        cls = (MATERIALS if kind == "material" else LIGHTS)[table.pop("type")]
        table.pop("colour", None)
        return cls, table
    if kind == "camera":
        kw = {k: draw(st.one_of(VEC3, NICE_VEC3)) for k in
              draw(st.lists(st.sampled_from(["position", "target", "up"]), unique=True))}
        for k in draw(st.lists(st.sampled_from(["fov", "width", "height", "spp"]), unique=True)):
            kw[k] = draw(st.one_of(FLOAT, SMALL_INT, st.integers(-10, 64), st.text(max_size=3)))
        return pyrt.Camera, kw
    scene = pyrt.Scene()
    mat = pyrt.Lambert(0.5)
    if kind == "sphere":
        return scene.add_sphere, {"center": draw(st.one_of(VEC3, NICE_VEC3)), "radius": draw(st.one_of(FLOAT, NICE)),
                                  "material": mat, "subdivisions": draw(SMALL_INT)}
    if kind == "box":
        return scene.add_box, {"center": draw(st.one_of(VEC3, NICE_VEC3)), "extents": draw(st.one_of(VEC3, NICE_VEC3)),
                               "material": mat}
    return scene.add_plane, {"center": draw(st.one_of(VEC3, NICE_VEC3)), "size": draw(st.one_of(FLOAT, NICE, VEC3)),
                             "material": mat, "normal": draw(st.one_of(NICE_VEC3, VEC3, st.text(max_size=3)))}


def _construct_or_error(call):
    fn, kwargs = call
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        try:
            fn(**kwargs)
        except pyrt.Error:
            pass


@FAST
@given(constructor_call())
def test_public_constructors_build_or_raise_pyrt_error(call):
    _construct_or_error(call)


@pytest.mark.slow
@SLOW
@given(constructor_call())
def test_public_constructors_build_or_raise_pyrt_error_many(call):
    _construct_or_error(call)
