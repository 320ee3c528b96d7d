"""Loaded material parameters -> pyrt materials: the glTF metallic-roughness material with its extras
(emission, occlusion, normal map), the OBJ/MTL Blinn-Phong mapping (:mod:`pyrt.io.assets.obj`) and the
textures that combine factors, textures and vertex colours."""
from __future__ import annotations

import math

import numpy as np

from pyrt.materials import BlinnPhong, Clearcoat, Glass, GltfPBR, MetallicRoughness, Sheen, Unlit
from pyrt.textures import Texture
from pyrt.textures import compiled as _TC
from pyrt.textures.base import footprinted, is_texture
from pyrt.io.assets.common import AssetError, DefaultParams, MTLParams, PBRParams

class ScaledTexture(Texture):
    """``factor * texture`` (factor a scalar or RGB); ``channels`` of the inner texture."""

    def __init__(self, texture, factor):
        self.texture = texture
        self.factor = np.asarray(factor, dtype=np.float64)
        self.channels = texture.channels

    @property
    def needs_footprint(self):
        return self.texture.needs_footprint

    def evaluate(self, ctx):
        v = np.asarray(self.texture.evaluate(ctx), dtype=np.float64).reshape(ctx.n_hits, -1)
        return v * self.factor

    def compiled_color(self):
        """The inner texture's compiled colour form with its factor times this one (a grey or RGB factor)."""
        inner = self.texture.compiled_color()
        if inner is None or self.factor.size not in (1, 3):
            return None
        f = np.broadcast_to(self.factor.reshape(-1), (3,))
        return inner[0], tuple(float(a) * float(b) for a, b in zip(inner[1], f))

    def compiled_scalar(self):
        """The inner texture's compiled scalar form with its factor times this one (a scalar factor)."""
        inner = self.texture.compiled_scalar()
        if inner is None or self.factor.size != 1:
            return None
        return inner[0], inner[1], inner[2] * float(self.factor.reshape(-1)[0])


class ProductTexture(Texture):
    """Per-hit product of two textures (or a texture and a constant), e.g. vertex colour x base colour."""

    def __init__(self, a, b):
        self.a, self.b = a, b
        self.channels = 3

    @property
    def needs_footprint(self):
        return footprinted(self.a, self.b)

    def evaluate(self, ctx):
        def val(x):
            if isinstance(x, Texture):
                return np.asarray(x.evaluate(ctx), dtype=np.float64).reshape(ctx.n_hits, -1)
            return np.broadcast_to(np.asarray(x, dtype=np.float64), (ctx.n_hits, 3))
        return val(self.a) * val(self.b)

    def compiled_vertex_product(self):
        """``(vertex colours, other factor)`` where one factor is vertex colours alone
        (:meth:`VertexColorTexture.compiled_vertex_product`) and the other a constant or a texture without them;
        None otherwise."""
        for x, y in ((self.a, self.b), (self.b, self.a)):
            form = x.compiled_vertex_product() if is_texture(x) else None
            if form is not None and form[0] is x and not (is_texture(y) and y.compiled_vertex_product() is not None):
                return x, y
        return None


