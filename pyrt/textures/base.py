"""The texture interface, its registry, the constant texture and the scene-file constructor.

A texture is a :class:`Texture`: ``evaluate(ctx) -> (N, C)`` float64 with ``C = channels``. Any material
parameter may be one: :meth:`pyrt.materials.Material.param` calls ``texture.evaluate(ctx)`` on the hits
that use the material. Every scene-file type is registered in :data:`TEXTURES`
(``@TEXTURES.register("checker")``); :func:`texture_from_dict` builds ``{"type": name, ...}`` through it,
and ``tests/test_texture_contracts.py`` checks every registered type.
"""
from __future__ import annotations

import numpy as np

from pyrt.core import checks
from pyrt.core.errors import Error
from pyrt.core.registry import Registry, RegistryError


class TextureError(Error, ValueError):
    """A texture file or parameter is missing, unreadable or invalid (the message names it)."""


class Texture:
    """Base class of every texture: ``evaluate(ctx) -> (N, C)`` float64, ``C = channels``.

    Attributes
    ----------
    channels : int
        Number of channels C of :meth:`evaluate`'s output: 1 (grey / data) or 3 (RGB).
    type_name : str or None
        Registry name used by scene files; set by ``TEXTURES.register``.

    Notes
    -----
    What ``ctx`` provides: ``ctx`` is a :class:`pyrt.geometry.SurfaceBatch` (or a subset of one) for N
    hits. A texture reads only the fields it needs; every field is always an attribute of the batch,
    ``None`` where the batch was built without it:

    - ``n_hits`` : int, N.
    - ``uv`` : (N, 2) float64, mesh UVs (``(0, 0)`` = bottom-left of an image, ``v`` up).
    - ``duvdx``, ``duvdy`` : (N, 2) float64 or None, UV change per pixel step in x / y from the ray
      differentials; zeros or None = unknown footprint (no filtering).
    - ``p`` : (N, 3) float64, world-space hit points; ``p_object`` : (N, 3), object-space points (3D
      procedural textures).
    - ``dpdx``, ``dpdy`` : (N, 3) float64 or None, world-space position change per pixel step (3D footprints;
      when None, ``dpdu du/dx + dpdv dv/dx`` is used).
    - ``dpdu``, ``dpdv`` : (N, 3) float64, position derivatives along u and v (tangent frames, footprints);
      ``ns`` : (N, 3) unit shading normals and ``wo`` : (N, 3) unit directions toward the viewer or None
      (normal maps, :func:`pyrt.textures.perturb_normal`).

    Subclasses set ``channels`` (class attribute or in ``__init__``), implement :meth:`evaluate`, and, when
    they are a scene-file type, are registered with ``@TEXTURES.register("name")``.
    """

    #: number of channels C of :meth:`evaluate`'s output: 1 (grey / data) or 3 (RGB). Every texture sets it.
    channels = 3
    #: registry name used by scene files (``{"type": "checker", ...}``); set by :meth:`Registry.register`
    type_name = None
    #: True when :meth:`evaluate` reads the hits' footprints (``duvdx``, ``dpdx``: ray differentials, for filtering);
    #: the renderer carries ray differentials only when some material's texture does
    #: (:attr:`pyrt.materials.Material.uses_footprints`). Unknown textures say True; a texture whose value does not
    #: depend on them (constants, vertex colours, unfiltered image lookups) says False
    needs_footprint = True
    #: the UV set the texture reads (0: ``ctx.uv``; k >= 1: glTF ``TEXCOORD_k``, :meth:`SurfaceBatch.uv_set
    #: <pyrt.geometry.SurfaceBatch.uv_set>`); image textures take it as a parameter
    texcoord = 0

    def compiled_record(self):
        """``(tag, record)`` of this texture in the compiled kernel's texture table (:mod:`pyrt.textures.compiled`),
        or None when the compiled kernel cannot read it (the render then takes the NumPy path). Default None."""
        return None

    def compiled_color(self):
        """``(texture, factor)``: this texture as ``factor`` (three floats) times an RGB texture that may be a row of
        the compiled kernel's texture table (whether it is: that texture's :meth:`compiled_record`), or None. The
        materials' textured colour slots read it (:mod:`pyrt.materials.gltf_record`). Default: itself times one
        when it has 3 channels."""
        return (self, (1.0, 1.0, 1.0)) if self.channels == 3 else None

    def compiled_scalar(self):
        """``(texture, channel, factor)``: this 1-channel texture as ``factor`` times channel ``channel`` of an RGB
        texture that may be a row of the compiled kernel's texture table, or None (the default)."""
        return None

    def compiled_vertex_product(self):
        """``(vertex colours, factor)``: this texture as the hit's interpolated vertex colours (a texture whose
        :meth:`compiled_record` has the tag :data:`pyrt.textures.compiled.VERTEX`) times ``factor`` (a constant or a
        texture), which the compiled kernel reads in a material's colour slot 0
        (:data:`pyrt.materials.compiled.VERTEX_COLOR`); None (the default) for any other texture."""
        return None

    def __init_subclass__(cls, **kwargs):
        super().__init_subclass__(**kwargs)
        # a subclass that changes what the texture returns but not its compiled record (or its compiled form as a
        # factor times a table texture) is not compiled
        if "evaluate" in cls.__dict__:
            for name in ("compiled_record", "compiled_color", "compiled_scalar", "compiled_vertex_product"):
                if name not in cls.__dict__:
                    setattr(cls, name, Texture.__dict__[name])

    def evaluate(self, ctx):  # pragma: no cover - interface
        """The texture's values at the hits of ``ctx``.

        Parameters
        ----------
        ctx : pyrt.geometry.SurfaceBatch
            N hits; see the class docstring for the fields a texture may read.

        Returns
        -------
        (N, channels) float64 ndarray
            Linear values (sRGB images are decoded on load). Deterministic: the same ``ctx`` gives the
            same values.
        """
        raise NotImplementedError

    @classmethod
    def from_dict(cls, params, base_dir=None):
        """Build from scene-file parameters (``"type"`` removed, nested texture dicts already built).

        Parameters
        ----------
        params : dict
            Keyword arguments of the constructor.
        base_dir : str or None
            Directory that relative file names are resolved against (image textures).

        Returns
        -------
        Texture
        """
        try:
            return cls(**params)
        except TypeError as exc:
            raise TextureError(f"{cls.type_name} texture: {exc}") from None

    @classmethod
    def example(cls):
        """A small instance with default or minimal parameters (contract tests, documentation).

        Returns
        -------
        Texture
        """
        return cls()

    def __repr__(self):
        fields = ", ".join(f"{k}={v!r}" for k, v in vars(self).items() if not k.startswith("_"))
        return f"{type(self).__name__}({fields})"


