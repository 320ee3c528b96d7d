"""glTF 2.0 (.gltf with files or data URIs, .glb) -> :class:`Asset`; the container (GLB chunks, buffers, URIs,
accessors, images, :func:`pack_glb`) is :mod:`pyrt.io.assets.gltf_file`, which also says what files a glTF may
make pyrt read.

Conventions (UV flip, colour spaces, defaults, ``KHR_lights_punctual`` units, cameras, instancing): see
:mod:`pyrt.io.assets`.
"""
from __future__ import annotations

import math

import numpy as np

from pyrt.core.transforms import quaternion_matrix, translation_matrix
from pyrt.textures import ChannelTexture, ImageTexture, NormalMap, TextureError
from pyrt.io.assets.common import AssetError, PBRParams, TextureSlot, malformed_is_asset_error
from pyrt.io.assets.alpha import ALPHA_MODES, alpha_texture
from pyrt.io.assets.asset import Asset, AssetCamera, AssetInstance, AssetLight, AssetMesh
from pyrt.io.assets.gltf_draco import DRACO, INSTALL_HINT, decode_draco_primitive, dracopy
from pyrt.io.assets.gltf_file import SUPPORTED_EXTENSIONS, GltfFile, pack_glb, read_gltf
from pyrt.io.assets.gltf_khr import METADATA_EXTENSIONS, read_material_extensions, read_spec_gloss, texture_source
from pyrt.io.assets import gltf_pose

__all__ = ["load_gltf", "gltf_node_transforms", "gltf_uv_transform", "pack_glb", "read_gltf"]
_WRAP = {10497: "repeat", 33071: "clamp", 33648: "mirror"}


def gltf_uv_transform(ext):
    """``KHR_texture_transform`` -> pyrt ImageTexture (scale, offset, rotation_deg) in flipped UVs.

    glTF applies ``uv' = T R S uv`` in its top-left space with ``R = [[c, s], [-s, c]]``. With
    ``p = (u, 1 - v)`` on both sides: ``p' = R_ccw(theta) S p + o``,
    ``o = (tx + sin(theta) sy, 1 - ty - cos(theta) sy)``.
    """
    tx, ty = (float(x) for x in ext.get("offset", (0.0, 0.0)))
    sx, sy = (float(x) for x in ext.get("scale", (1.0, 1.0)))
    th = float(ext.get("rotation", 0.0))
    offset = (tx + math.sin(th) * sy, 1.0 - ty - math.cos(th) * sy)
    return (sx, sy), offset, math.degrees(th)


def _gltf_texture(g, info, what, *, srgb, cache, kind="image", warnings=None, **extra):
    """Build a texture from a glTF textureInfo ``info`` ({index, texCoord, extensions}), or None when its image is a
    file that does not exist (recorded in ``g.substitutions``: the slot is rendered with its factor alone).

    ``cache`` (a dict, one per load) maps ``(image index, decoding)`` to the first texture made from
    those texels: later slots and materials reading the same image with the same decoding share its
    decoded level 0 and lazy MIP pyramid (:class:`ImageTexture` built from an ImageTexture) and keep
    their own sampler and transform.
    """
    ti = info.get("index")
    tex = g.get("textures", ti)
    src = texture_source(tex)
    if src is None:
        raise AssetError(f"{g.path}: {what}: texture {ti} has no image source in a supported format "
                         f"(extensions {sorted(tex.get('extensions', {}))})")
    key = (int(src), "srgb" if srgb else "linear", None)
    if key not in cache and g.missing_image(src) is not None:    # a substitution, not an error: the factor alone
        g.substitutions.append(f"{g.path}: {what}: image {src} file not found: {g.missing_image(src)}; rendered "
                               "with the factor alone")
        return None
    arr, label = (cache[key], cache[key].name) if key in cache else g.image_array(src, srgb=srgb)
    sampler = g.get("samplers", tex["sampler"]) if "sampler" in tex else {}
    wrap = (_WRAP.get(sampler.get("wrapS", 10497), "repeat"), _WRAP.get(sampler.get("wrapT", 10497), "repeat"))
    filt = "nearest" if sampler.get("magFilter") == 9728 and sampler.get("minFilter") in (9728, None) else "trilinear"
    texcoord = int(info.get("texCoord", 0))
    kw = {}
    tt = info.get("extensions", {}).get("KHR_texture_transform")
    if tt:
        scale, offset, rot = gltf_uv_transform(tt)
        kw = {"scale": scale, "offset": offset, "rotation_deg": rot}
        texcoord = int(tt.get("texCoord", texcoord))
    try:
        if kind == "normal":
            if filt == "nearest":       # the sampler's nearest filter (else NormalMap's bilinear default)
                kw["filter"] = "nearest"
            t = NormalMap(arr, strength=float(info.get("scale", 1.0)), wrap=wrap, name=label, texcoord=texcoord,
                          **kw, **extra)
        else:
            t = ImageTexture(arr, srgb=srgb, wrap=wrap, filter=filt, name=label, texcoord=texcoord, **kw, **extra)
    except TextureError as exc:
        raise AssetError(f"{g.path}: {what}: {exc}") from None
    cache.setdefault(key, t)
    return TextureSlot(texture=t, texcoord=texcoord, source=label, image=int(src))


