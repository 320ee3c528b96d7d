"""glTF material extensions (KHR_materials_transmission / _ior / _volume / _specular / _clearcoat / _unlit) and
KHR_texture_transform on every slot, on glTF files written here (JSON + data-URI buffers and PNGs).

Ground truth: the extensions' formulas written out again in the tests (F0 from ior, Schlick, GGX), closed-form
transmittances of slabs (Fresnel at normal incidence and Beer-Lambert), quadrature of the clear coat's albedo.
"""
import base64
import io
import json
import math

import numpy as np
import pytest
import trimesh
from PIL import Image

import pyrt
from material_helpers import LocalCtx, direction
from pyrt.io import assets as A
from pyrt.io.assets import AssetError, load_asset
from pyrt.materials import Clearcoat, GltfPBR, Lambert, Unlit


def _b64(data):
    return "data:application/octet-stream;base64," + base64.b64encode(data).decode()


def _png_uri(arr):
    buf = io.BytesIO()
    Image.fromarray(np.asarray(arr, dtype=np.uint8)).save(buf, format="PNG")
    return "data:image/png;base64," + base64.b64encode(buf.getvalue()).decode()


def write_gltf(path, prims, materials, *, images=(), extensions_used=None, extensions_required=None):
    """A .gltf with one mesh + node per primitive ``{"pos", "faces", "uv", "color" (optional), "material"}``, its buffer a
    data URI, ``images`` (uint8 arrays) as PNG data URIs, one texture per image (nearest, repeat)."""
    blob = bytearray()
    views, accessors, meshes, nodes = [], [], [], []

    def add(arr, comp, typ, target=None):
        a = np.ascontiguousarray(arr)
        off = len(blob)
        blob.extend(a.tobytes())
        blob.extend(b"\0" * (-len(blob) % 4))
        views.append({"buffer": 0, "byteOffset": off, "byteLength": a.nbytes, **({"target": target} if target else {})})
        acc = {"bufferView": len(views) - 1, "componentType": comp, "count": int(a.shape[0]), "type": typ}
        if typ == "VEC3" and comp == 5126:
            acc["min"], acc["max"] = a.min(0).tolist(), a.max(0).tolist()
        accessors.append(acc)
        return len(accessors) - 1

    for i, p in enumerate(prims):
        attrs = {"POSITION": add(np.asarray(p["pos"], np.float32), 5126, "VEC3")}
        if p.get("uv") is not None:
            attrs["TEXCOORD_0"] = add(np.asarray(p["uv"], np.float32), 5126, "VEC2")
        if p.get("color") is not None:
            attrs["COLOR_0"] = add(np.asarray(p["color"], np.float32), 5126, "VEC3")
        idx = add(np.asarray(p["faces"], np.uint32).ravel(), 5125, "SCALAR")
        meshes.append({"primitives": [{"attributes": attrs, "indices": idx, "material": p["material"]}]})
        nodes.append({"mesh": i})
    h = {"asset": {"version": "2.0"}, "scene": 0, "scenes": [{"nodes": list(range(len(nodes)))}], "nodes": nodes,
         "meshes": meshes, "materials": materials, "accessors": accessors, "bufferViews": views,
         "buffers": [{"byteLength": len(blob), "uri": _b64(bytes(blob))}]}
    if images:
        h["images"] = [{"uri": _png_uri(im)} for im in images]
        h["samplers"] = [{"magFilter": 9728, "minFilter": 9728}]
        h["textures"] = [{"source": i, "sampler": 0} for i in range(len(images))]
    if extensions_used:
        h["extensionsUsed"] = extensions_used
    if extensions_required:
        h["extensionsRequired"] = extensions_required
    path.write_text(json.dumps(h))
    return str(path)


def _quad(z=0.0, size=1.0, material=0):
    s = size
    return {"pos": [[-s, -s, z], [s, -s, z], [s, s, z], [-s, s, z]], "faces": [[0, 1, 2], [0, 2, 3]],
            "uv": [[0, 1], [1, 1], [1, 0], [0, 0]], "material": material}


def _materials(path):
    a = load_asset(path)
    return a, [A.to_pyrt_material(p) for p in a.materials]


def _f0(ior):
    return ((ior - 1.0) / (ior + 1.0)) ** 2


# ---------------------------------------------------------------------------------------------- parsing

