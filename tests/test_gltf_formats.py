"""glTF files as other tools write them: WebP / AVIF textures (EXT_texture_webp, EXT_texture_avif), the archived
specular-glossiness material (KHR_materials_pbrSpecularGlossiness, converted on load) and GPU instancing
(EXT_mesh_gpu_instancing)."""
import base64
import io
import json
import math

import numpy as np
import pytest
from PIL import Image, features

from material_helpers import LocalCtx
from test_gltf_materials import _materials, _quad, write_gltf
from pyrt.core.image_io import read_image
from pyrt.core.image_types import image_kind
from pyrt.io.assets import AssetError, load_asset
from pyrt.io.assets.gltf_khr import SPEC_GLOSS_IOR


_NO_AVIF = pytest.mark.skipif(not features.check("avif"), reason="this Pillow has no AVIF codec (wheels >= 11.3 do)")


def _encoded(arr, fmt, **kw):
    buf = io.BytesIO()
    Image.fromarray(np.asarray(arr, dtype=np.uint8)).save(buf, format=fmt, **kw)
    return buf.getvalue()


def _rewrite(path, edit):
    h = json.loads(open(path).read())
    edit(h)
    open(path, "w").write(json.dumps(h))
    return str(path)


def _texel(mat_texture, n=1):
    """A texture's value at UV (0.5, 0.5) (LocalCtx's UV), (3,) or scalar."""
    return np.asarray(mat_texture.evaluate(LocalCtx(n)))[0]


# ---------------------------------------------------------------------------------------------- WebP / AVIF

def test_webp_and_avif_files_are_recognised_and_decoded(tmp_path):
    rng = np.random.default_rng(3)
    rgba = (rng.random((6, 10, 4)) * 255).astype(np.uint8)
    (tmp_path / "a.webp").write_bytes(_encoded(rgba, "WEBP", lossless=True, exact=True))
    np.testing.assert_array_equal(read_image(tmp_path / "a.webp"), rgba)         # lossless: the known pixels
    smooth = np.zeros((16, 16, 3), np.uint8)
    smooth[..., 0] = np.linspace(20, 230, 16)[None, :]
    smooth[..., 1] = 128
    smooth[..., 2] = np.linspace(200, 40, 16)[:, None]
    if not features.check("avif"):
        return                                            # this Pillow has no AVIF codec (wheels >= 11.3 do)
    (tmp_path / "b.avif").write_bytes(_encoded(smooth, "AVIF", quality=100))
    got = read_image(tmp_path / "b.avif")
    assert got.shape == (16, 16, 3) and got.dtype == np.uint8
    np.testing.assert_array_equal(got, np.asarray(Image.open(tmp_path / "b.avif").convert("RGB")))
    assert np.abs(got.astype(int) - smooth).max() <= 8      # lossy, 4:2:0 chroma: a smooth ramp survives
    assert image_kind(b"RIFF\0\0\0\0WEBPVP8L") == "WebP" and image_kind(b"\0\0\0\x1cftypavif") == "AVIF"
    assert image_kind(b"RIFF\0\0\0\0WAVEfmt ") is None


@pytest.mark.parametrize("fmt, ext", [("WEBP", "EXT_texture_webp"),
                                      pytest.param("AVIF", "EXT_texture_avif", marks=_NO_AVIF)])
def test_a_texture_reads_the_extension_image_before_its_fallback(tmp_path, fmt, ext):
    colour = np.zeros((4, 4, 3), np.uint8)
    colour[...] = (200, 60, 30)
    fallback = np.zeros((4, 4, 3), np.uint8)          # black PNG: read only by viewers without the extension
    path = write_gltf(tmp_path / "t.gltf", [_quad()], [{"pbrMetallicRoughness": {"baseColorTexture": {"index": 0}}}],
                      images=[fallback])
    blob = _encoded(colour, fmt, **({"lossless": True} if fmt == "WEBP" else {"quality": 100}))

    def edit(h):
        h["images"].append({"uri": f"data:image/{fmt.lower()};base64," + base64.b64encode(blob).decode()})
        h["textures"][0]["extensions"] = {ext: {"source": 1}}
        h["extensionsUsed"] = [ext]
    _rewrite(path, edit)
    asset, (mat,) = _materials(path)
    assert not any(ext in w for w in asset.warnings)
    srgb = np.asarray(colour[0, 0], float) / 255
    lin = np.where(srgb <= 0.04045, srgb / 12.92, ((srgb + 0.055) / 1.055) ** 2.4)
    tol = 1e-6 if fmt == "WEBP" else 0.03                 # AVIF: lossy even at quality 100
    np.testing.assert_allclose(_texel(mat.base_color), lin, atol=tol)

    def only_extension(h):                                # required, no fallback source: loads as well
        del h["textures"][0]["source"]
        h["extensionsRequired"] = [ext]
    _rewrite(path, only_extension)
    _, (mat,) = _materials(path)
    np.testing.assert_allclose(_texel(mat.base_color), lin, atol=tol)