class VertexColorTexture(Texture):
    """Linear per-vertex colours interpolated with the hit's barycentrics.

    The colours are bound to scene meshes after :meth:`pyrt.Scene.add_mesh` (``bind(mesh_id,
    faces, colors)``, with the mesh's final faces so that ``ctx.prim_id`` indexes them). Hits on
    meshes that were not bound get white (1, 1, 1). ``channels=1``: one value per vertex (bound as
    (V, 1), e.g. COLOR_0's alpha).

    One texture may serve many meshes (every part of a model that shares a material): the bound meshes'
    faces and colours are joined into one table on the first lookup after a :meth:`bind`, so a lookup is
    a few gathers whatever the number of meshes (a loop over the meshes of every batch cost ~2000 NumPy
    calls per lookup on a 2000-part model). A single bound mesh's arrays are used as they are.
    """

    channels = 3
    #: barycentric interpolation: no footprint
    needs_footprint = False

    def __init__(self, channels=3):
        self.channels = int(channels)
        self._bound = {}
        self._table = None

    def bind(self, mesh_id, faces, colors):
        self._bound[int(mesh_id)] = (np.asarray(faces, dtype=np.int64), np.asarray(colors, dtype=np.float64))
        self._table = None

    def bound(self, mesh_id):
        """``(faces, colors)`` bound to scene mesh ``mesh_id``, or None (its hits get white)."""
        return self._bound.get(int(mesh_id))

    def compiled_record(self):
        """RGB vertex colours: a row of tag :data:`pyrt.textures.compiled.VERTEX` (no fields; the kernel reads the
        colours packed with the geometry, :mod:`pyrt.integrators.compiled_vertex`); None with one channel."""
        return (_TC.VERTEX, np.zeros(_TC.RECORD)) if self.channels == 3 else None

    def compiled_color(self):
        """None: the kernel does not look vertex colours up as a texture slot (only as :meth:`compiled_vertex_product`
        of a material's colour slot 0)."""
        return None

    def compiled_vertex_product(self):
        """``(self, 1.0)`` for RGB colours (the kernel interpolates them at the hit as :meth:`evaluate`), else
        None."""
        return (self, 1.0) if self.channels == 3 else None

    def _tables(self):
        """``(face offset per mesh id (-1: unbound), faces (F, 3) into colours, colours (V, C))`` of every bound
        mesh, joined (face and vertex indices offset)."""
        if self._table is None:
            mids = sorted(self._bound)
            foff = np.full(mids[-1] + 1, -1, dtype=np.int64)
            if len(mids) == 1:
                foff[mids[0]] = 0
                faces, colors = self._bound[mids[0]]
            else:
                fparts, cparts, nf, nv = [], [], 0, 0
                for mid in mids:
                    f, c = self._bound[mid]
                    foff[mid] = nf
                    fparts.append(f + nv)
                    cparts.append(c)
                    nf, nv = nf + f.shape[0], nv + c.shape[0]
                faces, colors = np.concatenate(fparts), np.concatenate(cparts)
            self._table = (foff, faces, colors)
        return self._table

    def _rows(self, ctx):
        """``(sel, rows)``: the hits on bound meshes (None: all of them) and their rows of the joined faces."""
        foff = self._tables()[0]
        mid = np.asarray(ctx.mesh_id, dtype=np.int64)
        base = np.full(mid.shape[0], -1, dtype=np.int64)
        inside = mid < foff.shape[0]
        base[inside] = foff[mid[inside]]
        ok = base >= 0
        if ok.all():
            return None, base + ctx.prim_id
        sel = np.flatnonzero(ok)
        return sel, base[sel] + np.asarray(ctx.prim_id)[sel]

    def evaluate(self, ctx):
        out = np.ones((ctx.n_hits, self.channels))
        if not self._bound or ctx.n_hits == 0:
            return out
        _, faces, colors = self._tables()
        sel, rows = self._rows(ctx)
        tri = faces[rows]
        b = ctx.bary if sel is None else ctx.bary[sel]
        val = (b[:, 0:1] * colors[tri[:, 0]] + b[:, 1:2] * colors[tri[:, 1]] + b[:, 2:3] * colors[tri[:, 2]])
        if sel is None:
            return val
        out[sel] = val
        return out


class FaceColorTexture(VertexColorTexture):
    """Linear per-face colours (PLY ``face`` colours): every hit on triangle ``k`` of a bound mesh gets colour ``k``.

    ``bind(mesh_id, faces, colors)`` with ``colors`` (F, 3), one row per face of the scene mesh (``ctx.prim_id``
    indexes them); hits on meshes that were not bound get white (1, 1, 1).
    """

    def _tables(self):
        if self._table is None:
            mids = sorted(self._bound)
            foff = np.full(mids[-1] + 1, -1, dtype=np.int64)
            parts, nf = [], 0
            for mid in mids:
                c = self._bound[mid][1]
                foff[mid] = nf
                parts.append(c)
                nf += c.shape[0]
            self._table = (foff, None, parts[0] if len(parts) == 1 else np.concatenate(parts))
        return self._table

    def evaluate(self, ctx):
        out = np.ones((ctx.n_hits, 3))
        if not self._bound or ctx.n_hits == 0:
            return out
        colors = self._tables()[2]
        sel, rows = self._rows(ctx)
        if sel is None:
            return colors[rows]
        out[sel] = colors[rows]
        return out