def _material_images(h):
    """The image indices the materials of glTF header ``h`` read, in order: the sources of every textureInfo (a dict
    with an ``index`` under a key ending in ``Texture``, core or extension) of every material. Malformed entries
    are skipped (reading the material reports them)."""
    out = []
    textures = h.get("textures", [])

    def walk(node):
        if isinstance(node, dict):
            for key, val in node.items():
                if key.endswith("Texture") and isinstance(val, dict) and isinstance(val.get("index"), int) \
                        and 0 <= val["index"] < len(textures) and isinstance(textures[val["index"]], dict):
                    src = texture_source(textures[val["index"]])
                    if isinstance(src, int) and not isinstance(src, bool):
                        out.append(src)
                else:
                    walk(val)
        elif isinstance(node, list):
            for val in node:
                walk(val)
    walk(h.get("materials", []))
    return [i for i in out if 0 <= i < len(h.get("images", []))]


def _gltf_material(g, mi, warnings, cache):
    m = g.get("materials", mi)
    name = m.get("name", f"material{mi}")
    pbr = m.get("pbrMetallicRoughness", {})
    what = f"material {mi} ({name})"
    P = PBRParams(name=name)
    bcf = np.asarray(pbr.get("baseColorFactor", [1.0, 1.0, 1.0, 1.0]), dtype=np.float64)
    if bcf.shape != (4,):
        raise AssetError(f"{g.path}: {what}: baseColorFactor must have 4 numbers, got {bcf.tolist()}")
    P.base_color_factor = np.clip(bcf, 0.0, 1.0)
    P.metallic_factor = float(np.clip(pbr.get("metallicFactor", 1.0), 0.0, 1.0))
    P.roughness_factor = float(np.clip(pbr.get("roughnessFactor", 1.0), 0.0, 1.0))
    if "baseColorTexture" in pbr:
        P.base_color_texture = _gltf_texture(g, pbr["baseColorTexture"], f"{what} baseColorTexture", srgb=True,
                                             channels=3, cache=cache)
    if "metallicRoughnessTexture" in pbr:
        slot = _gltf_texture(g, pbr["metallicRoughnessTexture"], f"{what} metallicRoughnessTexture", srgb=False,
                            cache=cache)
        P.metallic_roughness_texture = slot
    if P.metallic_roughness_texture is not None:
        slot = P.metallic_roughness_texture
        raw = slot.texture
        if raw.channels < 3:
            raise AssetError(f"{g.path}: {what}: metallicRoughnessTexture {slot.source} has {raw.channels} "
                             "channel(s); need RGB (G = roughness, B = metallic)")
        P.metallic_texture = _channel(slot, 2, f"{slot.source} B (metallic)", cache)
        P.roughness_texture = _channel(slot, 1, f"{slot.source} G (roughness)", cache)
    read_spec_gloss(m, P, what, warnings,
                    lambda info, label, srgb: _gltf_texture(g, info, label, srgb=srgb, channels=3, cache=cache),
                    lambda i, srgb=False: g.image_array(i, srgb)[0])
    if "normalTexture" in m:
        P.normal_scale = float(m["normalTexture"].get("scale", 1.0))
        slot = _gltf_texture(g, m["normalTexture"], f"{what} normalTexture", srgb=False, kind="normal", cache=cache)
        P.normal_texture = None if slot is None else slot.texture
    if "occlusionTexture" in m:
        P.occlusion_strength = float(m["occlusionTexture"].get("strength", 1.0))
        slot = _gltf_texture(g, m["occlusionTexture"], f"{what} occlusionTexture", srgb=False, cache=cache)
        P.occlusion_texture = None if slot is None else _channel(slot, 0, f"{slot.source} R (occlusion)", cache)
    ef = np.asarray(m.get("emissiveFactor", [0.0, 0.0, 0.0]), dtype=np.float64)
    if ef.shape != (3,) or np.any(ef < 0):
        raise AssetError(f"{g.path}: {what}: emissiveFactor must be 3 numbers >= 0, got {ef.tolist()}")
    P.emissive_factor = ef
    if "emissiveTexture" in m:
        P.emissive_texture = _gltf_texture(g, m["emissiveTexture"], f"{what} emissiveTexture", srgb=True,
                                           channels=3, cache=cache)
    P.emissive_strength = float(m.get("extensions", {}).get("KHR_materials_emissive_strength", {})
                                .get("emissiveStrength", 1.0))
    P.double_sided = bool(m.get("doubleSided", False))
    P.alpha_mode = m.get("alphaMode", "OPAQUE")
    P.alpha_cutoff = float(m.get("alphaCutoff", 0.5))
    if P.alpha_mode not in ALPHA_MODES:
        warnings.append(f"{what}: unknown alphaMode {P.alpha_mode!r} rendered opaque")
        P.alpha_mode = "OPAQUE"
    if P.alpha_mode != "OPAQUE" and P.base_color_texture is not None:   # coverage: pyrt.io.assets.alpha
        slot = P.base_color_texture
        P.alpha_texture = alpha_texture(*g.image_array(slot.image, srgb=True), slot, cache)   # base colour's image
    read_material_extensions(
        m, P, what, warnings,
        lambda info, label, srgb, kind="image": _gltf_texture(g, info, label, srgb=srgb, cache=cache, kind=kind),
        lambda slot, c, label: _channel(slot, c, label, cache), lambda i: g.image_array(i)[0])
    P.texcoords = P.uv_sets_read()
    other = set(m.get("extensions", {})) - SUPPORTED_EXTENSIONS
    if other:
        warnings.append(f"{what}: material extension(s) {sorted(other)} ignored")
    return P