def test_an_embedded_image_of_another_type_is_named(tmp_path):
    path = write_gltf(tmp_path / "t.gltf", [_quad()], [{"pbrMetallicRoughness": {"baseColorTexture": {"index": 0}}}],
                      images=[np.zeros((2, 2, 3), np.uint8)])
    _rewrite(path, lambda h: h["images"][0].update(uri="data:image/ktx2;base64," +
                                                   base64.b64encode(b"\xabKTX 20\xbb\r\n\x1a\n" + bytes(64)).decode()))
    with pytest.raises(AssetError, match=r"image 0 \(data URI\): not a PNG, JPEG, WebP or AVIF image"):
        load_asset(path)


# ---------------------------------------------------------------------------------------------- spec-gloss

def _spec_gloss(tmp_path, sg, images=()):
    mats = [{"name": "sg", "pbrMetallicRoughness": {"baseColorFactor": [0, 1, 0, 1], "metallicFactor": 1.0},
             "extensions": {"KHR_materials_pbrSpecularGlossiness": sg}}]
    return write_gltf(tmp_path / "sg.gltf", [_quad()], mats, images=images,
                      extensions_used=["KHR_materials_pbrSpecularGlossiness"],
                      extensions_required=["KHR_materials_pbrSpecularGlossiness"])


def test_spec_gloss_specular_lobe_matches_the_closed_form_at_normal_incidence(tmp_path):
    """Black diffuse: at wo = wi = n the model's BRDF x cos is ``F0 D(n) G / 4 = specular / (4 pi alpha^2)``
    (GGX D(n) = 1 / (pi alpha^2), Smith G = 1 at normal incidence), alpha = (1 - glossiness)^2."""
    spec, gloss = np.array([0.9, 0.6, 0.2]), 0.5
    path = _spec_gloss(tmp_path, {"diffuseFactor": [0, 0, 0, 1], "specularFactor": spec.tolist(),
                                  "glossinessFactor": gloss})
    asset, (mat,) = _materials(path)
    assert not any("SpecularGlossiness" in w for w in asset.warnings)
    P = asset.materials[0]
    assert P.metallic_factor == 0.0 and P.roughness_factor == pytest.approx(1 - gloss) and P.ior == SPEC_GLOSS_IOR
    z = np.array([[0.0, 0.0, 1.0]])
    alpha = (1 - gloss) ** 2
    np.testing.assert_allclose(mat.f_cos(z, z, LocalCtx(1))[0], spec / (4 * math.pi * alpha ** 2), rtol=1e-9)


def test_spec_gloss_without_specular_is_lambert_of_the_diffuse_colour_at_normal_incidence(tmp_path):
    diffuse = [0.7, 0.5, 0.25, 1.0]
    path = _spec_gloss(tmp_path, {"diffuseFactor": diffuse, "specularFactor": [0, 0, 0]})
    _, (mat,) = _materials(path)
    z = np.array([[0.0, 0.0, 1.0]])
    np.testing.assert_allclose(mat.f_cos(z, z, LocalCtx(1))[0], np.array(diffuse[:3]) / math.pi, rtol=1e-12)