def is_texture(value):
    """True when ``value`` is a :class:`Texture` (rather than a constant parameter)."""
    return isinstance(value, Texture)


def footprinted(*values):
    """True when one of ``values`` is a texture that reads the hits' footprints (:attr:`Texture.needs_footprint`)."""
    return any(isinstance(v, Texture) and v.needs_footprint for v in values)


#: every scene-file texture type, ``type name -> class``
TEXTURES = Registry("texture", Texture)


# ----------------------------------------------------------------------------- ctx helpers

def footprints(ctx):
    """UV footprints ``(duvdx, duvdy)``, each (N, 2) float64; zeros where ``ctx`` has none."""
    n = ctx.n_hits
    z = np.zeros((n, 2))
    dx, dy = ctx.duvdx, ctx.duvdy
    dx = z if dx is None else np.asarray(dx, dtype=np.float64).reshape(n, 2)
    dy = z if dy is None else np.asarray(dy, dtype=np.float64).reshape(n, 2)
    return dx, dy


def texcoords(ctx, k=0):
    """``(uv, duvdx, duvdy)`` of UV set ``k`` at the hits of ``ctx``, each (N, 2) float64 (footprints as
    :func:`footprints`: zeros where unknown). Set 0 reads ``ctx.uv`` and the footprint fields; set ``k`` >= 1
    :meth:`ctx.uv_set(k) <pyrt.geometry.SurfaceBatch.uv_set>`."""
    if k == 0:
        return (ctx.uv, *footprints(ctx))
    uv, dx, dy = ctx.uv_set(k)
    n = ctx.n_hits
    return uv, (np.zeros((n, 2)) if dx is None else dx), (np.zeros((n, 2)) if dy is None else dy)