def test_each_extension_becomes_the_right_material_parameters(tmp_path):
    mats = [
        {"name": "thick", "pbrMetallicRoughness": {"baseColorFactor": [0.9, 0.8, 0.7, 1], "roughnessFactor": 0.0,
                                                   "metallicFactor": 0.0},
         "extensions": {"KHR_materials_transmission": {"transmissionFactor": 0.75},
                        "KHR_materials_ior": {"ior": 1.4},
                        "KHR_materials_volume": {"thicknessFactor": 0.2, "attenuationDistance": 2.0,
                                                 "attenuationColor": [0.5, 0.25, 1.0]}}},
        {"name": "thin", "extensions": {"KHR_materials_transmission": {"transmissionFactor": 1.0},
                                        "KHR_materials_volume": {"thicknessFactor": 0.0,
                                                                 "attenuationColor": [0.5, 0.5, 0.5]}}},
        {"name": "spec", "extensions": {"KHR_materials_specular": {"specularFactor": 0.3,
                                                                   "specularColorFactor": [2.0, 1.0, 0.5]},
                                        "KHR_materials_ior": {"ior": 2.0}}},
        {"name": "coat", "pbrMetallicRoughness": {"roughnessFactor": 0.6},
         "extensions": {"KHR_materials_clearcoat": {"clearcoatFactor": 0.7, "clearcoatRoughnessFactor": 0.1}}},
        {"name": "flat", "pbrMetallicRoughness": {"baseColorFactor": [0.2, 0.4, 0.6, 1]},
         "extensions": {"KHR_materials_unlit": {}}},
        {"name": "plain"},
    ]
    path = write_gltf(tmp_path / "m.gltf", [_quad(material=i) for i in range(len(mats))], mats)
    a, (thick, thin, spec, coat, flat, plain) = _materials(path)
    assert isinstance(thick, GltfPBR) and thick.transmits and thick.is_dielectric and not thick.thin
    assert (thick.transmission, thick.ior, thick.ior_value) == (0.75, 1.4, 1.4)
    np.testing.assert_allclose(thick.absorption, -np.log([0.5, 0.25, 1.0]) / 2.0)
    np.testing.assert_allclose(thick.tint, 0.75 * np.array([0.9, 0.8, 0.7]), rtol=1e-6)   # transparent shadows
    assert thin.thin and thin.transmits and np.all(np.asarray(thin.absorption) == 0)
    assert not spec.transmits and spec.ior is None and spec.specular == 0.3
    np.testing.assert_allclose(spec._f0_dielectric(None), np.minimum(_f0(2.0) * np.array([2.0, 1.0, 0.5]), 1.0))
    assert isinstance(coat, Clearcoat) and isinstance(coat.base, A.GltfMaterial)
    assert (coat.clearcoat, coat.roughness, coat.coat_ior, coat.fresnel) == (0.7, pytest.approx(0.1), 1.5, "view")
    assert isinstance(flat, Unlit) and not flat.has_diffuse
    np.testing.assert_allclose(flat.color, [0.2, 0.4, 0.6], rtol=1e-6)
    assert type(plain) is A.GltfMaterial            # no extension: the core material, pixels unchanged
    assert not a.warnings


def test_specular_colour_scales_f0_only_and_the_specular_factor_both():
    """KHR_materials_specular: a black specularColor leaves F90 = 1 (grazing reflection stays), a zero specularFactor
    removes the specular layer at every angle; F0 = min(f0(ior) x colour, 1) gives a mirror for a large colour."""
    black_base = dict(base_color=0.0, roughness=0.3)
    no_color = GltfPBR(specular_color=0.0, **black_base)
    no_spec = GltfPBR(specular=0.0, **black_base)
    mirror = GltfPBR(specular_color=30.0, **black_base)
    assert _albedo(no_color, 0.0).max() < 1e-4 and _albedo(no_color, 80.0).min() > 0.2   # (1 - v.h)^5 of tilted h only
    assert _albedo(no_spec, 0.0).max() == 0.0 and _albedo(no_spec, 80.0).max() == 0.0
    assert _albedo(mirror, 0.0).min() > 0.95                 # F0 = min(0.04 x 30, 1) = 1


def test_unknown_extensions_warn_and_unsupported_required_ones_say_why(tmp_path):
    mats = [{"name": "m", "extensions": {"KHR_materials_iridescence": {"iridescenceFactor": 1.0}}}]
    path = write_gltf(tmp_path / "u.gltf", [_quad()], mats, extensions_used=["KHR_materials_iridescence", "KHR_xmp"])
    w = load_asset(path).warnings
    assert any("KHR_materials_iridescence" in x and "not supported" in x for x in w)
    assert any("KHR_xmp" in x and "metadata" in x for x in w)
    assert any("material 0 (m)" in x and "KHR_materials_iridescence" in x for x in w)
    path = write_gltf(tmp_path / "r.gltf", [_quad()], [{}], extensions_used=["KHR_texture_basisu"],
                      extensions_required=["KHR_texture_basisu"])
    with pytest.raises(AssetError, match=r"KHR_texture_basisu \(KTX2 / Basis Universal textures"):
        load_asset(path)
    path = write_gltf(tmp_path / "ok.gltf", [_quad()], [{"extensions": {"KHR_materials_clearcoat": {}}}],
                      extensions_used=["KHR_materials_clearcoat"], extensions_required=["KHR_materials_clearcoat"])
    load_asset(path)                                 # a supported required extension loads


