"""glTF 2.0 (.gltf with files or data URIs, .glb) -> :class:`Asset`, and :func:`pack_glb` to write GLB.

Conventions (UV flip, colour spaces, defaults, ``KHR_lights_punctual`` units, cameras, instancing): see
:mod:`pyrt.io.assets`.
"""
from __future__ import annotations

import base64
import json
import math
import os
import struct
import tempfile
import urllib.parse

import numpy as np
import trimesh

from pyrt.textures import ImageTexture, NormalMap, TextureError, load_image
from pyrt.io.assets.common import AssetError, PBRParams, TextureSlot
from pyrt.io.assets.asset import Asset, AssetCamera, AssetInstance, AssetLight, AssetMesh

_COMPONENT = {5120: np.int8, 5121: np.uint8, 5122: np.int16, 5123: np.uint16, 5125: np.uint32, 5126: np.float32}
_NCOMP = {"SCALAR": 1, "VEC2": 2, "VEC3": 3, "VEC4": 4, "MAT2": 4, "MAT3": 9, "MAT4": 16}
_WRAP = {10497: "repeat", 33071: "clamp", 33648: "mirror"}
_GLB_MAGIC = 0x46546C67
_CHUNK_JSON = 0x4E4F534A
_CHUNK_BIN = 0x004E4942