def _channel(slot, c, label, cache):
    """Channel ``c`` of a slot's ImageTexture as a 1-channel texture (:class:`pyrt.textures.ChannelTexture`: no
    copy; the channels of one image and sampler, e.g. a packed occlusion-roughness-metallic map, share one
    lookup per batch of hits). ``cache`` is unused (kept for the extension readers' signature)."""
    return ChannelTexture(slot.texture, c, name=label)


def _node_local(node):
    if "matrix" in node:
        m = np.asarray(node["matrix"], dtype=np.float64)
        if m.shape != (16,):
            raise ValueError(f"matrix must have 16 numbers, got {m.size}")
        return m.reshape(4, 4).T  # column-major
    m = np.eye(4)
    if "scale" in node:
        m = np.diag([*np.asarray(node["scale"], dtype=np.float64), 1.0]) @ m
    if "rotation" in node:
        x, y, z, w = (float(q) for q in node["rotation"])
        m = quaternion_matrix([w, x, y, z]) @ m
    if "translation" in node:
        m = translation_matrix(np.asarray(node["translation"], dtype=np.float64)) @ m
    return m


def gltf_node_transforms(header):
    """World transforms of the nodes of the default scene: {node index: (4, 4) world_from_node}."""
    nodes = header.get("nodes", [])
    scenes = header.get("scenes")
    if scenes:
        roots = scenes[header.get("scene", 0)].get("nodes", [])
    else:
        children = {c for n in nodes for c in n.get("children", [])}
        roots = [i for i in range(len(nodes)) if i not in children]
    out = {}
    stack = [(r, np.eye(4)) for r in roots]
    while stack:
        i, parent = stack.pop()
        if not isinstance(i, int) or not 0 <= i < len(nodes):
            raise AssetError(f"reference to node {i} but the file has {len(nodes)} nodes")
        if i in out:
            raise AssetError(f"node {i} is reached twice (a cycle or a node with two parents)")
        try:
            world = parent @ _node_local(nodes[i])
        except (ValueError, TypeError) as exc:
            raise AssetError(f"node {i}: invalid transform: {exc}") from None
        if not np.all(np.isfinite(world)):
            raise AssetError(f"node {i}: transform is not finite")
        out[i] = world
        stack.extend((c, world) for c in nodes[i].get("children", []))
    return out


