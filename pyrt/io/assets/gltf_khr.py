"""glTF material extensions (``KHR_materials_*``) read into :class:`PBRParams`, and the extension lists a loader
checks: what pyrt renders, what it ignores with a warning, and why a required one it cannot honour is refused.

What each extension becomes (the materials: :mod:`pyrt.materials.gltf_pbr`; the mapping:
:func:`pyrt.io.assets.materials.to_pyrt_material`):

- ``KHR_materials_transmission`` (transmissionFactor x transmissionTexture R): the weight of a transmission lobe
  tinted by the base colour; ``KHR_materials_ior`` (ior, default 1.5) its index and the dielectric F0;
- ``KHR_materials_volume``: with ``thicknessFactor > 0`` the mesh bounds a volume (refraction, nested media) whose
  medium absorbs ``sigma_a = -ln(attenuationColor) / attenuationDistance`` per scene unit (world units, as the
  extension defines them); without it, or with thickness 0, a thin wall (light goes straight through).
  ``thicknessTexture`` is a rasteriser's stand-in for the distance a ray tracer measures: not read, and no
  warning (nothing is lost);
- ``KHR_materials_specular`` (specularFactor x specularTexture A, specularColorFactor x specularColorTexture
  RGB, sRGB): the dielectric F0 scale and tint; ``KHR_materials_ior`` without transmission: F0 from ior;
- ``KHR_materials_clearcoat`` (clearcoatFactor x clearcoatTexture R, clearcoatRoughnessFactor x
  clearcoatRoughnessTexture G, clearcoatNormalTexture perturbing the normal before the base's normal map):
  :class:`pyrt.materials.Clearcoat` over the material;
- ``KHR_materials_unlit``: :class:`pyrt.materials.Unlit` of the base colour (x texture x vertex colour);
- ``KHR_materials_sheen`` (sheenColorFactor x sheenColorTexture RGB, sRGB; sheenRoughnessFactor x
  sheenRoughnessTexture A): :class:`pyrt.materials.Sheen` over the material, under a clear coat;
- ``KHR_materials_anisotropy`` (anisotropyStrength x anisotropyTexture B, anisotropyRotation radians, the direction
  ``2 anisotropyTexture.RG - 1`` rotated by it in the tangent frame, linear data): the anisotropic GGX reflection
  of :class:`pyrt.materials.GltfPBR` (``alpha_t = mix(alpha, 1, strength^2)`` along the direction, ``alpha`` across
  it); a material with a strength is a :class:`~pyrt.materials.GltfPBR` even without the other extensions;
- ``KHR_materials_pbrSpecularGlossiness`` (archived, still common in older exports): converted on load as
  glTF-Transform's ``metalRough()`` does (:func:`read_spec_gloss`): the diffuse colour becomes the base colour
  (``metallic = 0``), the specular colour the ``KHR_materials_specular`` F0 tint of a dielectric, ``roughness =
  1 - glossiness``.

A file that requires an extension of :data:`REQUIRED_REASONS` (or one pyrt does not know) is refused with the
reason; ``KHR_draco_mesh_compression`` (geometry, :mod:`pyrt.io.assets.gltf_draco`) only when DracoPy, the
``[draco]`` extra, is not installed (:data:`MISSING_PACKAGE_REASONS`: the message says what to install).
"""
from __future__ import annotations

import math

import numpy as np

from pyrt.io.assets.common import AssetError
from pyrt.io.assets.gltf_draco import DRACO, DRACO_MISSING
from pyrt.textures import ImageTexture

#: material extensions this module reads
MATERIAL_EXTENSIONS = {"KHR_materials_transmission", "KHR_materials_ior", "KHR_materials_volume",
                       "KHR_materials_clearcoat", "KHR_materials_specular", "KHR_materials_unlit",
                       "KHR_materials_pbrSpecularGlossiness", "KHR_materials_sheen", "KHR_materials_anisotropy"}
#: the index of refraction a converted specular-glossiness material gets: its F0 comes from the specular colour
#: (``specular_color_factor = specular / f0(SPEC_GLOSS_IOR)``, so ``F0 = specular`` exactly below 1), and a
#: dielectric of this index reflects ~all light at normal incidence (glTF-Transform's ``metalRough()`` uses 1000)
SPEC_GLOSS_IOR = 1000.0
#: texture extensions whose image (``textures[i].extensions[name].source``) pyrt decodes (Pillow's WebP and AVIF
#: codecs), in the order they are preferred over the texture's own ``source`` (a PNG / JPEG fallback, if any)
IMAGE_EXTENSIONS = ("EXT_texture_webp", "EXT_texture_avif")
#: extensions that carry metadata only (no effect on the image): ignored without a warning about the picture
METADATA_EXTENSIONS = {"KHR_xmp", "KHR_xmp_json_ld"}
#: why pyrt cannot render a file that *requires* these (the message of the refusal)
REQUIRED_REASONS = {
    "KHR_texture_basisu": "KTX2 / Basis Universal textures, which pyrt cannot decode",
}