def test_extension_textures_read_the_channels_the_specs_name(tmp_path):
    img = np.zeros((2, 2, 4), np.uint8)
    img[..., 0], img[..., 1], img[..., 2], img[..., 3] = 51, 102, 153, 204      # R .2, G .4, B .6, A .8
    mats = [{"name": "t", "extensions": {
        "KHR_materials_transmission": {"transmissionFactor": 0.5, "transmissionTexture": {"index": 0}},
        "KHR_materials_specular": {"specularFactor": 0.5, "specularTexture": {"index": 0}},
        "KHR_materials_clearcoat": {"clearcoatFactor": 1.0, "clearcoatTexture": {"index": 0},
                                    "clearcoatRoughnessFactor": 0.5, "clearcoatRoughnessTexture": {"index": 0}}}}]
    path = write_gltf(tmp_path / "t.gltf", [_quad()], mats, images=[img])
    _, (m,) = _materials(path)
    ctx = LocalCtx(1)
    assert m.param(m.clearcoat, ctx, 1)[0] == pytest.approx(0.2)            # R
    assert m.param(m.roughness, ctx, 1)[0] == pytest.approx(0.5 * 0.4)      # G
    assert m.base.param(m.base.transmission, ctx, 1)[0] == pytest.approx(0.5 * 0.2)  # R
    assert m.base.param(m.base.specular, ctx, 1)[0] == pytest.approx(0.5 * 0.8)      # A


# ---------------------------------------------------------------------------------------------- clear coat

def _albedo(mat, theta_o, n_t=400, n_p=256, phi_o=0.0):
    """Directional albedo (3,) toward (theta_o, phi_o) by midpoint quadrature in (cos theta, phi) (error < 1e-3
    for these lobes)."""
    c = (np.arange(n_t) + 0.5) / n_t
    ph = (np.arange(n_p) + 0.5) / n_p * 2 * np.pi
    C, P = np.meshgrid(c, ph, indexing="ij")
    s = np.sqrt(1 - C * C)
    wi = np.stack([s * np.cos(P), s * np.sin(P), C], -1).reshape(-1, 3)
    wo = np.tile(direction(theta_o, phi_o), (wi.shape[0], 1))
    return mat.f_cos(wo, wi, LocalCtx(wi.shape[0])).sum(0) * (2 * np.pi / (n_t * n_p))


def _ggx_spec_cos(wo, wi, alpha):
    """D G2 / (4 cos_o), GGX with height-correlated Smith, written out (Walter 2007, Heitz 2014)."""
    h = wo + wi
    h /= np.linalg.norm(h, axis=1, keepdims=True)
    a2 = alpha * alpha
    D = a2 / (np.pi * (h[:, 2] ** 2 * (a2 - 1) + 1) ** 2)

    def lam(c):
        return (np.sqrt(1 + a2 * (1 - c * c) / (c * c)) - 1) / 2
    G = 1 / (1 + lam(wo[:, 2]) + lam(wi[:, 2]))
    return D * G / (4 * wo[:, 2])


@pytest.mark.parametrize("theta_o", [0.0, 60.0, 89.0])
def test_clearcoat_fresnel_weighting_matches_the_spec_closed_form(theta_o):
    """f = base (1 - c F(n.v)) + c F(n.v) D G / (4 cos_o), F = 0.04 + 0.96 (1 - n.v)^5, at normal and grazing view."""
    base = Lambert(albedo=(0.5, 0.3, 0.1))
    c, r = 0.8, 0.3
    coat = Clearcoat(base, clearcoat=c, roughness=r)
    rng = np.random.default_rng(7)
    wi = rng.normal(size=(500, 3))
    wi[:, 2] = np.abs(wi[:, 2]) + 0.01
    wi /= np.linalg.norm(wi, axis=1, keepdims=True)
    wo = np.tile(direction(theta_o, 20.0), (500, 1))
    F = 0.04 + 0.96 * (1 - wo[0, 2]) ** 5
    expected = (np.array([0.5, 0.3, 0.1]) / np.pi * wi[:, 2:3] * (1 - c * F)
                + (c * F * _ggx_spec_cos(wo, wi, r * r))[:, None])
    np.testing.assert_allclose(coat.f_cos(wo, wi, LocalCtx(500)), expected, rtol=1e-9)
    assert coat.coat_weight(wo[:1], LocalCtx(1))[0] == pytest.approx(c * F, rel=1e-12)
    if theta_o == 0.0:
        assert F == pytest.approx(0.04)
    if theta_o == 89.0:
        assert F > 0.8


@pytest.mark.parametrize("theta_o", [0.0, 45.0, 80.0, 88.0])
@pytest.mark.parametrize("roughness", [0.3, 0.6])
def test_clearcoat_white_furnace_at_most_one(theta_o, roughness):
    """Over a white Lambert base (albedo 1) the coated albedo stays <= 1 at every view (quadrature error < 2e-3;
    coats smoother than ~0.3 need finer nodes near the mirror direction) and above the base's 1 - c F(n.v) share."""
    coat = Clearcoat(Lambert(albedo=1.0), clearcoat=1.0, roughness=roughness)
    rho = _albedo(coat, theta_o)
    F = 0.04 + 0.96 * (1 - math.cos(math.radians(theta_o))) ** 5
    assert np.all(rho <= 1.0 + 2e-3), rho
    assert np.all(rho >= 1.0 - F - 2e-3)