def _strip_faces(idx, mode):
    n = idx.size
    if n < 3:
        return np.zeros((0, 3), dtype=np.int64)
    k = np.arange(n - 2)
    if mode == 5:  # strip: odd triangles flipped to keep the winding
        a = np.where(k % 2 == 0, idx[k], idx[k + 1])
        b = np.where(k % 2 == 0, idx[k + 1], idx[k])
        return np.stack([a, b, idx[k + 2]], axis=1)
    return np.stack([np.full(n - 2, idx[0]), idx[k + 1], idx[k + 2]], axis=1)  # fan


def load_gltf(path, max_texture=None):
    """Load a glTF 2.0 (.gltf + files / data URIs) or GLB file into an :class:`Asset`; images longer than
    ``max_texture`` texels are reduced as they are decoded (:mod:`pyrt.io.assets.texture_budget`; None: none).

    Raises
    ------
    AssetError
        Naming the file and the part for anything malformed, truncated, too large or refused (remote URIs:
        :mod:`pyrt.io.assets.gltf_file`).
    """
    with malformed_is_asset_error(path, "glTF"):
        return _load_gltf(path, max_texture)


def _load_gltf(path, max_texture=None):
    g = GltfFile(path, max_texture=max_texture)
    h = g.header
    asset = Asset(path=path, format="gltf", up_axis="+y")
    W = asset.warnings
    for ext in sorted(set(h.get("extensionsUsed", [])) - SUPPORTED_EXTENSIONS):
        W.append(f"extension {ext} is used by the file but not supported: ignored"
                 + (" (metadata only, no effect on the image)" if ext in METADATA_EXTENSIONS else ""))
    if DRACO in h.get("extensionsUsed", []) and dracopy() is None:    # (a file requiring it was refused)
        W.append(f"extension {DRACO} is used by the file but the DracoPy package is not installed: the "
                 f"uncompressed fallback is read ({INSTALL_HINT} to decode the Draco data)")
    try:
        world = gltf_node_transforms(h)
    except AssetError as exc:
        raise AssetError(f"{path}: {exc}") from None
    # materials
    g.prefetch_images(_material_images(h))       # decoded on all cores, before the slots read them in order
    textures = {}  # (image, decoding, channel) -> first texture of those texels: each image decoded once
    asset.materials = [_gltf_material(g, i, W, textures) for i in range(len(h.get("materials", [])))]
    for msg in g.substitutions:            # missing texture files: each slot rendered with its factor alone
        asset.substitute(msg)
    W.extend(g.reductions)                 # the texture budget's reductions
    asset.decode_time = g.decode_time
    # meshes: (glTF mesh index, morph weights) -> list of AssetMesh indices (one per triangle primitive)
    mesh_prims = {}
    skin_attrs = {}     # AssetMesh index -> (JOINTS (V, K), WEIGHTS (V, K)) of its primitive, when it has them

    def decode_mesh(mi, node):
        m = g.get("meshes", mi)
        prims = m.get("primitives", [])
        n_targets = max((len(p.get("targets", [])) for p in prims), default=0)
        weights = gltf_pose.default_weights(node, m, n_targets, f"mesh {mi} ({m.get('name', '')})", path)
        key = (mi, tuple(weights))
        if key in mesh_prims:
            return mesh_prims[key]
        ids = []
        for pi, p in enumerate(prims):
            where = f"mesh {mi} ({m.get('name', '')}) primitive {pi}"
            mode = p.get("mode", 4)
            if mode not in (4, 5, 6):
                W.append(f"{where}: mode {mode} (points/lines) skipped")
                continue
            attrs = p.get("attributes", {})
            if "POSITION" not in attrs:
                raise AssetError(f"{path}: {where}: no POSITION attribute")
            idx, decoded = None, {}        # Draco-decoded indices and attributes (None: DracoPy missing, fallback)
            if DRACO in p.get("extensions", {}):
                idx, decoded = decode_draco_primitive(g, p, where) or (None, {})

            def attribute(name):           # the Draco-decoded values first, else the accessor's
                return decoded[name] if name in decoded else g.accessor(attrs[name])

            pos = attribute("POSITION")
            if pos.shape[1] != 3:
                raise AssetError(f"{path}: {where}: POSITION must be VEC3")
            nv = pos.shape[0]
            if idx is None:
                idx = g.accessor(p["indices"]).astype(np.int64).ravel() if "indices" in p else np.arange(nv)
            if idx.size and (idx.min() < 0 or idx.max() >= nv):
                raise AssetError(f"{path}: {where}: index {int(idx.max())} out of range for {nv} vertices")
            if mode == 4:
                if idx.size % 3:
                    raise AssetError(f"{path}: {where}: {idx.size} indices is not a multiple of 3")
                faces = idx.reshape(-1, 3)
            else:
                faces = _strip_faces(idx, mode)
            if faces.shape[0] == 0:
                W.append(f"{where}: no triangles")
                continue
            normals = None
            if "NORMAL" in attrs:
                normals = attribute("NORMAL")[:, :3]
                ln = np.linalg.norm(normals, axis=1, keepdims=True)
                normals = np.divide(normals, ln, out=np.zeros_like(normals), where=ln > 0)
            tangents = None
            if "TANGENT" in attrs and normals is not None:
                tangents = attribute("TANGENT")
                if tangents.ndim != 2 or tangents.shape[1] != 4:
                    raise AssetError(f"{path}: {where}: TANGENT must be VEC4, got {tangents.shape[1:]} components")
            targets = p.get("targets", [])
            if targets:                    # the default pose: the targets at the node's / mesh's weights
                pos, normals = gltf_pose.morph(g, targets, weights[:len(targets)], pos, normals, where)
                if any("TANGENT" in t and w != 0 for t, w in zip(targets, weights)):
                    tangents = None        # morphed tangents are not applied: generated from the posed mesh instead
            mat = p.get("material", -1)
            if mat >= len(asset.materials):
                raise AssetError(f"{path}: {where}: material {mat} does not exist")
            # TEXCOORD_0 is the mesh's UVs; another set only when a texture of the material reads it
            uv_sets = {}
            for tc in sorted({0} | set(asset.materials[mat].texcoords if mat >= 0 else ())):
                if f"TEXCOORD_{tc}" in attrs:
                    uv_sets[tc] = attribute(f"TEXCOORD_{tc}")[:, :2].copy()
                    uv_sets[tc][:, 1] = 1.0 - uv_sets[tc][:, 1]          # glTF top-left -> pyrt bottom-left
                elif mat >= 0 and tc in asset.materials[mat].texcoords:
                    W.append(f"{where}: material {asset.materials[mat].name!r} has textures reading TEXCOORD_{tc} "
                             f"but the primitive has none (they read UV (0, 0))")
            uv = uv_sets.pop(0, None)
            colors = alpha = None
            if "COLOR_0" in attrs:
                col4 = attribute("COLOR_0")
                colors = np.clip(col4[:, :3], 0.0, None)
                if col4.shape[1] == 4:     # coverage alpha (used by MASK / BLEND materials only)
                    alpha = np.clip(col4[:, 3], 0.0, 1.0)
            for arr, nm in ((normals, "NORMAL"), (uv, "TEXCOORD_0"), *((a, f"TEXCOORD_{k}") for k, a in uv_sets.items()),
                            (colors, "COLOR_0"), (tangents, "TANGENT")):
                if arr is not None and arr.shape[0] != nv:
                    raise AssetError(f"{path}: {where}: {nm} has {arr.shape[0]} entries for {nv} vertices")
            asset.meshes.append(AssetMesh(name=f"{m.get('name', f'mesh{mi}')}.{pi}", vertices=pos, faces=faces,
                                          normals=normals, uv=uv, colors=colors, material=mat,
                                          alpha=alpha, uv_sets=uv_sets or None, tangents=tangents))
            ids.append(len(asset.meshes) - 1)
            sets = sorted(int(k[7:]) for k in attrs if k.startswith("JOINTS_") and k[7:].isdigit()
                          and f"WEIGHTS_{k[7:]}" in attrs)
            if sets:
                skin_attrs[ids[-1]] = (np.concatenate([attribute(f"JOINTS_{k}") for k in sets], axis=1),
                                       np.concatenate([attribute(f"WEIGHTS_{k}") for k in sets], axis=1))
        mesh_prims[key] = ids
        return ids

    skinned = {}        # (AssetMesh index, skin index) -> the AssetMesh posed by the skin's joints
    all_world = None

    def skinned_mesh(am, si, where):
        nonlocal all_world
        if (am, si) in skinned:
            return skinned[(am, si)]
        if am not in skin_attrs:
            W.append(f"{where}: the node has a skin but primitive {asset.meshes[am].name!r} has no JOINTS_0 / "
                     "WEIGHTS_0: drawn with the node's transform")
            skinned[(am, si)] = None
            return None
        if all_world is None:
            try:
                all_world = gltf_pose.all_node_transforms(h, _node_local)
            except AssetError as exc:
                raise AssetError(f"{path}: {exc}") from None
        src = asset.meshes[am]
        joints, weights = skin_attrs[am]
        jm = gltf_pose.joint_matrices(g, si, all_world, where)
        pos, nrm, faces = gltf_pose.skin(src.vertices, src.normals, src.faces, joints, weights, jm,
                                         f"{path}: {where}", W)
        asset.meshes.append(AssetMesh(name=f"{src.name}.skin{si}", vertices=pos, faces=faces, normals=nrm,
                                      uv=src.uv, colors=src.colors, material=src.material, alpha=src.alpha,
                                      face_colors=src.face_colors, uv_sets=src.uv_sets))
        skinned[(am, si)] = len(asset.meshes) - 1
        return skinned[(am, si)]

    lights_def = h.get("extensions", {}).get("KHR_lights_punctual", {}).get("lights", [])
    nodes = h.get("nodes", [])
    for ni in sorted(world):
        node = nodes[ni]
        M = world[ni]
        nname = node.get("name", f"node{ni}")
        if "mesh" in node:
            gpu = node.get("extensions", {}).get("EXT_mesh_gpu_instancing")
            mats = [M] if gpu is None else [M @ T for T in _gpu_instances(g, gpu, f"node {ni} ({nname})")]
            for am in decode_mesh(node["mesh"], node):
                if "skin" in node:         # posed by its joints; the node's own transform is ignored (glTF)
                    posed = skinned_mesh(am, node["skin"], f"node {ni} ({nname})")
                    if posed is not None:
                        asset.instances.append(AssetInstance(mesh=posed, world_from_object=np.eye(4), node=nname))
                        continue
                for j, Mj in enumerate(mats):
                    asset.instances.append(AssetInstance(mesh=am, world_from_object=Mj,
                                                         node=nname if gpu is None else f"{nname}[{j}]"))
        if "camera" in node:
            cam = g.get("cameras", node["camera"])
            if cam.get("type") == "perspective" and "perspective" in cam:
                pp = cam["perspective"]
                asset.cameras.append(AssetCamera(
                    name=cam.get("name", nname), position=M[:3, 3].copy(), forward=_unit(-M[:3, 2]),
                    up=_unit(M[:3, 1]), yfov_deg=math.degrees(float(pp["yfov"])), aspect=pp.get("aspectRatio")))
            else:
                W.append(f"camera {node['camera']} ({cam.get('type')}): only perspective cameras are supported")
        lext = node.get("extensions", {}).get("KHR_lights_punctual")
        if lext is not None:
            li = lext.get("light")
            if not isinstance(li, int) or not 0 <= li < len(lights_def):
                raise AssetError(f"{path}: node {ni} refers to KHR_lights_punctual light {li}, "
                                 f"but the file defines {len(lights_def)}")
            asset.lights.append(_gltf_light(lights_def[li], li, M, path))
    if not asset.instances:
        raise AssetError(f"{path}: the default scene has no triangle meshes")
    return asset