class _Gltf:
    """A parsed glTF container: JSON header, buffers (bytes), base directory for URIs."""

    def __init__(self, path):
        self.path = path
        self.base = os.path.dirname(os.path.abspath(path))
        with open(path, "rb") as fh:
            data = fh.read()
        glb_bin = None
        if data[:4] == b"glTF":
            if len(data) < 20:
                raise AssetError(f"{path}: truncated GLB header ({len(data)} bytes)")
            magic, version, length = struct.unpack_from("<III", data, 0)
            if version != 2:
                raise AssetError(f"{path}: GLB version {version} is not supported (need 2)")
            if length > len(data):
                raise AssetError(f"{path}: GLB header says {length} bytes but the file has {len(data)} (truncated)")
            off, chunks = 12, []
            while off + 8 <= length:
                clen, ctype = struct.unpack_from("<II", data, off)
                if off + 8 + clen > length:
                    raise AssetError(f"{path}: GLB chunk at byte {off} runs past the end of the file")
                chunks.append((ctype, data[off + 8: off + 8 + clen]))
                off += 8 + clen
            if not chunks or chunks[0][0] != _CHUNK_JSON:
                raise AssetError(f"{path}: GLB has no JSON chunk first")
            text = chunks[0][1]
            glb_bin = next((c for t, c in chunks[1:] if t == _CHUNK_BIN), None)
        elif path.lower().endswith(".glb"):
            raise AssetError(f"{path}: not a GLB file (the first 4 bytes are {data[:4]!r}, expected b'glTF')")
        else:
            text = data
        try:
            self.header = json.loads(text.decode("utf-8") if isinstance(text, bytes) else text)
        except (UnicodeDecodeError, json.JSONDecodeError) as exc:
            raise AssetError(f"{path}: not valid glTF JSON: {exc}") from None
        if not isinstance(self.header, dict) or "asset" not in self.header:
            raise AssetError(f"{path}: not a glTF file (no 'asset' object)")
        ver = str(self.header["asset"].get("version", ""))
        if not ver.startswith("2"):
            raise AssetError(f"{path}: glTF version {ver!r} is not supported (need 2.x)")
        required = set(self.header.get("extensionsRequired", [])) - _SUPPORTED_EXTENSIONS
        if required:
            raise AssetError(f"{path}: requires unsupported glTF extension(s) {sorted(required)}")
        self.buffers = []
        for i, b in enumerate(self.header.get("buffers", [])):
            uri = b.get("uri")
            if uri is None:
                if glb_bin is None:
                    raise AssetError(f"{path}: buffer {i} has no uri and there is no GLB binary chunk")
                blob = glb_bin
            else:
                blob = self._read_uri(uri, f"buffer {i}")
            if len(blob) < b.get("byteLength", 0):
                raise AssetError(f"{path}: buffer {i} has {len(blob)} bytes, byteLength says {b['byteLength']}")
            self.buffers.append(blob)
        self._acc_cache = {}
        self._img_cache = {}

    def _read_uri(self, uri, what):
        if uri.startswith("data:"):
            try:
                head, payload = uri.split(",", 1)
                return base64.b64decode(payload) if head.endswith(";base64") else urllib.parse.unquote_to_bytes(payload)
            except (ValueError, base64.binascii.Error) as exc:
                raise AssetError(f"{self.path}: {what}: malformed data URI: {exc}") from None
        fpath = os.path.join(self.base, urllib.parse.unquote(uri))
        if not os.path.isfile(fpath):
            raise AssetError(f"{self.path}: {what}: file not found: {fpath}")
        with open(fpath, "rb") as fh:
            return fh.read()

    def _get(self, kind, i):
        arr = self.header.get(kind, [])
        if not isinstance(i, int) or not 0 <= i < len(arr):
            raise AssetError(f"{self.path}: reference to {kind}[{i}] but the file has {len(arr)}")
        return arr[i]

    def view_bytes(self, vi):
        bv = self._get("bufferViews", vi)
        buf_i = bv.get("buffer")
        if not isinstance(buf_i, int) or not 0 <= buf_i < len(self.buffers):
            raise AssetError(f"{self.path}: bufferView {vi} refers to missing buffer {buf_i}")
        off, length = bv.get("byteOffset", 0), bv.get("byteLength", 0)
        buf = self.buffers[buf_i]
        if off + length > len(buf):
            raise AssetError(f"{self.path}: bufferView {vi} (bytes {off}..{off + length}) runs past the end of "
                             f"buffer {buf_i} ({len(buf)} bytes)")
        return buf[off: off + length], bv.get("byteStride")

    def accessor(self, ai):
        """Accessor ``ai`` as float64 (count, ncomp) (normalised integers mapped to [0, 1] / [-1, 1])."""
        if ai in self._acc_cache:
            return self._acc_cache[ai]
        a = self._get("accessors", ai)
        try:
            dt = np.dtype(_COMPONENT[a["componentType"]]).newbyteorder("<")
            nc = _NCOMP[a["type"]]
            count = int(a["count"])
        except KeyError as exc:
            raise AssetError(f"{self.path}: accessor {ai}: missing or invalid {exc}") from None
        if "bufferView" in a:
            raw, stride = self.view_bytes(a["bufferView"])
            off = a.get("byteOffset", 0)
            elem = dt.itemsize * nc
            stride = stride or elem
            need = off + (count - 1) * stride + elem if count else 0
            if need > len(raw):
                raise AssetError(f"{self.path}: accessor {ai} reads {need} bytes past bufferView "
                                 f"{a['bufferView']} of {len(raw)} bytes")
            u8 = np.frombuffer(raw, dtype=np.uint8, count=need - off if count else 0, offset=off)
            if count:
                rows = np.lib.stride_tricks.as_strided(u8, shape=(count, elem), strides=(stride, 1))
                out = np.ascontiguousarray(rows).view(dt).reshape(count, nc)
            else:
                out = np.zeros((0, nc), dtype=dt)
        else:
            out = np.zeros((count, nc), dtype=dt)
        out = self._normalise(out, a.get("normalized", False))
        sp = a.get("sparse")
        if sp:
            n = int(sp["count"])
            ib, _ = self.view_bytes(sp["indices"]["bufferView"])
            idt = np.dtype(_COMPONENT[sp["indices"]["componentType"]]).newbyteorder("<")
            idx = np.frombuffer(ib, dtype=idt, count=n, offset=sp["indices"].get("byteOffset", 0)).astype(np.int64)
            vb, _ = self.view_bytes(sp["values"]["bufferView"])
            vals = np.frombuffer(vb, dtype=dt, count=n * nc, offset=sp["values"].get("byteOffset", 0)).reshape(n, nc)
            out = out.copy()
            if idx.size and (idx.max() >= count or idx.min() < 0):
                raise AssetError(f"{self.path}: accessor {ai}: sparse index out of range")
            out[idx] = self._normalise(vals, a.get("normalized", False))
        if not np.all(np.isfinite(out)):
            raise AssetError(f"{self.path}: accessor {ai} holds NaN or Inf values")
        self._acc_cache[ai] = out
        return out

    @staticmethod
    def _normalise(x, normalized):
        if np.issubdtype(x.dtype, np.floating):
            return x.astype(np.float64)
        if not normalized:
            return x.astype(np.float64)
        info = np.iinfo(x.dtype)
        y = x.astype(np.float64) / info.max
        return np.maximum(y, -1.0) if info.min < 0 else y

    def image_array(self, ii):
        """Image ``ii`` decoded by :func:`pyrt.textures.load_image`: ``((H, W, C) float32 in its stored
        encoding, label)``, cached. Embedded images go through a temporary file of their type."""
        if ii in self._img_cache:
            return self._img_cache[ii]
        im = self._get("images", ii)
        uri = im.get("uri")
        if uri is not None and not uri.startswith("data:"):
            fpath = os.path.join(self.base, urllib.parse.unquote(uri))
            label = uri
            if not os.path.isfile(fpath):
                raise AssetError(f"{self.path}: image {ii} ({uri}): file not found: {fpath}")
            arr = _load_image_file(fpath, f"{self.path}: image {ii} ({uri})")
        else:
            if uri is not None:
                blob, label = self._read_uri(uri, f"image {ii}"), f"image {ii} (data URI)"
            elif "bufferView" in im:
                blob, label = self.view_bytes(im["bufferView"])[0], f"image {ii} (embedded)"
            else:
                raise AssetError(f"{self.path}: image {ii} has neither uri nor bufferView")
            arr = _decode_image_bytes(blob, f"{self.path}: {label}")
        self._img_cache[ii] = (arr, label)
        return arr, label