def test_clearcoat_half_vector_variant_is_reciprocal_but_gains_energy_at_grazing_view():
    """fresnel="half" (F at v.h) is reciprocal; over a white base its albedo exceeds 1 at grazing view, which is
    why the spec's n.v weighting is the default."""
    coat = Clearcoat(Lambert(albedo=1.0), clearcoat=1.0, roughness=0.3, fresnel="half")
    assert coat.reciprocal
    rng = np.random.default_rng(8)
    a, b = np.abs(rng.normal(size=(300, 3))), np.abs(rng.normal(size=(300, 3)))
    a /= np.linalg.norm(a, axis=1, keepdims=True)
    b /= np.linalg.norm(b, axis=1, keepdims=True)
    np.testing.assert_allclose(coat.f_cos(a, b, LocalCtx(300)) / b[:, 2:3], coat.f_cos(b, a, LocalCtx(300)) / a[:, 2:3],
                               rtol=1e-9)
    assert _albedo(coat, 85.0).max() > 1.2              # measured 1.267 (view: 0.899)
    assert _albedo(Clearcoat(Lambert(albedo=1.0), clearcoat=1.0, roughness=0.3), 85.0).max() <= 1.0 + 2e-3


def test_clearcoat_normal_map_tilts_the_coat_lobe_only():
    """A coat normal map of constant tangent-space normal n_c: the coat term is the closed form in n_c's frame
    (F at wo.n_c, D and G about n_c), the base term is unchanged (still about the shading normal)."""
    tilt = math.atan(0.3)
    n_c = np.array([math.sin(tilt), 0.0, math.cos(tilt)])
    img = np.broadcast_to((n_c + 1) / 2, (2, 2, 3)).astype(np.float32)
    nm = pyrt.NormalMap(np.ascontiguousarray(img))
    base = Lambert(albedo=(0.5, 0.3, 0.1))
    c, r = 1.0, 0.3
    coat = Clearcoat(base, clearcoat=c, roughness=r, normal_map=nm)
    rng = np.random.default_rng(9)
    wi = rng.normal(size=(400, 3))
    wi[:, 2] = np.abs(wi[:, 2]) + 0.2
    wi /= np.linalg.norm(wi, axis=1, keepdims=True)
    wo = np.tile(direction(30.0, 10.0), (400, 1))
    ctx = LocalCtx(400)
    ctx.wo = wo
    R = np.array([[math.cos(tilt), 0, math.sin(tilt)], [0, 1, 0], [-math.sin(tilt), 0, math.cos(tilt)]])  # z -> n_c
    wo_c, wi_c = wo @ R, wi @ R                         # coordinates in a frame whose z is n_c
    assert np.allclose(R @ [0, 0, 1], n_c)
    F = 0.04 + 0.96 * (1 - wo_c[0, 2]) ** 5
    ok = wi_c[:, 2] > 0
    coat_term = np.where(ok, c * F * _ggx_spec_cos(wo_c, np.where(ok[:, None], wi_c, [0, 0, 1.0]), r * r), 0.0)
    expected = np.array([0.5, 0.3, 0.1]) / np.pi * wi[:, 2:3] * (1 - c * F) + coat_term[:, None]
    np.testing.assert_allclose(coat.f_cos(wo, wi, ctx), expected, rtol=1e-6, atol=1e-12)


def test_clearcoat_ignores_the_base_normal_map():
    """A base with a normal map perturbed the shading normal (local z); the coat's lobe stays about the normal
    before that map (``ns_unmapped``), as the spec's separate clearcoatNormal says: the coat term is the closed
    form about the unmapped normal, the base's about z."""
    tilt = math.atan(0.4)
    n0 = np.array([0.0, math.sin(tilt), math.cos(tilt)])       # unmapped normal in the mapped shading frame
    base = Lambert(albedo=(0.5, 0.3, 0.1))
    base.normal_map = pyrt.NormalMap(np.full((2, 2, 3), 0.5, np.float32))   # any map: the base declares one
    coat = Clearcoat(base, clearcoat=1.0, roughness=0.3)
    rng = np.random.default_rng(10)
    wi = rng.normal(size=(300, 3))
    wi[:, 2] = np.abs(wi[:, 2]) + 0.2
    wi /= np.linalg.norm(wi, axis=1, keepdims=True)
    wo = np.tile(direction(35.0, 60.0), (300, 1))
    ctx = LocalCtx(300)
    ctx.ns_unmapped = np.tile(n0, (300, 1))
    R = np.array([[1, 0, 0], [0, math.cos(tilt), math.sin(tilt)], [0, -math.sin(tilt), math.cos(tilt)]])  # z -> n0
    assert np.allclose(R @ [0, 0, 1], n0)
    wo_c, wi_c = wo @ R, wi @ R
    F = 0.04 + 0.96 * (1 - wo_c[0, 2]) ** 5
    ok = wi_c[:, 2] > 0
    coat_term = np.where(ok, F * _ggx_spec_cos(wo_c, np.where(ok[:, None], wi_c, [0, 0, 1.0]), 0.09), 0.0)
    expected = np.array([0.5, 0.3, 0.1]) / np.pi * wi[:, 2:3] * (1 - F) + coat_term[:, None]
    np.testing.assert_allclose(coat.f_cos(wo, wi, ctx), expected, rtol=1e-6, atol=1e-12)