#: why a file that *requires* these is refused when the optional package that decodes them is not installed
MISSING_PACKAGE_REASONS = {DRACO: DRACO_MISSING}


def texture_source(tex):
    """The image index a glTF texture ``tex`` (a dict) is read from: the source of the first of
    :data:`IMAGE_EXTENSIONS` it has, else its core ``source`` (None when it has neither, e.g. KTX2 only)."""
    ext = tex.get("extensions", {})
    for name in IMAGE_EXTENSIONS:
        src = ext.get(name, {}).get("source") if isinstance(ext.get(name), dict) else None
        if src is not None:
            return src
    return tex.get("source")


def read_spec_gloss(m, P, what, warnings, texture, image_array):
    """Convert material ``m``'s ``KHR_materials_pbrSpecularGlossiness`` into ``P`` (:class:`PBRParams`), replacing
    its ``pbrMetallicRoughness`` (the fallback such files carry); no-op without the extension.

    The specular-glossiness model (the archived extension's Appendix) reflects ``F0 = specular`` with GGX of
    ``alpha = (1 - glossiness)^2`` over a Lambert diffuse of ``diffuse``. As glTF-Transform's ``metalRough()``:
    ``baseColor = diffuseFactor x diffuseTexture`` (its alpha the coverage), ``metallic = 0``, ``roughness = 1 -
    glossinessFactor x specularGlossinessTexture.A``, and the dielectric's F0 tint ``KHR_materials_specular``
    ``specularColor = specularFactor x specularGlossinessTexture.RGB / f0(ior)`` with ``ior =``
    :data:`SPEC_GLOSS_IOR`, so that ``F0 = specular`` (clamped to 1). The diffuse weight is then glTF's
    ``1 - F`` rather than the archived model's ``1 - max(specular)``: a documented difference of the conversion.

    ``texture(info, label, srgb)`` builds a :class:`TextureSlot` of the RGB channels (None for a missing file: the
    factor alone);
    ``image_array(i, srgb)`` gives image ``i``'s decoded codes with their alpha (``srgb``: read by a colour slot).
    """
    sg = m.get("extensions", {}).get("KHR_materials_pbrSpecularGlossiness") if isinstance(
        m.get("extensions"), dict) else None
    if sg is None:
        return
    w = f"{what} KHR_materials_pbrSpecularGlossiness"
    diffuse = np.asarray(sg.get("diffuseFactor", [1.0, 1.0, 1.0, 1.0]), dtype=np.float64)
    if diffuse.shape != (4,) or not np.all(np.isfinite(diffuse)):
        raise AssetError(f"{w}: diffuseFactor must be 4 numbers, got {diffuse.tolist()}")
    specular = np.clip(_color3(sg, "specularFactor", w), 0.0, 1.0)
    gloss = min(_number(sg, "glossinessFactor", 1.0, w, warnings, lo=0.0), 1.0)
    P.base_color_factor = np.clip(diffuse, 0.0, 1.0)
    P.base_color_texture = texture(sg["diffuseTexture"], f"{w} diffuseTexture", True) \
        if "diffuseTexture" in sg else None
    P.metallic_factor, P.metallic_texture, P.metallic_roughness_texture = 0.0, None, None
    P.roughness_factor, P.roughness_texture = 1.0 - gloss, None
    P.ior = SPEC_GLOSS_IOR
    P.specular_factor = 1.0
    P.specular_color_factor = specular / ((SPEC_GLOSS_IOR - 1.0) / (SPEC_GLOSS_IOR + 1.0)) ** 2
    if "specularGlossinessTexture" in sg:
        slot = texture(sg["specularGlossinessTexture"], f"{w} specularGlossinessTexture", True)
        if slot is not None:
            P.ext_slots.append(slot)
            P.specular_color_texture = slot
            arr = image_array(slot.image, srgb=True)         # the colour slot's image (its A reduced as values)
            if arr.ndim == 3 and arr.shape[2] in (2, 4):     # glossiness in A (none: A = 1, roughness 1 - factor)
                a = arr[:, :, -1]
                if a.dtype == np.uint8 and gloss == 1.0:     # 255 - A: the same codes, exact
                    rough = np.ascontiguousarray(np.uint8(255) - a)
                else:
                    rough = (1.0 - gloss * a.astype(np.float32) / np.float32(np.iinfo(a.dtype).max)).astype(np.float32)
                t = slot.texture
                P.roughness_factor = 1.0
                P.roughness_texture = ImageTexture(rough, srgb=False, wrap=t.wrap, filter=t.filter, scale=t.scale,
                                                   offset=t.offset, rotation_deg=t.rotation_deg,
                                                   name=f"{slot.source} 1 - A (glossiness)", texcoord=t.texcoord)