def _load_image_file(path, label):
    try:
        return load_image(path)[0]
    except TextureError as exc:
        raise AssetError(f"{label}: {exc}") from None


def _decode_image_bytes(blob, label):
    """Decode PNG/JPEG bytes with pyrt's image reader (16-bit PNGs stay 16-bit) via a temporary file."""
    if blob[:8] == b"\x89PNG\r\n\x1a\n":
        ext = ".png"
    elif blob[:3] == b"\xff\xd8\xff":
        ext = ".jpg"
    else:
        raise AssetError(f"{label}: not a PNG or JPEG image (first bytes {blob[:8]!r})")
    fd, tmp = tempfile.mkstemp(suffix=ext)
    try:
        with os.fdopen(fd, "wb") as fh:
            fh.write(blob)
        return _load_image_file(tmp, label)
    finally:
        os.remove(tmp)


_SUPPORTED_EXTENSIONS = {"KHR_lights_punctual", "KHR_texture_transform", "KHR_materials_emissive_strength",
                         "KHR_mesh_quantization"}


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


def _gltf_texture(g, info, what, *, srgb, kind="image", warnings=None, **extra):
    """Build a texture from a glTF textureInfo ``info`` ({index, texCoord, extensions})."""
    ti = info.get("index")
    tex = g._get("textures", ti)
    src = tex.get("source")
    if src is None:
        raise AssetError(f"{g.path}: {what}: texture {ti} has no image source in a supported format "
                         f"(extensions {sorted(tex.get('extensions', {}))})")
    arr, label = g.image_array(src)
    sampler = g._get("samplers", tex["sampler"]) if "sampler" in tex else {}
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
            t = NormalMap(arr, strength=float(info.get("scale", 1.0)), wrap=wrap, name=label, **kw, **extra)
        else:
            t = ImageTexture(arr, srgb=srgb, wrap=wrap, filter=filt, name=label, **kw, **extra)
    except TextureError as exc:
        raise AssetError(f"{g.path}: {what}: {exc}") from None
    return TextureSlot(texture=t, texcoord=texcoord, source=label)