# ---------------------------------------------------------------------------------------------- renders

def _camera(z=5.0, fov=4.0, n=8):
    return pyrt.Camera((0, 0, z), (0, 0, 0), fov=fov, width=n, height=n, spp=1, jitter=False)


def test_unlit_renders_exactly_its_colour_under_lights(tmp_path):
    mats = [{"pbrMetallicRoughness": {"baseColorFactor": [0.2, 0.4, 0.6, 1.0]}, "extensions": {"KHR_materials_unlit": {}}}]
    path = write_gltf(tmp_path / "u.gltf", [_quad()], mats, extensions_used=["KHR_materials_unlit"])
    scene = pyrt.Scene(_camera(), ambient=0.3)
    load_asset(path).add_to_scene(scene)
    scene.add_light(pyrt.PointLight((0.3, 0.2, 2.0), intensity=50.0))
    for integrator in ("whitted", "glossy"):
        img = pyrt.render_full(scene, integrator=integrator).image
        np.testing.assert_allclose(img, np.broadcast_to([0.2, 0.4, 0.6], img.shape), rtol=1e-6)


def test_unlit_colour_is_base_factor_times_texture_times_vertex_colour(tmp_path):
    """KHR_materials_unlit: the pixel is baseColorFactor x baseColorTexture (sRGB-decoded) x COLOR_0 (linear)."""
    tex = np.full((2, 2, 3), (200, 100, 50), np.uint8)
    q = _quad()
    q["color"] = [[0.5, 1.0, 0.25]] * 4
    mats = [{"pbrMetallicRoughness": {"baseColorFactor": [0.8, 0.6, 1.0, 1.0], "baseColorTexture": {"index": 0}},
             "extensions": {"KHR_materials_unlit": {}}}]
    path = write_gltf(tmp_path / "v.gltf", [q], mats, images=[tex])
    scene = pyrt.Scene(_camera())
    load_asset(path).add_to_scene(scene)
    scene.add_light(pyrt.DirectionalLight((0.0, 0.0, -1.0), 3.0))
    img = pyrt.render(scene)
    want = (np.array([0.8, 0.6, 1.0]) * pyrt.shaders.color.srgb_decode(np.array([200, 100, 50]) / 255.0)
            * np.array([0.5, 1.0, 0.25]))
    np.testing.assert_allclose(img, np.broadcast_to(want, img.shape), rtol=1e-5)


def _emitter_behind(tmp_path, front_prims, front_mats, E=(1.0, 2.0, 4.0), name="s.gltf"):
    """``front_prims`` (material indices from 1) in front of an emissive quad at z = -2 (material 0)."""
    mats = [{"emissiveFactor": list(E), "pbrMetallicRoughness": {"baseColorFactor": [0, 0, 0, 1]}}] + front_mats
    path = write_gltf(tmp_path / name, [_quad(z=-2.0, size=5.0, material=0)] + front_prims, mats)
    scene = pyrt.Scene(_camera())
    load_asset(path).add_to_scene(scene)
    return scene


@pytest.mark.parametrize("sigma_d", [0.0, 0.7])
@pytest.mark.parametrize("ior", [1.5, 1.8])
def test_slab_transmittance_is_fresnel_squared_times_beer_lambert(tmp_path, ior, sigma_d):
    """A glass slab (KHR_materials_volume, thickness d) in front of an emitter at normal incidence transmits
    ``(1 - R)^2 tau / (1 - R^2 tau^2)`` per channel, ``tau = exp(-sigma_a d)``, ``R = ((n - 1)/(n + 1))^2``,
    ``sigma_a = -ln(color) / distance`` (the series of internal reflections; max_depth 8 keeps three round trips,
    the rest is < 1e-10; rays within 2 degrees of the normal: R and the path length change by < 2e-4)."""
    d = 0.5
    color = np.array([1.0, 0.6, 0.3]) ** (sigma_d / 0.7 if sigma_d else 0.0)
    dist = 1.3
    box = trimesh.creation.box(extents=(3.0, 3.0, d))
    slab = {"pos": box.vertices, "faces": box.faces, "material": 1}
    vol = {"thicknessFactor": d, "attenuationDistance": dist, "attenuationColor": color.tolist()}
    front = [{"pbrMetallicRoughness": {"roughnessFactor": 0.0, "metallicFactor": 0.0},
              "extensions": {"KHR_materials_transmission": {"transmissionFactor": 1.0},
                             "KHR_materials_ior": {"ior": ior}, "KHR_materials_volume": vol}}]
    scene = _emitter_behind(tmp_path, [slab], front)
    img = pyrt.render(scene)
    R = _f0(ior)
    tau = np.exp(-(-np.log(color) / dist) * d)
    expected = np.array([1.0, 2.0, 4.0]) * (1 - R) ** 2 * tau / (1 - R * R * tau * tau)
    np.testing.assert_allclose(img[3:5, 3:5].reshape(-1, 3), np.broadcast_to(expected, (4, 3)), rtol=2e-4)