def required_extension_error(path, names):
    """The :class:`AssetError` for a file that requires extensions pyrt does not support (or cannot read without
    an optional package that is not installed), with the reason for each."""
    reasons = REQUIRED_REASONS | MISSING_PACKAGE_REASONS
    parts = [f"{n} ({reasons.get(n, 'not implemented')})" for n in sorted(names)]
    return AssetError(f"{path}: requires unsupported glTF extension(s): {'; '.join(parts)}; the file declares "
                      "that it cannot be displayed correctly without them (extensionsRequired)")


def _number(d, key, default, what, warnings, *, lo=None):
    v = d.get(key, default)
    if isinstance(v, bool) or not isinstance(v, (int, float)) or not math.isfinite(v) and v != math.inf:
        raise AssetError(f"{what}: {key} must be a number, got {v!r}")
    v = float(v)
    if lo is not None and v < lo:
        warnings.append(f"{what}: {key} {v} < {lo}: clamped to {lo}")
        v = lo
    return v


def _color3(d, key, what, default=(1.0, 1.0, 1.0)):
    v = np.asarray(d.get(key, default), dtype=np.float64)
    if v.shape != (3,) or not np.all(np.isfinite(v)) or np.any(v < 0):
        raise AssetError(f"{what}: {key} must be 3 numbers >= 0, got {v.tolist()}")
    return v