def _gpu_instances(g, ext, what):
    """The object-from-instance matrices (list of (4, 4)) of a node's ``EXT_mesh_gpu_instancing``: per instance
    ``T R S`` from its TRANSLATION (VEC3), ROTATION (VEC4 quaternion x, y, z, w; float or normalised integers)
    and SCALE (VEC3) accessors, each optional; all of one count. The node's mesh is drawn once per instance, its
    world matrix applied after the instance's (the extension's order)."""
    attrs = ext.get("attributes", {}) if isinstance(ext, dict) else None
    if not isinstance(attrs, dict) or not attrs:
        raise AssetError(f"{g.path}: {what}: EXT_mesh_gpu_instancing needs attributes (TRANSLATION, ROTATION, "
                         f"SCALE), got {attrs!r}")
    shapes = {"TRANSLATION": 3, "ROTATION": 4, "SCALE": 3}
    cols = {}
    for name, ai in attrs.items():
        if name not in shapes:
            continue           # custom per-instance attributes (_ID, _COLOR...): a shader's business, not read
        a = g.accessor(ai)
        if a.shape[1] != shapes[name]:
            raise AssetError(f"{g.path}: {what}: EXT_mesh_gpu_instancing {name} must have {shapes[name]} "
                             f"components, accessor {ai} has {a.shape[1]}")
        cols[name] = a
    counts = {k: v.shape[0] for k, v in cols.items()}
    if len(set(counts.values())) != 1:
        raise AssetError(f"{g.path}: {what}: EXT_mesh_gpu_instancing attributes have different counts {counts}")
    n = next(iter(counts.values()))
    out = []
    for j in range(n):
        m = np.eye(4)
        if "SCALE" in cols:
            m = np.diag([*cols["SCALE"][j], 1.0])
        if "ROTATION" in cols:
            x, y, z, w = cols["ROTATION"][j]
            m = quaternion_matrix([w, x, y, z]) @ m
        if "TRANSLATION" in cols:
            m = translation_matrix(cols["TRANSLATION"][j]) @ m
        out.append(m)
    return out


def _unit(v):
    n = np.linalg.norm(v)
    if not n > 0:
        raise AssetError("a camera or light node has a degenerate (zero-scale) transform")
    return v / n


def _gltf_light(d, li, M, path):
    kind = d.get("type")
    if kind not in ("point", "spot", "directional"):
        raise AssetError(f"{path}: KHR_lights_punctual light {li}: unknown type {kind!r}")
    color = np.asarray(d.get("color", [1.0, 1.0, 1.0]), dtype=np.float64)
    intensity = float(d.get("intensity", 1.0))
    if color.shape != (3,) or np.any(color < 0) or intensity < 0:
        raise AssetError(f"{path}: KHR_lights_punctual light {li}: color must be 3 numbers >= 0 and intensity >= 0")
    spot = d.get("spot", {})
    return AssetLight(name=d.get("name", f"light{li}"), kind=kind, color=color, intensity=intensity,
                      position=M[:3, 3].copy(), direction=_unit(-M[:3, 2]), range=d.get("range"),
                      inner_cone=float(spot.get("innerConeAngle", 0.0)),
                      outer_cone=float(spot.get("outerConeAngle", math.pi / 4)))