def dp_dxy(ctx):
    """World-space position change per pixel step (N, 3) x2: ``ctx.dpdx``/``ctx.dpdy`` when given,
    else ``dpdu du/dx + dpdv dv/dx``."""
    if ctx.dpdx is not None and ctx.dpdy is not None:
        return np.asarray(ctx.dpdx, dtype=np.float64), np.asarray(ctx.dpdy, dtype=np.float64)
    dx, dy = footprints(ctx)
    dpdu = np.asarray(ctx.dpdu, dtype=np.float64)
    dpdv = np.asarray(ctx.dpdv, dtype=np.float64)
    return dpdu * dx[:, :1] + dpdv * dx[:, 1:], dpdu * dy[:, :1] + dpdv * dy[:, 1:]


def as_value(value, owner, name):
    """A constant parameter as a float64 (C,) array (C = 1 or 3), or a texture unchanged."""
    if is_texture(value):
        return value
    arr = np.atleast_1d(checks.numbers_array(owner, name, value, TextureError))
    if arr.ndim != 1 or arr.shape[0] not in (1, 3) or not np.all(np.isfinite(arr)):
        raise TextureError(f"{owner}: {name} must be a finite scalar, an RGB triple or a texture, got {value!r}")
    return arr


def value_channels(value):
    """Channel count of a parameter made by :func:`as_value`: ``channels`` of a texture, C of a constant."""
    return value.channels if is_texture(value) else value.shape[0]


def resolve(value, ctx):
    """A parameter made by :func:`as_value` at the hits of ``ctx``: (N, C) float64 (a read-only broadcast
    for constants)."""
    if is_texture(value):
        return np.asarray(value.evaluate(ctx), dtype=np.float64).reshape(ctx.n_hits, -1)
    return np.broadcast_to(value, (ctx.n_hits, value.shape[0]))


def lerp(a, b, t):
    """``a + (b - a) t`` with a, b (N, Ca), (N, Cb) broadcast to a common channel count, t (N,)."""
    c = max(a.shape[1], b.shape[1])
    a = np.broadcast_to(a, (a.shape[0], c)) if a.shape[1] == 1 else a
    b = np.broadcast_to(b, (b.shape[0], c)) if b.shape[1] == 1 else b
    return a + (b - a) * t[:, None]


# ----------------------------------------------------------------------------- constant

@TEXTURES.register("constant")
class ConstantTexture(Texture):
    """The same value everywhere: a scalar (C = 1) or an RGB triple (C = 3).

    Parameters
    ----------
    value : float or (3,) float
        The value (linear).
    """

    needs_footprint = False

    def __init__(self, value):
        self.value = as_value(value, "ConstantTexture", "value")
        self.channels = self.value.shape[0]

    def evaluate(self, ctx):
        return np.array(np.broadcast_to(self.value, (ctx.n_hits, self.channels)))

    @classmethod
    def from_dict(cls, params, base_dir=None):
        params = dict(params)
        if "value" not in params:
            raise TextureError("constant texture needs a 'value'")
        return cls(params.pop("value"), **params)

    @classmethod
    def example(cls):
        return cls(0.5)


# ----------------------------------------------------------------------------- scene files

def texture_from_dict(spec, base_dir=None):
    """Build a texture from a scene-file dict ``{"type": name, ...keyword args}``.

    ``name`` is looked up in :data:`TEXTURES`; ``"path"`` (image / normal_map) is resolved relative to
    ``base_dir``. Nested dicts in colour parameters become textures too.

    Raises
    ------
    TextureError
        Unknown type (the message lists the known ones), missing or bad parameters.
    """
    spec = dict(spec)
    kind = spec.pop("type", None)
    try:
        cls = TEXTURES.lookup(kind)
    except RegistryError:
        raise TextureError(f"texture type must be one of {sorted(TEXTURES)}, got {kind!r}") from None
    for k, v in list(spec.items()):
        if isinstance(v, dict):
            spec[k] = texture_from_dict(v, base_dir)
    return cls.from_dict(spec, base_dir)