class SurfaceExtras:
    """Mixin adding glTF-style extras to a material: emission, occlusion and a normal map.

    - ``emission_value`` (constant or texture): emitted radiance (W m^-2 sr^-1).
    - ``occlusion`` (1-channel texture or None): ``1 + strength (occ - 1)``; multiplies
      :meth:`albedo`, i.e. the constant ambient term (pyrt's only indirect light, which is what glTF
      occlusion applies to) and the albedo AOV, and the split-sum environment preview
      (:meth:`preview_lobes`: image-based light). Direct light is not occluded (glTF spec).
    - ``normal_map`` (:class:`pyrt.textures.NormalMap` or None): applied by the integrator
      (:func:`pyrt.textures.apply_normal_maps` perturbs the shading normal of every material with a
      ``normal_map`` attribute before shading).
    """

    @property
    def emits(self):
        """True unless the emission is a constant zero (a texture may emit). Without it every glTF / OBJ material
        would count as an emitter, and the previewer probed each of their triangles for an emissive-mesh light
        (12-15 s of a 5.24 M-triangle PLY's preparation, to find nothing) and evaluated their zero emission at
        every hit."""
        e = self.emission_value
        return is_texture(e) or bool(np.any(np.asarray(e) > 0))

    def _init_extras(self, emission=None, occlusion=None, occlusion_strength=1.0, normal_map=None):
        self.emission_value = 0.0 if emission is None else emission
        self.occlusion = occlusion
        self.occlusion_strength = float(occlusion_strength)
        self.normal_map = normal_map

    def albedo(self, ctx):
        a = super().albedo(ctx)
        if self.occlusion is None:
            return a
        occ = self.param(self.occlusion, ctx, 1)
        return a * (1.0 + self.occlusion_strength * (occ - 1.0))[:, None]

    def emission(self, ctx):
        return np.array(self.param(self.emission_value, ctx))

    def compiled_record(self, pack_texture):
        """The base model's compiled record when the extras change nothing it shades (no emission or occlusion; a
        normal map is the compiled scene's, :func:`pyrt.integrators.compiled.normal_map_fields`), else its
        :meth:`~pyrt.materials.Material.compiled_record_extras` (None where the model has no place for them: the
        mixin overrides ``albedo`` and ``emission``, which :class:`pyrt.materials.Material`'s subclass rule does not
        see on a class that is no Material)."""
        if self.emits or self.occlusion is not None:
            return self.compiled_record_extras(pack_texture, emission=self.emission_value, occlusion=self.occlusion,
                                               occlusion_strength=self.occlusion_strength)
        return super().compiled_record(pack_texture)

    def preview_lobes(self, ctx):
        """The material's split-sum lobes with the occlusion ``1 + strength (occ - 1)`` on the environment term."""
        lobes = super().preview_lobes(ctx)
        if lobes is None or self.occlusion is None:
            return lobes
        occ = 1.0 + self.occlusion_strength * (self.param(self.occlusion, ctx, 1) - 1.0)
        lobes.occlusion = occ if lobes.occlusion is None else lobes.occlusion * occ
        return lobes


class ObjMaterial(SurfaceExtras, BlinnPhong):
    """An OBJ/MTL opaque material: energy-normalised Blinn-Phong plus MTL ``Ke`` emission."""

    type_name = None

    def __init__(self, kd, ks, exponent, *, emission=None, normal_map=None, name=None):
        BlinnPhong.__init__(self, kd, ks, exponent, name=name)
        self._init_extras(emission=emission, normal_map=normal_map)


class GltfMaterial(SurfaceExtras, MetallicRoughness):
    """The glTF material: :class:`pyrt.materials.MetallicRoughness` plus emission, occlusion, normal map."""

    type_name = None

    def __init__(self, *, base_color, metallic, roughness, emission=None, occlusion=None,
                 occlusion_strength=1.0, normal_map=None, double_sided=True, name=None):
        MetallicRoughness.__init__(self, base_color=base_color, metallic=metallic, roughness=roughness,
                                   name=name)
        self._init_extras(emission=emission, occlusion=occlusion, occlusion_strength=occlusion_strength,
                          normal_map=normal_map)
        self.double_sided = bool(double_sided)


class GltfPBRMaterial(SurfaceExtras, GltfPBR):
    """A glTF material with ``KHR_materials_specular`` / ``_ior`` / ``_transmission`` / ``_volume`` / ``_anisotropy``:
    :class:`pyrt.materials.GltfPBR` plus emission, occlusion, normal map."""

    type_name = None

    def __init__(self, *, emission=None, occlusion=None, occlusion_strength=1.0, normal_map=None, double_sided=True,
                 **kwargs):
        GltfPBR.__init__(self, **kwargs)
        self._init_extras(emission=emission, occlusion=occlusion, occlusion_strength=occlusion_strength,
                          normal_map=normal_map)
        self.double_sided = bool(double_sided)


