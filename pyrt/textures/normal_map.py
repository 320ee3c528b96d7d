"""Tangent-space normal maps: :class:`NormalMap`, :func:`perturb_normal`, :func:`apply_normal_maps`."""
from __future__ import annotations

import numpy as np

from pyrt.shaders import textures as _tex
from pyrt.shaders.vec import valid_reflection_normal
from pyrt.textures.base import TEXTURES, TextureError
from pyrt.textures.image import ImageTexture


#: what :func:`perturb_normal` does with normals whose mirror reflection goes below the surface (:class:`NormalMap`)
REFLECTION_MODES = ("bend", "drop")


@TEXTURES.register("normal_map")
class NormalMap(ImageTexture):
    """Tangent-space normal map (OpenGL convention: red = +u tangent, green = +v, blue = normal).

    Loaded as linear data (``srgb=False``) with 3 channels. Default filter ``"bilinear"`` (trilinear
    also works; averaged normals are renormalised). Use with :func:`perturb_normal` or a material's
    ``normal_map`` attribute.

    Parameters
    ----------
    source : str, os.PathLike or (H, W, 3) array
        As for :class:`ImageTexture`; values are ``(n + 1) / 2`` of a tangent-space normal.
    strength : float
        Scales the tangential components (0 = flat, 1 = as authored), >= 0.
    flip_green : bool
        Read DirectX-style maps (green = -v).
    filter : str
        As for :class:`ImageTexture`, default ``"bilinear"``.
    reflection : {"bend", "drop"}
        What :func:`perturb_normal` does where the mirror reflection of the view direction about the perturbed
        normal would go below the geometric surface (the rims of strong bumps): ``"bend"`` (default) tilts the
        normal toward the geometric one just enough that it does not
        (:func:`pyrt.shaders.vec.valid_reflection_normal`, Cycles' bump-map correction); ``"drop"`` keeps the
        normal, and the reflections there, which the integrators drop, are black.
    **kwargs
        Further :class:`ImageTexture` options (``wrap``, ``scale``, ``name`` ...).
    """

    #: scale of the tangential components (0 = flat); read by :func:`perturb_normal`
    strength = 1.0
    #: True for DirectX-style maps (green = -v); read by :func:`perturb_normal`
    flip_green = False
    #: "bend" or "drop": reflections the map tilts below the surface (the class docstring); read by :func:`perturb_normal`
    reflection = "bend"

    def __init__(self, source, *, strength=1.0, flip_green=False, filter="bilinear", reflection="bend", **kwargs):
        kwargs.setdefault("srgb", False)
        super().__init__(source, filter=filter, channels=3, **kwargs)
        if not np.isfinite(strength) or strength < 0:
            raise TextureError(f"NormalMap {self.path or self.name or ''}: strength must be finite and >= 0")
        self.strength = float(strength)
        self.flip_green = bool(flip_green)
        if reflection not in REFLECTION_MODES:
            raise TextureError(f"NormalMap {self.path or self.name or ''}: reflection must be one of "
                               f"{REFLECTION_MODES}, got {reflection!r}")
        self.reflection = reflection

    @classmethod
    def example(cls):
        """A flat 4 x 4 map (:func:`flat_normal_map`)."""
        return cls(flat_normal_map(), name="example")


def flat_normal_map(height=4, width=4):
    """A flat tangent-space normal-map image (every texel (0.5, 0.5, 1)), float32 (H, W, 3)."""
    img = np.empty((height, width, 3), dtype=np.float32)
    img[...] = (0.5, 0.5, 1.0)
    return img