def _gltf_material(g, mi, warnings):
    m = g._get("materials", mi)
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
                                             channels=3)
    if "metallicRoughnessTexture" in pbr:
        slot = _gltf_texture(g, pbr["metallicRoughnessTexture"], f"{what} metallicRoughnessTexture", srgb=False)
        P.metallic_roughness_texture = slot
        raw = slot.texture
        if raw.channels < 3:
            raise AssetError(f"{g.path}: {what}: metallicRoughnessTexture {slot.source} has {raw.channels} "
                             "channel(s); need RGB (G = roughness, B = metallic)")
        P.metallic_texture = _channel(raw, 2, f"{slot.source} B (metallic)")
        P.roughness_texture = _channel(raw, 1, f"{slot.source} G (roughness)")
    if "normalTexture" in m:
        P.normal_scale = float(m["normalTexture"].get("scale", 1.0))
        P.normal_texture = _gltf_texture(g, m["normalTexture"], f"{what} normalTexture", srgb=False,
                                         kind="normal").texture
    if "occlusionTexture" in m:
        P.occlusion_strength = float(m["occlusionTexture"].get("strength", 1.0))
        slot = _gltf_texture(g, m["occlusionTexture"], f"{what} occlusionTexture", srgb=False)
        P.occlusion_texture = _channel(slot.texture, 0, f"{slot.source} R (occlusion)")
    ef = np.asarray(m.get("emissiveFactor", [0.0, 0.0, 0.0]), dtype=np.float64)
    if ef.shape != (3,) or np.any(ef < 0):
        raise AssetError(f"{g.path}: {what}: emissiveFactor must be 3 numbers >= 0, got {ef.tolist()}")
    P.emissive_factor = ef
    if "emissiveTexture" in m:
        P.emissive_texture = _gltf_texture(g, m["emissiveTexture"], f"{what} emissiveTexture", srgb=True,
                                           channels=3)
    P.emissive_strength = float(m.get("extensions", {}).get("KHR_materials_emissive_strength", {})
                                .get("emissiveStrength", 1.0))
    P.double_sided = bool(m.get("doubleSided", False))
    P.alpha_mode = m.get("alphaMode", "OPAQUE")
    P.alpha_cutoff = float(m.get("alphaCutoff", 0.5))
    if P.alpha_mode != "OPAQUE":
        warnings.append(f"{what}: alphaMode {P.alpha_mode} is rendered opaque")
    sets = {s.texcoord for s in (P.base_color_texture, P.metallic_roughness_texture, P.emissive_texture) if s}
    for k in ("normalTexture", "occlusionTexture"):
        if k in m:
            sets.add(int(m[k].get("texCoord", 0)))
    if len(sets) > 1:
        warnings.append(f"{what}: textures use several UV sets {sorted(sets)}; all read TEXCOORD_{min(sets)}")
    P.texcoord = min(sets) if sets else 0
    other = set(m.get("extensions", {})) - _SUPPORTED_EXTENSIONS
    if other:
        warnings.append(f"{what}: material extension(s) {sorted(other)} ignored")
    return P


def _channel(tex, c, label):
    """A 1-channel linear texture from channel ``c`` of an ImageTexture (same wrap/filter/transform)."""
    img = np.asarray(tex.image)
    return ImageTexture(np.ascontiguousarray(img[:, :, c]), srgb=False, wrap=tex.wrap, filter=tex.filter,
                        scale=tex.scale, offset=tex.offset, rotation_deg=tex.rotation_deg, name=label)


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
        m = trimesh.transformations.quaternion_matrix([w, x, y, z]) @ m
    if "translation" in node:
        m = trimesh.transformations.translation_matrix(np.asarray(node["translation"], dtype=np.float64)) @ m
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


def pack_glb(header, binary=b""):
    """Encode a glTF JSON ``header`` (dict) and its binary buffer as GLB 2.0 bytes.

    Buffer 0 of ``header`` must be the binary chunk (no ``uri``); chunks are padded to 4 bytes
    (JSON with spaces, binary with zeros) as the specification requires.
    """
    js = json.dumps(header, separators=(",", ":")).encode("utf-8")
    js += b" " * (-len(js) % 4)
    binary = bytes(binary) + b"\0" * (-len(binary) % 4)
    chunks = struct.pack("<II", len(js), _CHUNK_JSON) + js
    if binary:
        chunks += struct.pack("<II", len(binary), _CHUNK_BIN) + binary
    return struct.pack("<III", _GLB_MAGIC, 2, 12 + len(chunks)) + chunks


def read_gltf(path):
    """The JSON header (dict) and the buffers (list of bytes) of a .gltf or .glb file."""
    g = _Gltf(os.fspath(path))
    return g.header, g.buffers


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