def test_a_thin_wall_in_front_of_a_slab_does_not_change_its_medium(tmp_path):
    """A thin wall (no volume) encloses no medium (Material.thin_walled): in front of an absorbing slab the pixel is
    the closed form of the two in series, ``T_w T_s / (1 - R_w R_s)``, with the slab entered from vacuum (a thin
    wall taken for a volume of index 1.5 would make the slab's Fresnel ((1.8 - 1.5)/(1.8 + 1.5))^2 on entry)."""
    d, ior = 0.5, 1.8
    box = trimesh.creation.box(extents=(3.0, 3.0, d))
    slab = {"pos": box.vertices, "faces": box.faces, "material": 1}
    vol = {"thicknessFactor": d, "attenuationDistance": 1.0, "attenuationColor": [0.8, 0.6, 0.4]}
    front = [{"pbrMetallicRoughness": {"roughnessFactor": 0.0, "metallicFactor": 0.0},
              "extensions": {"KHR_materials_transmission": {"transmissionFactor": 1.0},
                             "KHR_materials_ior": {"ior": ior}, "KHR_materials_volume": vol}},
             {"pbrMetallicRoughness": {"roughnessFactor": 0.0, "metallicFactor": 0.0},
              "extensions": {"KHR_materials_transmission": {"transmissionFactor": 1.0}}}]
    scene = _emitter_behind(tmp_path, [slab, _quad(z=1.0, size=2.0, material=2)], front)
    assert scene.materials[2].thin_walled and not scene.materials[1].thin_walled
    img = pyrt.render(scene, split_depth=None)     # the full tree: exact, no random branch choice
    R = _f0(ior)
    tau = np.exp(np.log([0.8, 0.6, 0.4]) * d)
    slab_t = (1 - R) ** 2 * tau / (1 - R * R * tau * tau)
    slab_r = R + (1 - R) ** 2 * R * tau * tau / (1 - R * R * tau * tau)
    wall_t, wall_r = 1 - 0.04, 0.04                                  # thin wall: T (1 - F0) and F0, both sides
    expected = np.array([1.0, 2.0, 4.0]) * wall_t * slab_t / (1 - wall_r * slab_r)   # two elements in series
    np.testing.assert_allclose(img[3:5, 3:5].reshape(-1, 3), np.broadcast_to(expected, (4, 3)), rtol=2e-4)


def test_thin_transmission_goes_straight_through_weighted_one_minus_f(tmp_path):
    """A thin wall (no volume) at normal incidence passes ``T base (1 - F0)`` straight on (no refraction: the emitter
    behind is seen unmoved), plus what the opaque share ``1 - T`` would show (nothing here: no lights)."""
    T = 0.6
    front = [{"pbrMetallicRoughness": {"roughnessFactor": 0.0, "metallicFactor": 0.0,
                                       "baseColorFactor": [1.0, 0.5, 0.25, 1]},
              "extensions": {"KHR_materials_transmission": {"transmissionFactor": T}}}]
    scene = _emitter_behind(tmp_path, [_quad(z=0.0, size=2.0, material=1)], front)
    img = pyrt.render(scene)
    expected = np.array([1.0, 2.0, 4.0]) * T * np.array([1.0, 0.5, 0.25]) * (1 - 0.04)
    np.testing.assert_allclose(img[3:5, 3:5].reshape(-1, 3), np.broadcast_to(expected, (4, 3)), rtol=2e-4)


def test_rough_transmission_integrates_like_its_smooth_limit_in_a_furnace():
    """Energy of the rough lobes: reflection + transmission (radiance compression undone) <= 1 and close to the
    smooth interface's 1 at normal incidence (single-scattering GGX loses a few % at roughness 0.5)."""
    for thin in (True, False):
        m = GltfPBR(base_color=1.0, roughness=0.5, transmission=1.0, thin=thin, ior=1.5)
        up = _albedo(m, 0.0)

        class Below:
            def f_cos(self, wo, wi, ctx):
                return m.f_cos(wo, wi * [1, 1, -1], ctx)
        down = _albedo(Below(), 0.0) * (1.0 if thin else 1.5 ** 2)
        total = up + down
        assert np.all(total <= 1.0 + 2e-3) and np.all(total >= 0.9), (thin, total)


@pytest.mark.parametrize("thin", [True, False])
@pytest.mark.parametrize("theta_o", [0.0, 45.0, 80.0])
def test_smooth_transmission_delta_lobes_sum_to_the_transmissive_share(thin, theta_o):
    """Smooth (roughness 0) transmission 0.7 over a white base: reflected + transmitted (x eta^2) delta weights
    equal w = 0.7 exactly, from outside and from inside (total internal reflection included); the opaque share
    0.3 is the GGX lobes'."""
    m = GltfPBR(base_color=1.0, roughness=0.0, transmission=0.7, thin=thin, ior=1.5)
    wo = np.tile(direction(theta_o, 15.0), (4, 1))
    ctx = LocalCtx(4)
    ctx.front[2:] = False
    total = np.zeros((4, 3))
    for lobe in m.delta_lobes(wo, ctx):
        total += lobe.weight * ((lobe.eta ** 2)[:, None] if lobe.kind == "refract" else 1.0)
    np.testing.assert_allclose(total, 0.7, rtol=1e-12)