def perturb_normal(ctx, normal_map, *, ns=None):
    """Shading normals perturbed by a tangent-space normal map.

    Parameters
    ----------
    ctx : SurfaceBatch
        Uses ``ns`` (unit shading normal, turned toward the viewer), the tangents of
        :meth:`~pyrt.geometry.SurfaceBatch.shading_tangents` (the mesh's vertex tangents, else ``dpdu``, ``dpdv`` of
        the map's UV set), ``wo`` (or None),
        ``front`` (or None: all front faces; on back faces the perturbation is mirrored with the surface) and what
        the texture reads (``uv``, footprints).
    normal_map : Texture
        A :class:`NormalMap` (its ``strength`` and ``flip_green`` apply) or any 3-channel texture
        whose values are ``(n + 1) / 2`` of a tangent-space normal (strength 1, OpenGL green).
    ns : (N, 3) float ndarray, optional
        The unit normals to perturb instead of ``ctx.ns`` (keyword-only; a clear coat's map perturbs the
        normals before the base's map, ``ctx.ns_unmapped``).

    Returns
    -------
    (N, 3) float64
        Unit normals ``normalize(x t + y b + z ns)`` with the tangent frame of
        :func:`pyrt.shaders.textures.tangent_frame`; exactly ``ctx.ns`` where the map is flat
        (0.5, 0.5, 1) or degenerate, and where the perturbed normal would face away from
        ``ctx.wo`` (when ``ctx.wo`` is not None); with the map's ``reflection = "bend"`` (default) and ``ctx.ng``
        and ``ctx.wo`` given, tilted toward ``ctx.ng`` where the mirror reflection of ``wo`` would go below the
        surface (:func:`pyrt.shaders.vec.valid_reflection_normal`).
    """
    ns = np.asarray(ctx.ns if ns is None else ns, dtype=np.float64)
    rgb = np.asarray(normal_map.evaluate(ctx), dtype=np.float64).reshape(ctx.n_hits, -1)
    if rgb.shape[1] != 3:
        raise TextureError(f"normal map {normal_map!r} must have 3 channels, got {rgb.shape[1]}")
    nm = normal_map if isinstance(normal_map, NormalMap) else NormalMap    # class defaults for other textures
    strength, flip_green = nm.strength, nm.flip_green
    n_ts = _tex.decode_normal_map(rgb, strength, flip_green)
    if ctx.front is not None and not np.all(ctx.front):
        # a back face (double-sided surface seen from behind, ns turned toward the viewer): the same micro-surface
        # seen from its other side, so the whole perturbed normal is mirrored, -(x t + y b + z n_front), as the
        # glTF Sample Viewer flips t, b and n on back faces (not only n)
        n_ts = np.where(np.asarray(ctx.front)[:, None], n_ts, n_ts * np.array([-1.0, -1.0, 1.0]))
    # the mesh's vertex tangents where it has them (glTF TANGENT), else the tangents of the UV set the map is read in
    dpdu, dpdv = ctx.shading_tangents(normal_map.texcoord)
    t, b = _tex.tangent_frame(ns, np.asarray(dpdu, dtype=np.float64), np.asarray(dpdv, dtype=np.float64))
    n = _tex.apply_tangent_normal(n_ts, ns, t, b)
    wo = ctx.wo
    if wo is not None:
        # A perturbed normal that turns away from the viewer cannot shade anything (every BRDF
        # kernel returns 0 for wo below the horizon): keep the unperturbed normal there, as
        # pyrt.geometry does for interpolated vertex normals.
        away = np.einsum("ij,ij->i", n, np.asarray(wo, dtype=np.float64)) <= 0
        n = np.where(away[:, None], ns, n)
        if nm.reflection == "bend" and ctx.ng is not None:
            # keep the mirror reflection of wo above the geometric surface (the integrators drop rays below it)
            n = valid_reflection_normal(np.asarray(ctx.ng, dtype=np.float64), np.asarray(wo, dtype=np.float64), n)
    return n


def apply_normal_maps(surf, materials):
    """Perturb ``surf``'s shading normals for every material whose ``normal_map`` is not None.

    Called by the integrator right after the surface batch is built (before any material or AOV
    reads ``ns``); rebuilds the local frame with ``surf.set_shading_normal``.

    Parameters
    ----------
    surf : pyrt.geometry.SurfaceBatch
        The hits; modified in place.
    materials : sequence of pyrt.materials.Material
        Indexed by ``surf.material_id``; ``Material.normal_map`` (declared on the base, default None).

    Returns
    -------
    pyrt.geometry.SurfaceBatch
        ``surf``.
    """
    mids = np.asarray(surf.material_id)
    ns = None
    for k in np.unique(mids):
        nm = materials[int(k)].normal_map
        if nm is None:
            continue
        sel = np.flatnonzero(mids == k)
        if ns is None:
            ns = np.array(surf.ns, dtype=np.float64, copy=True)
        ns[sel] = perturb_normal(surf.subset(sel), nm)
    if ns is not None:
        surf.ns_unmapped = surf.ns
        surf.set_shading_normal(ns)
    return surf