def _factor_tex(factor, tex):
    """``factor`` alone, or ``factor x texture``."""
    return factor if tex is None else ScaledTexture(tex, factor)


def gltf_extension_material(params, base, *, base_color, metallic, roughness, emission):
    """The material of a glTF material with ``KHR_materials_*`` extensions (:mod:`pyrt.io.assets.gltf_khr`), or
    ``base`` (the core material, already built) when it has none that changes it."""
    P = params
    if P.unlit:
        return Unlit(base_color, name=P.name)
    mat = base
    if P.uses_pbr_extensions:
        thick = P.thickness_factor > 0
        sigma = 0.0
        if thick and math.isfinite(P.attenuation_distance):
            sigma = -np.log(np.maximum(P.attenuation_color, 1e-6)) / P.attenuation_distance
        sc_tex = _slot_tex(P.specular_color_texture)
        mat = GltfPBRMaterial(base_color=base_color, metallic=metallic, roughness=roughness,
                              specular=_factor_tex(P.specular_factor, P.specular_texture),
                              specular_color=_factor_tex(P.specular_color_factor, sc_tex), ior=P.ior,
                              transmission=_factor_tex(P.transmission_factor, P.transmission_texture), thin=not thick,
                              absorption=sigma, anisotropy=P.anisotropy_strength,
                              anisotropy_rotation=P.anisotropy_rotation, anisotropy_texture=P.anisotropy_texture,
                              emission=emission, occlusion=P.occlusion_texture,
                              occlusion_strength=P.occlusion_strength, normal_map=P.normal_texture,
                              double_sided=P.double_sided, name=P.name)
    if P.sheened:        # the sheen lies on the material, under a clear coat (KHR_materials_sheen)
        sc_tex = _slot_tex(P.sheen_color_texture)
        mat = Sheen(mat, color=_factor_tex(P.sheen_color_factor, sc_tex),
                    roughness=_factor_tex(P.sheen_roughness_factor, P.sheen_roughness_texture), name=P.name)
    if P.coated:
        mat = Clearcoat(mat, clearcoat=_factor_tex(P.clearcoat_factor, P.clearcoat_texture),
                        roughness=_factor_tex(P.clearcoat_roughness_factor, P.clearcoat_roughness_texture),
                        normal_map=P.clearcoat_normal_texture, name=P.name)
    return mat


def make_metallic_roughness(**kwargs):
    """Adapter: build the glTF metallic-roughness material (:class:`GltfMaterial`).

    Raises :class:`AssetError` if the material library's ``MetallicRoughness`` class is missing:
    no other model is substituted silently.
    """
    if GltfMaterial is None:
        raise AssetError("pyrt.materials.MetallicRoughness is not available, so glTF metallic-roughness "
                         "materials cannot be built (the material library)")
    return GltfMaterial(**kwargs)


def _slot_tex(slot):
    return None if slot is None else slot.texture


def to_pyrt_material(params, *, vertex_colors=None):
    """A pyrt material for loaded parameters (:class:`PBRParams`, :class:`MTLParams`, :class:`DefaultParams`).

    ``vertex_colors`` (a texture, e.g. :class:`VertexColorTexture`) multiplies the base colour /
    diffuse colour (glTF ``COLOR_0`` semantics).
    """
    if isinstance(params, PBRParams):
        base = params.base_color_factor[:3]
        tex = _slot_tex(params.base_color_texture)
        base_color = base if tex is None else ScaledTexture(tex, base)
        if vertex_colors is not None:
            base_color = ProductTexture(vertex_colors, base_color)
        metallic = params.metallic_factor if params.metallic_texture is None else \
            ScaledTexture(params.metallic_texture, params.metallic_factor)
        roughness = params.roughness_factor if params.roughness_texture is None else \
            ScaledTexture(params.roughness_texture, params.roughness_factor)
        e = params.emissive_factor * params.emissive_strength
        etex = _slot_tex(params.emissive_texture)
        emission = (e if np.any(e > 0) else None) if etex is None else ScaledTexture(etex, e)
        core = make_metallic_roughness(base_color=base_color, metallic=metallic, roughness=roughness,
                                       emission=emission, occlusion=params.occlusion_texture,
                                       occlusion_strength=params.occlusion_strength,
                                       normal_map=params.normal_texture, double_sided=params.double_sided,
                                       name=params.name)
        return gltf_extension_material(params, core, base_color=base_color, metallic=metallic, roughness=roughness,
                                       emission=emission)
    if isinstance(params, DefaultParams):
        base = np.asarray(params.base_color, dtype=np.float64)
        base_color = base if vertex_colors is None else ProductTexture(vertex_colors, base)
        return make_metallic_roughness(base_color=base_color, metallic=params.metallic,
                                       roughness=params.roughness, name=params.name)
    if isinstance(params, MTLParams):
        return _mtl_material(params, vertex_colors)
    raise AssetError(f"unknown material parameters {type(params).__name__}")