def _sampling_cases():
    tilt = np.broadcast_to((np.array([0.25, -0.1, 1.0]) / np.linalg.norm([0.25, -0.1, 1.0]) + 1) / 2, (2, 2, 3))
    nm = pyrt.NormalMap(np.ascontiguousarray(tilt, dtype=np.float32))
    return {"thin_rough": GltfPBR(base_color=(0.9, 0.7, 0.5), roughness=0.5, transmission=0.6, thin=True),
            "volume_rough": GltfPBR(base_color=(0.9, 0.7, 0.5), roughness=0.5, transmission=0.6, thin=False, ior=1.4),
            # full transmission: the reflection's specular layer is still there and must be sampled
            "thin_full": GltfPBR(base_color=(0.9, 0.7, 0.5), roughness=0.5, transmission=1.0, thin=True),
            "volume_full": GltfPBR(base_color=(0.9, 0.7, 0.5), roughness=0.3, transmission=1.0, thin=False, ior=1.5),
            "coat_normal_map": Clearcoat(GltfPBR(base_color=(0.2, 0.5, 0.8), roughness=0.6), clearcoat=0.9,
                                         roughness=0.4, normal_map=nm)}


@pytest.mark.parametrize("case", ["thin_rough", "volume_rough", "thin_full", "volume_full", "coat_normal_map"])
@pytest.mark.parametrize("theta_o", [25.0, 70.0])
def test_sampling_of_transmission_and_coat_frames_matches_pdf_and_f(case, theta_o):
    """sample(): pdf equals pdf(), weight = f_cos / pdf, E[weight] (transmission x eta^2 for a volume) equals the
    albedo by quadrature over the sphere within 5 standard errors; chi-square of the upper hemisphere (the
    contract tests' harness) p > 1e-4."""
    from test_material_contracts import _chi_square_p

    mat = _sampling_cases()[case]
    n = 60_000
    wo = np.tile(direction(theta_o, 30.0), (n, 1))
    wi, weight, pdf = mat.sample(wo, np.random.default_rng(3).random((n, 2)), LocalCtx(n))
    ok = pdf > 0
    k = int(ok.sum())
    np.testing.assert_allclose(pdf[ok], mat.pdf(wo[ok], wi[ok], LocalCtx(k)), rtol=1e-9)
    np.testing.assert_allclose(weight[ok] * pdf[ok][:, None], mat.f_cos(wo[ok], wi[ok], LocalCtx(k)), rtol=1e-9,
                               atol=1e-300)
    assert np.all(np.isfinite(weight)) and np.all(weight[~ok] == 0)
    eta2 = mat.ior ** 2 if (mat.transmits and not mat.thin) else 1.0
    w = np.where((wi[:, 2] < 0)[:, None], weight * eta2, weight)

    class Below:
        def f_cos(self, a, b, ctx):
            return mat.f_cos(a, b * [1, 1, -1], ctx)
    rho = _albedo(mat, theta_o, phi_o=30.0) + (_albedo(Below(), theta_o, phi_o=30.0) * eta2 if mat.transmits else 0.0)
    mean, se = w.mean(0), w.std(0) / math.sqrt(n)
    assert np.all(np.abs(mean - rho) <= 5 * se + 3e-3), (mean, rho, se)
    assert _chi_square_p(mat, theta_o) > 1e-4


# ---------------------------------------------------------------------------------------------- texture transform

def _transformed_texel(uv, ext, shape):
    """The texel (row, col) glTF's ``T R S uv`` lands on (nearest, repeat), uv in glTF's top-left convention."""
    tx, ty = ext.get("offset", (0, 0))
    sx, sy = ext.get("scale", (1, 1))
    r = ext.get("rotation", 0.0)
    c, s = math.cos(r), math.sin(r)
    M = np.array([[1, 0, tx], [0, 1, ty], [0, 0, 1]]) @ np.array([[c, s, 0], [-s, c, 0], [0, 0, 1]]) \
        @ np.diag([sx, sy, 1.0])
    g = (M @ np.array([uv[0], uv[1], 1.0]))[:2] % 1.0
    return int(g[1] * shape[0]), int(g[0] * shape[1])


@pytest.mark.parametrize("slot", ["emissiveTexture", "normalTexture", "occlusionTexture", "metallicRoughnessTexture",
                                  "clearcoatTexture"])