def read_material_extensions(m, P, what, warnings, texture, channel, image_array):
    """Fill the extension fields of ``P`` (:class:`PBRParams`) from material ``m``'s ``extensions``.

    ``texture(info, label, srgb, kind="image")`` builds a :class:`TextureSlot` from a textureInfo (the loader's,
    with ``KHR_texture_transform`` and texCoord; ``kind="normal"``: a :class:`pyrt.NormalMap`); ``channel(slot, c, label)`` a 1-channel texture of channel ``c``;
    ``image_array(i)`` the decoded texels of image ``i`` with their alpha (which textures drop).
    """
    ext = m.get("extensions", {})
    if not isinstance(ext, dict):
        raise AssetError(f"{what}: extensions must be an object")

    def scalar_tex(d, key, c, cname):
        if key not in d:
            return None
        slot = texture(d[key], f"{what} {key}", False)
        if slot is None:    # a missing image file: the factor alone (a substitution the loader records)
            return None
        P.ext_slots.append(slot)
        if c == 3:          # alpha: from the decoded image (textures keep RGB); none: glTF reads A = 1
            arr = image_array(slot.image)
            if arr.ndim < 3 or arr.shape[2] not in (2, 4):
                return None
            t = slot.texture
            return ImageTexture(np.ascontiguousarray(arr[:, :, -1]), srgb=False, wrap=t.wrap, filter=t.filter,
                                scale=t.scale, offset=t.offset, rotation_deg=t.rotation_deg,
                                name=f"{slot.source} A ({key})", texcoord=t.texcoord)
        if slot.texture.channels <= c:
            raise AssetError(f"{what}: {key} {slot.source} has {slot.texture.channels} channel(s); "
                             f"the extension reads {cname}")
        return channel(slot, c, f"{slot.source} {cname} ({key})")

    if "KHR_materials_unlit" in ext:
        P.unlit = True
    ior_ext = ext.get("KHR_materials_ior")
    if ior_ext is not None:
        ior = _number(ior_ext, "ior", 1.5, f"{what} KHR_materials_ior", warnings)
        if ior < 1.0:
            warnings.append(f"{what}: KHR_materials_ior ior {ior} < 1 is not supported: 1.5 used")
            ior = 1.5
        P.ior = ior
    tr = ext.get("KHR_materials_transmission")
    if tr is not None:
        w = f"{what} KHR_materials_transmission"
        P.transmission_factor = min(_number(tr, "transmissionFactor", 0.0, w, warnings, lo=0.0), 1.0)
        P.transmission_texture = scalar_tex(tr, "transmissionTexture", 0, "R")
    vol = ext.get("KHR_materials_volume")
    if vol is not None:
        w = f"{what} KHR_materials_volume"
        P.thickness_factor = _number(vol, "thicknessFactor", 0.0, w, warnings, lo=0.0)
        dist = _number(vol, "attenuationDistance", math.inf, w, warnings)
        if not dist > 0:
            raise AssetError(f"{w}: attenuationDistance must be > 0, got {dist}")
        color = np.clip(_color3(vol, "attenuationColor", w), 0.0, 1.0)
        P.attenuation_color, P.attenuation_distance = color, dist
        # thicknessTexture is not read and not warned about: it stands in, for rasterisers, for the distance a ray
        # tracer measures (the extension: path tracers may ignore it); nothing of the model is lost
        if tr is None:
            warnings.append(f"{w}: volume without KHR_materials_transmission has no effect")
    sp = ext.get("KHR_materials_specular")
    if sp is not None:
        w = f"{what} KHR_materials_specular"
        P.specular_factor = min(_number(sp, "specularFactor", 1.0, w, warnings, lo=0.0), 1.0)
        P.specular_texture = scalar_tex(sp, "specularTexture", 3, "A")
        P.specular_color_factor = _color3(sp, "specularColorFactor", w)
        if "specularColorTexture" in sp:
            slot = texture(sp["specularColorTexture"], f"{w} specularColorTexture", True)
            if slot is not None:
                P.ext_slots.append(slot)
                P.specular_color_texture = slot
    sh = ext.get("KHR_materials_sheen")
    if sh is not None:
        w = f"{what} KHR_materials_sheen"
        P.sheen_color_factor = np.clip(_color3(sh, "sheenColorFactor", w, default=(0.0, 0.0, 0.0)), 0.0, 1.0)
        P.sheen_roughness_factor = min(_number(sh, "sheenRoughnessFactor", 0.0, w, warnings, lo=0.0), 1.0)
        if "sheenColorTexture" in sh:
            slot = texture(sh["sheenColorTexture"], f"{w} sheenColorTexture", True)
            if slot is not None:
                P.ext_slots.append(slot)
                P.sheen_color_texture = slot
        P.sheen_roughness_texture = scalar_tex(sh, "sheenRoughnessTexture", 3, "A")
    an = ext.get("KHR_materials_anisotropy")
    if an is not None:
        w = f"{what} KHR_materials_anisotropy"
        P.anisotropy_strength = _number(an, "anisotropyStrength", 0.0, w, warnings, lo=0.0)
        if P.anisotropy_strength > 1.0:
            warnings.append(f"{w}: anisotropyStrength {P.anisotropy_strength} > 1: clamped to 1")
            P.anisotropy_strength = 1.0
        P.anisotropy_rotation = _number(an, "anisotropyRotation", 0.0, w, warnings)
        if not math.isfinite(P.anisotropy_rotation):
            raise AssetError(f"{w}: anisotropyRotation must be finite, got {P.anisotropy_rotation}")
        if "anisotropyTexture" in an:
            slot = texture(an["anisotropyTexture"], f"{w} anisotropyTexture", False)
            if slot is not None:
                if slot.texture.channels < 3:
                    raise AssetError(f"{w}: anisotropyTexture {slot.source} has {slot.texture.channels} channel(s); "
                                     "the extension reads RGB")
                P.ext_slots.append(slot)
                P.anisotropy_texture = slot.texture
    cc = ext.get("KHR_materials_clearcoat")
    if cc is not None:
        w = f"{what} KHR_materials_clearcoat"
        P.clearcoat_factor = min(_number(cc, "clearcoatFactor", 0.0, w, warnings, lo=0.0), 1.0)
        P.clearcoat_texture = scalar_tex(cc, "clearcoatTexture", 0, "R")
        P.clearcoat_roughness_factor = min(_number(cc, "clearcoatRoughnessFactor", 0.0, w, warnings, lo=0.0), 1.0)
        P.clearcoat_roughness_texture = scalar_tex(cc, "clearcoatRoughnessTexture", 1, "G")
        if "clearcoatNormalTexture" in cc:
            slot = texture(cc["clearcoatNormalTexture"], f"{w} clearcoatNormalTexture", False, "normal")
            if slot is not None:
                P.ext_slots.append(slot)
                P.clearcoat_normal_texture = slot.texture
    if P.unlit and len(set(ext) & (MATERIAL_EXTENSIONS - {"KHR_materials_unlit"})):
        warnings.append(f"{what}: KHR_materials_unlit with other material extensions: unlit wins")