#: MTL illumination models that make a material glass (4: "Glass on, reflection: ray trace", 6: "Refraction on",
#: 7: "Refraction on, reflection: Fresnel", 9: "Glass on, reflection: ray trace off")
MTL_GLASS_ILLUM = (4, 6, 7, 9)


def mtl_is_transparent(p):
    """True for an MTL material that is glass (``illum`` 4, 6, 7 or 9); ``d`` / ``Tr`` / ``map_d`` alone are
    dissolve (coverage, :func:`mtl_opacity`), as the MTL spec defines them."""
    return p.illum in MTL_GLASS_ILLUM


def mtl_opacity(p):
    """The coverage of a non-glass MTL material: ``d`` (``1 - Tr``) times ``map_d``, or None (opaque)."""
    d = 1.0 if p.d is None else float(np.clip(p.d, 0.0, 1.0))
    if p.map_d is None:
        return None if d >= 1.0 else d
    return p.map_d if d >= 1.0 else ScaledTexture(p.map_d, d)


def mtl_kd_ks(p):
    """``(kd, ks, s)``: Kd and Ks clipped to [0, 1] (defaults 0.8 and 0), ks already scaled by ``s <= 1``
    so that ``kd * max(map_Kd) + ks <= 1`` in every channel."""
    kd = np.clip(p.Kd if p.Kd is not None else np.full(3, 0.8), 0.0, 1.0)
    ks = np.clip(p.Ks if p.Ks is not None else np.zeros(3), 0.0, 1.0)
    kd_max = kd * (float(np.max(p.map_Kd.image)) if p.map_Kd is not None else 1.0)
    s = _ks_scale(kd_max, ks)
    return kd, ks * s, s


def _mtl_material(p, vertex_colors=None):
    if mtl_is_transparent(p):
        ior = p.Ni if (p.Ni is not None and p.Ni > 1.0) else 1.5
        tint = np.clip(p.Tf, 0, 1) if p.Tf is not None else 1.0
        return Glass(ior=ior, tint=tint, name=p.name)
    kd, ks, _ = mtl_kd_ks(p)
    kd_param = kd if p.map_Kd is None else ScaledTexture(p.map_Kd, kd)
    if vertex_colors is not None:
        kd_param = ProductTexture(vertex_colors, kd_param)
    emission = None
    ke = p.Ke if p.Ke is not None else np.zeros(3)
    if p.map_Ke is not None:
        emission = ScaledTexture(p.map_Ke, ke if p.Ke is not None else np.ones(3))
    elif np.any(ke > 0):
        emission = ke
    if p.pbr:          # the exporters' PBR extension: glTF's metallic-roughness model; a map replaces its scalar
        metallic = p.map_Pm if p.map_Pm is not None else (0.0 if p.Pm is None else p.Pm)
        roughness = p.map_Pr if p.map_Pr is not None else (0.5 if p.Pr is None else p.Pr)
        mat = make_metallic_roughness(base_color=kd_param, metallic=metallic, roughness=roughness, emission=emission,
                                      normal_map=p.norm, name=p.name)
    else:
        exponent = float(p.Ns) if p.Ns is not None else 10.0
        mat = ObjMaterial(kd_param, ks, max(exponent, 0.0), emission=emission, normal_map=p.norm, name=p.name)
    opacity = mtl_opacity(p)
    if opacity is not None:     # dissolve: straight-through coverage (blend), shadows included
        mat.set_coverage(opacity=opacity, alpha_mode="blend")
    return mat


def _ks_scale(kd_max, ks):
    """Uniform factor <= 1 on ks so that kd + ks <= 1 in every channel."""
    room = 1.0 - kd_max
    need = ks > room + 1e-12
    if not np.any(need):
        return 1.0
    return float(np.min(np.where(ks > 0, np.clip(room, 0.0, None) / np.where(ks > 0, ks, 1.0), 1.0)))