def load_gltf(path):
    """Load a glTF 2.0 (.gltf + files / data URIs) or GLB file into an :class:`Asset`."""
    g = _Gltf(path)
    h = g.header
    asset = Asset(path=path, format="gltf", up_axis="+y")
    W = asset.warnings
    try:
        world = gltf_node_transforms(h)
    except AssetError as exc:
        raise AssetError(f"{path}: {exc}") from None
    # materials
    asset.materials = [_gltf_material(g, i, W) for i in range(len(h.get("materials", [])))]
    # meshes: glTF mesh index -> list of AssetMesh indices (one per triangle primitive)
    mesh_prims = {}

    def decode_mesh(mi):
        if mi in mesh_prims:
            return mesh_prims[mi]
        m = g._get("meshes", mi)
        ids = []
        for pi, p in enumerate(m.get("primitives", [])):
            where = f"mesh {mi} ({m.get('name', '')}) primitive {pi}"
            mode = p.get("mode", 4)
            if mode not in (4, 5, 6):
                W.append(f"{where}: mode {mode} (points/lines) skipped")
                continue
            attrs = p.get("attributes", {})
            if "POSITION" not in attrs:
                raise AssetError(f"{path}: {where}: no POSITION attribute")
            if "targets" in p:
                W.append(f"{where}: morph targets ignored (rest pose rendered)")
            pos = g.accessor(attrs["POSITION"])
            if pos.shape[1] != 3:
                raise AssetError(f"{path}: {where}: POSITION must be VEC3")
            nv = pos.shape[0]
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
                normals = g.accessor(attrs["NORMAL"])[:, :3]
                ln = np.linalg.norm(normals, axis=1, keepdims=True)
                normals = np.divide(normals, ln, out=np.zeros_like(normals), where=ln > 0)
            mat = p.get("material", -1)
            if mat >= len(asset.materials):
                raise AssetError(f"{path}: {where}: material {mat} does not exist")
            tc = asset.materials[mat].texcoord if mat >= 0 else 0
            uv = None
            if f"TEXCOORD_{tc}" in attrs:
                uv = g.accessor(attrs[f"TEXCOORD_{tc}"])[:, :2].copy()
                uv[:, 1] = 1.0 - uv[:, 1]          # glTF top-left -> pyrt bottom-left
            elif mat >= 0 and _has_textures(asset.materials[mat]):
                W.append(f"{where}: material {asset.materials[mat].name!r} has textures but the primitive has "
                         f"no TEXCOORD_{tc}")
            colors = None
            if "COLOR_0" in attrs:
                colors = np.clip(g.accessor(attrs["COLOR_0"])[:, :3], 0.0, None)
            for arr, nm in ((normals, "NORMAL"), (uv, "TEXCOORD"), (colors, "COLOR_0")):
                if arr is not None and arr.shape[0] != nv:
                    raise AssetError(f"{path}: {where}: {nm} has {arr.shape[0]} entries for {nv} vertices")
            asset.meshes.append(AssetMesh(name=f"{m.get('name', f'mesh{mi}')}.{pi}", vertices=pos, faces=faces,
                                          normals=normals, uv=uv, colors=colors, material=mat))
            ids.append(len(asset.meshes) - 1)
        mesh_prims[mi] = ids
        return ids

    lights_def = h.get("extensions", {}).get("KHR_lights_punctual", {}).get("lights", [])
    nodes = h.get("nodes", [])
    for ni in sorted(world):
        node = nodes[ni]
        M = world[ni]
        nname = node.get("name", f"node{ni}")
        if "skin" in node:
            W.append(f"node {ni} ({nname}): skinning ignored (bind pose rendered)")
        if "mesh" in node:
            for am in decode_mesh(node["mesh"]):
                asset.instances.append(AssetInstance(mesh=am, world_from_object=M, node=nname))
        if "camera" in node:
            cam = g._get("cameras", node["camera"])
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


def _has_textures(P):
    return any(x is not None for x in (P.base_color_texture, P.metallic_roughness_texture, P.normal_texture,
                                       P.occlusion_texture, P.emissive_texture))


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