def test_spec_gloss_textures_give_diffuse_specular_colour_and_one_minus_glossiness(tmp_path):
    diff = np.zeros((2, 2, 4), np.uint8)
    diff[...] = (255, 128, 0, 255)
    sgt = np.zeros((2, 2, 4), np.uint8)
    sgt[...] = (255, 255, 255, 51)                        # specular white (sRGB 1), glossiness 0.2
    path = _spec_gloss(tmp_path, {"diffuseTexture": {"index": 0}, "specularGlossinessTexture": {"index": 1},
                                  "specularFactor": [0.5, 0.25, 1.0], "glossinessFactor": 1.0}, images=[diff, sgt])
    asset, (mat,) = _materials(path)
    P = asset.materials[0]
    assert _texel(P.roughness_texture) == pytest.approx(1 - 51 / 255)
    c = 128 / 255
    np.testing.assert_allclose(_texel(mat.base_color), [1.0, ((c + 0.055) / 1.055) ** 2.4, 0.0], rtol=1e-6)
    np.testing.assert_allclose(mat._f0_dielectric(LocalCtx(1))[0], [0.5, 0.25, 1.0], rtol=1e-6)   # F0 = specular
    path = _spec_gloss(tmp_path, {"specularGlossinessTexture": {"index": 0}, "glossinessFactor": 0.5},
                       images=[sgt])
    assert _texel(load_asset(path).materials[0].roughness_texture) == pytest.approx(1 - 0.5 * 51 / 255, rel=1e-6)


# ---------------------------------------------------------------------------------------------- instancing

def _instanced(tmp_path, translations, rotations=None, scales=None, node_translation=(0, 0, 0)):
    path = write_gltf(tmp_path / "i.gltf", [_quad(size=0.5)], [{}])

    def edit(h):
        blob = bytearray(base64.b64decode(h["buffers"][0]["uri"].split(",", 1)[1]))
        attrs = {}
        for name, arr in (("TRANSLATION", translations), ("ROTATION", rotations), ("SCALE", scales)):
            if arr is None:
                continue
            a = np.asarray(arr, np.float32)
            h["bufferViews"].append({"buffer": 0, "byteOffset": len(blob), "byteLength": a.nbytes})
            blob.extend(a.tobytes())
            h["accessors"].append({"bufferView": len(h["bufferViews"]) - 1, "componentType": 5126,
                                   "count": a.shape[0], "type": "VEC4" if a.shape[1] == 4 else "VEC3"})
            attrs[name] = len(h["accessors"]) - 1
        h["buffers"][0] = {"byteLength": len(blob), "uri": "data:application/octet-stream;base64,"
                           + base64.b64encode(bytes(blob)).decode()}
        h["nodes"][0]["extensions"] = {"EXT_mesh_gpu_instancing": {"attributes": attrs}}
        h["nodes"][0]["translation"] = list(node_translation)
        h["extensionsUsed"] = h["extensionsRequired"] = ["EXT_mesh_gpu_instancing"]
    return _rewrite(path, edit)


def test_gpu_instances_are_node_times_translation_rotation_scale(tmp_path):
    s = math.sqrt(0.5)
    path = _instanced(tmp_path, [[0, 0, 0], [2, 0, 0], [0, 3, 0]],
                      rotations=[[0, 0, 0, 1], [0, 0, s, s], [0, 0, 0, 1]],      # 90 deg about z for the second
                      scales=[[1, 1, 1], [1, 1, 1], [2, 2, 2]], node_translation=(0, 0, 5))
    asset = load_asset(path)
    assert not any("EXT_mesh_gpu_instancing" in w for w in asset.warnings)
    assert len(asset.instances) == 3 and asset.n_triangles == 6
    corner = np.array([0.5, -0.5, 0.0, 1.0])               # vertex 1 of the quad
    want = [[0.5, -0.5, 5.0], [2.5, 0.5, 5.0], [1.0, 2.0, 5.0]]
    for inst, w in zip(asset.instances, want):
        np.testing.assert_allclose((inst.world_from_object @ corner)[:3], w, atol=1e-6)


def test_gpu_instances_with_different_counts_are_refused_naming_the_node(tmp_path):
    path = _instanced(tmp_path, [[0, 0, 0], [1, 0, 0]], scales=[[1, 1, 1]])
    with pytest.raises(AssetError, match=r"node 0 .*EXT_mesh_gpu_instancing attributes have different counts"):
        load_asset(path)