def test_texture_transform_moves_the_texels_of_every_slot(tmp_path, slot):
    """KHR_texture_transform (offset, rotation, scale) on a slot: the texture at a glTF UV reads the texel the
    spec's matrix maps that UV to."""
    rng = np.random.default_rng(11)
    img = rng.integers(0, 256, size=(8, 8, 3), dtype=np.uint8)
    ext = {"offset": [0.25, 0.125], "rotation": 0.5, "scale": [1.5, 0.75]}
    info = {"index": 0, "extensions": {"KHR_texture_transform": ext}}
    m = {"name": "x"}
    if slot == "clearcoatTexture":
        m["extensions"] = {"KHR_materials_clearcoat": {"clearcoatFactor": 1.0, slot: info}}
    elif slot == "metallicRoughnessTexture":
        m["pbrMetallicRoughness"] = {slot: info}
    else:
        m[slot] = info
    path = write_gltf(tmp_path / "t.gltf", [_quad()], [m], images=[img], extensions_used=["KHR_texture_transform"])
    P = load_asset(path).materials[0]
    tex, chan = {"emissiveTexture": (lambda: P.emissive_texture.texture, slice(0, 3)),
                 "normalTexture": (lambda: P.normal_texture, slice(0, 3)),
                 "occlusionTexture": (lambda: P.occlusion_texture, 0),
                 "metallicRoughnessTexture": (lambda: P.roughness_texture, 1),
                 "clearcoatTexture": (lambda: P.clearcoat_texture, 0)}[slot]
    tex = tex()
    for uv in rng.random((20, 2)) * 0.9 + 0.05:
        row, col = _transformed_texel(uv, ext, img.shape)
        got = np.asarray(tex.lookup(np.array([[uv[0], 1.0 - uv[1]]]))).ravel()
        want = img[row, col, chan] / 255.0
        if slot == "emissiveTexture":
            want = pyrt.shaders.color.srgb_decode(want)
        np.testing.assert_allclose(got[:np.size(want)], np.ravel(want), atol=2e-3)


def test_texture_transform_texcoord_override_is_honoured(tmp_path):
    """``KHR_texture_transform.texCoord`` replaces the textureInfo's texCoord (the slot's UV set)."""
    img = np.full((2, 2, 3), 128, np.uint8)
    info = {"index": 0, "texCoord": 0, "extensions": {"KHR_texture_transform": {"texCoord": 1}}}
    path = write_gltf(tmp_path / "t.gltf", [_quad()], [{"emissiveTexture": info}], images=[img])
    assert load_asset(path).materials[0].emissive_texture.texcoord == 1


# ---------------------------------------------------------------------------------------------- previewer

def test_previewer_lets_light_through_glass_and_casts_a_shadow_under_an_opaque_twin(tmp_path):
    """pyrt-preview's rig on a glass ball (thin-walled transmission 1) and on the same ball opaque (same framing):
    where the opaque ball's shadow darkens the ground below 0.7 of the backdrop, the glass ball's ground keeps
    on average more than 0.75 of it (two interfaces at 1 - R each, R of the ray's angle, along straight lines)."""
    from pyrt.apps import preview as P
    from pyrt.shaders import color as C

    ball = trimesh.creation.icosphere(subdivisions=3, radius=0.5)
    glass = {"pbrMetallicRoughness": {"roughnessFactor": 0.0, "metallicFactor": 0.0},
             "extensions": {"KHR_materials_transmission": {"transmissionFactor": 1.0}}}
    opaque = {"pbrMetallicRoughness": {"roughnessFactor": 0.5, "metallicFactor": 0.0}}
    ratio = {}
    for name, mat in (("glass", glass), ("opaque", opaque)):
        path = write_gltf(tmp_path / f"{name}.gltf", [{"pos": ball.vertices, "faces": ball.faces, "material": 0}], [mat])
        ps = P.PreviewScene(load_asset(path), P.PreviewOptions(width=48, height=36, spp=1))
        try:
            img = ps.render_view(35.0).image
            ratio[name] = np.where(ps.model_mask(), np.nan, C.luminance(img) / C.luminance(ps.scene.background))
        finally:
            ps.close()
    shadow = ratio["opaque"] < 0.7
    assert shadow.sum() > 10
    assert np.nanmean(ratio["glass"][shadow]) > 0.75, np.nanmean(ratio["glass"][shadow])


@pytest.mark.parametrize("n", [1, 3, 4])
def test_rough_transmission_samples_any_number_of_hits(n):
    """The transmission lobe's sampling probability is one per hit for every batch size (three hits once made a
    3 x 3 Fresnel table: a (3,) F0 read as RGB), and sample() equals the per-hit samples."""
    m = GltfPBR(base_color=(0.9, 0.7, 0.5), roughness=0.5, transmission=1.0, thin=True, specular=0.8)
    rng = np.random.default_rng(n)
    wo = np.stack([direction(t, 20.0) for t in rng.uniform(0.0, 85.0, n)])
    u = rng.random((n, 2))
    wi, weight, pdf = m.sample(wo, u, LocalCtx(n))
    assert wi.shape == (n, 3) and weight.shape == (n, 3) and pdf.shape == (n,)
    for k in range(n):
        one = m.sample(wo[k:k + 1], u[k:k + 1], LocalCtx(1))
        np.testing.assert_allclose(one[0][0], wi[k], rtol=1e-12)
        np.testing.assert_allclose(one[2][0], pdf[k], rtol=1e-12)
