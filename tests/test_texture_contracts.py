"""Contract tests for the texture family, parametrised over the registry (no hand-kept list).

Every registered type, built with :meth:`Texture.example`, must return float64 (N, channels) finite values,
deterministically, lane by lane (a subset of the hits gives the same rows), with and without ray
differentials; the registry accepts only :class:`Texture` subclasses.
"""
import numpy as np
import pytest

from pyrt.core.registry import RegistryError
from pyrt.geometry import SurfaceBatch
from pyrt.textures import TEXTURES, Texture, TextureError, is_texture, texture_from_dict

N = 64
TYPES = sorted(TEXTURES)


def _unit(v):
    return v / np.linalg.norm(v, axis=1, keepdims=True)


def _ctx(rng, *, differentials=True):
    """A SurfaceBatch of N hits on a tilted, textured patch (all the fields a texture may read)."""
    uv = rng.uniform(-1.5, 2.5, (N, 2))
    p = np.column_stack([uv, 0.3 * uv[:, 0]])
    fields = dict(p=p, p_object=p - 0.25, uv=uv, ns=np.tile([0.0, 0.0, 1.0], (N, 1)),
                  wo=_unit(rng.normal(size=(N, 3)) + [0.0, 0.0, 3.0]),
                  dpdu=np.tile([1.0, 0.0, 0.3], (N, 1)), dpdv=np.tile([0.0, 1.0, 0.0], (N, 1)))
    if differentials:
        # footprints from magnified (1e-3 UV per pixel) to strongly minified (0.5 UV per pixel)
        scale = 10.0 ** rng.uniform(-3, np.log10(0.5), (N, 1))
        fields.update(duvdx=scale * [1.0, 0.2], duvdy=scale * [-0.1, 0.7])
        fields.update(dpdx=fields["duvdx"][:, :1] * fields["dpdu"] + fields["duvdx"][:, 1:] * fields["dpdv"],
                      dpdy=fields["duvdy"][:, :1] * fields["dpdu"] + fields["duvdy"][:, 1:] * fields["dpdv"])
    return SurfaceBatch(**fields)


@pytest.fixture
def rng():
    return np.random.default_rng(12345)


def test_registry_is_not_empty_and_names_its_classes():
    assert {"constant", "image", "checker", "normal_map"} <= set(TEXTURES)
    for name, cls in TEXTURES.items():
        assert issubclass(cls, Texture) and cls.type_name == name


@pytest.mark.parametrize("name", TYPES)
def test_example_is_an_instance_of_the_registered_class(name):
    tex = TEXTURES[name].example()
    assert type(tex) is TEXTURES[name]
    assert is_texture(tex)
    assert tex.channels in (1, 3)
    assert repr(tex).startswith(TEXTURES[name].__name__ + "(")


@pytest.mark.parametrize("differentials", [True, False], ids=["footprints", "no-differentials"])
@pytest.mark.parametrize("name", TYPES)
def test_evaluate_is_float64_n_by_channels_finite_and_deterministic(name, differentials, rng):
    ctx = _ctx(rng, differentials=differentials)
    tex = TEXTURES[name].example()
    out = tex.evaluate(ctx)
    assert isinstance(out, np.ndarray) and out.dtype == np.float64
    assert out.shape == (N, tex.channels)
    assert np.all(np.isfinite(out))
    np.testing.assert_array_equal(tex.evaluate(ctx), out)                          # same object, again
    np.testing.assert_array_equal(TEXTURES[name].example().evaluate(ctx), out)     # a fresh instance


@pytest.mark.parametrize("name", TYPES)
def test_evaluate_is_per_hit(name, rng):
    """Materials evaluate textures on the subset of hits that use them: row k depends on hit k only."""
    ctx = _ctx(rng)
    tex = TEXTURES[name].example()
    full = tex.evaluate(ctx)
    idx = np.flatnonzero(rng.random(N) < 0.4)[::-1]
    np.testing.assert_array_equal(tex.evaluate(ctx.subset(idx)), full[idx])


def test_fields_a_texture_reads_are_declared_on_every_surface_batch():
    """Fields given to neither the batch nor its subset read as None (never an AttributeError)."""
    bare = SurfaceBatch(p=np.zeros((3, 3)), uv=np.zeros((3, 2)))
    for batch in (bare, bare.subset(np.array([0, 2]))):
        for field in ("duvdx", "duvdy", "dpdx", "dpdy", "wo", "p_object", "dpdu", "dpdv", "ns"):
            assert getattr(batch, field) is None


def test_registering_a_class_that_is_not_a_texture_fails():
    class NotATexture:
        channels = 3

        def evaluate(self, ctx):
            return np.zeros((ctx.n_hits, 3))

    before = dict(TEXTURES)
    with pytest.raises(RegistryError, match="not a subclass of Texture"):
        TEXTURES.register("not_a_texture")(NotATexture)
    with pytest.raises(RegistryError):
        TEXTURES.register("constant_instance")(TEXTURES["constant"].example())
    assert dict(TEXTURES) == before
    assert not is_texture(NotATexture())


def test_registering_a_taken_name_fails():
    class Impostor(Texture):
        def evaluate(self, ctx):
            return np.zeros((ctx.n_hits, 3))

    with pytest.raises(RegistryError, match="already"):
        TEXTURES.register("checker")(Impostor)
    assert TEXTURES["checker"].__name__ == "CheckerTexture"


@pytest.mark.parametrize("value", [0.5, [0.1, 0.2, 0.3], np.ones(3), None, "checker", {"type": "checker"}])
def test_constants_are_not_textures(value):
    assert not is_texture(value)


def test_texture_from_dict_looks_types_up_in_the_registry():
    for name, cls in TEXTURES.items():
        if name in ("constant", "image", "normal_map"):
            continue   # need a value / a file: covered in tests/test_textures.py
        assert type(texture_from_dict({"type": name})) is cls
    assert texture_from_dict({"type": "constant", "value": [1, 2, 3]}).channels == 3
    with pytest.raises(TextureError, match=r"texture type must be one of \[.*'checker'.*\], got 'marble'"):
        texture_from_dict({"type": "marble"})
    with pytest.raises(TextureError, match="needs a 'value'"):
        texture_from_dict({"type": "constant"})
    with pytest.raises(TextureError, match="checker texture: .*colour"):
        texture_from_dict({"type": "checker", "colour": 1})
