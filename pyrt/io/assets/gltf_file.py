"""The glTF 2.0 container: a .gltf (JSON + files or data URIs) or .glb file read into its JSON header, its
buffers and its decoded accessors and images, every count and length checked against the bytes that exist;
:func:`pack_glb` writes GLB.

What a glTF file may make pyrt read (documented choice; the glTF specification allows only these)
-------------------------------------------------------------------------------------------------
- ``data:`` URIs (base64 or percent-encoded), decoded in memory;
- relative URI references, percent-decoded and resolved from the folder of the .gltf/.glb file, to a regular file
  inside the model's root (:mod:`pyrt.io.assets.find_file`): the model's own folder and its subfolders, the archive
  for a model in a ZIP, or the wider folder given as :func:`pyrt.load_asset`'s ``root`` (model packs that share a
  texture folder; ``pyrt-preview --root``). A ``..`` step may move within the root; a reference that leaves it, or
  a link to a file outside it, is an :class:`~pyrt.io.assets.find_file.OutsideRootError` naming the URI, and
  nothing outside is opened or quoted;
- nothing else: a URI with a scheme (``https://``, ``http://``, ``file:``, ...) or an absolute path is refused
  with an :class:`AssetError` — pyrt never opens a network connection.

Sizes are checked before memory is allocated: a buffer shorter than its ``byteLength``, a bufferView outside its
buffer, an accessor reading past its bufferView, a negative count or offset, a stride shorter than an element,
and an accessor without a bufferView of more than :data:`MAX_ZERO_ACCESSOR_COUNT` elements are all errors naming
the file and the part.
"""
from __future__ import annotations

import base64
import binascii
from concurrent.futures import ThreadPoolExecutor
import io
import json
import os
import re
import struct
import tempfile
import time
import urllib.parse

import numpy as np

from pyrt.core.image_types import image_kind
from pyrt.io.assets.find_file import find_file
from pyrt.textures import TextureError, load_image
from pyrt.io.assets.common import AssetError, colour_texels, malformed_is_asset_error
from pyrt.io.assets.gltf_draco import DRACO, dracopy
from pyrt.io.assets.gltf_khr import IMAGE_EXTENSIONS, MATERIAL_EXTENSIONS, required_extension_error
from pyrt.io.assets.gltf_meshopt import MESHOPT_EXTENSIONS, MeshoptError, is_fallback_buffer, meshopt_extension
from pyrt.io.assets import gltf_meshopt
from pyrt.io.assets.texture_budget import reduce_texels, reduction_factor

_COMPONENT = {5120: np.int8, 5121: np.uint8, 5122: np.int16, 5123: np.uint16, 5125: np.uint32, 5126: np.float32}
_NCOMP = {"SCALAR": 1, "VEC2": 2, "VEC3": 3, "VEC4": 4, "MAT2": 4, "MAT3": 9, "MAT4": 16}
_GLB_MAGIC = 0x46546C67
_CHUNK_JSON = 0x4E4F534A
_CHUNK_BIN = 0x004E4942
#: image types glTF embeds (the core spec's PNG and JPEG, EXT_texture_webp, EXT_texture_avif), by their suffix
_EMBEDDED_SUFFIX = {"PNG": ".png", "JPEG": ".jpg", "WebP": ".webp", "AVIF": ".avif"}
_SCHEME = re.compile(r"^[A-Za-z][A-Za-z0-9+.\-]*:")

MAX_ZERO_ACCESSOR_COUNT = 1 << 24
"""The most elements an accessor without a bufferView (all zeros, optionally with sparse values) may have:
16,777,216 (a 16M-vertex mesh). Such an accessor is the only part of a glTF file whose size the file's own bytes
do not bound, so a hostile ``count`` would otherwise allocate unbounded memory."""

SUPPORTED_EXTENSIONS = {"KHR_lights_punctual", "KHR_texture_transform", "KHR_materials_emissive_strength",
                        "KHR_mesh_quantization", "EXT_mesh_gpu_instancing", DRACO} | MATERIAL_EXTENSIONS \
    | set(IMAGE_EXTENSIONS) | set(MESHOPT_EXTENSIONS)
"""The extensions pyrt reads. ``KHR_draco_mesh_compression`` needs the optional DracoPy package: a file that
requires it is refused without it, with the install hint (:class:`GltfFile`). ``EXT_meshopt_compression`` and
``KHR_meshopt_compression`` are decoded by :mod:`pyrt.io.assets.gltf_meshopt` (pure NumPy)."""


def _int(value, what, path, *, lo=0):
    """A JSON integer >= ``lo`` (bool is not an integer here), else AssetError."""
    if isinstance(value, bool) or not isinstance(value, int) or value < lo:
        raise AssetError(f"{path}: {what} must be an integer >= {lo}, got {value!r}")
    return value


class GltfFile:
    """A parsed glTF container: JSON header, buffers (bytes), the base directory of its URIs.

    Parameters
    ----------
    path : str
        The .gltf or .glb file.

    Raises
    ------
    AssetError
        A truncated or malformed GLB, invalid JSON, an unsupported version or required extension, a buffer
        shorter than its ``byteLength``, a refused URI (see the module docstring).
    """

    def __init__(self, path, max_texture=None):
        self.path = path
        #: images whose longer side exceeds this are reduced as they are decoded (:mod:`.texture_budget`); None: none
        self.max_texture = max_texture
        self.base = os.path.dirname(os.path.abspath(path))
        with open(path, "rb") as fh:
            data = fh.read()
        glb_bin = None
        if data[:4] == b"glTF":
            text, glb_bin = self._glb_chunks(data)
        elif path.lower().endswith(".glb"):
            raise AssetError(f"{path}: not a GLB file (the first 4 bytes are {data[:4]!r}, expected b'glTF')")
        else:
            text = data
        try:
            self.header = json.loads(text.decode("utf-8") if isinstance(text, bytes) else text)
        except (UnicodeDecodeError, json.JSONDecodeError) as exc:
            raise AssetError(f"{path}: not valid glTF JSON: {exc}") from None
        except RecursionError:
            raise AssetError(f"{path}: not valid glTF JSON: nested too deeply") from None
        if not isinstance(self.header, dict) or not isinstance(self.header.get("asset"), dict):
            raise AssetError(f"{path}: not a glTF file (no 'asset' object)")
        ver = str(self.header["asset"].get("version", ""))
        if not ver.startswith("2"):
            raise AssetError(f"{path}: glTF version {ver!r} is not supported (need 2.x)")
        required = set(self.header.get("extensionsRequired", []))
        refused = required - SUPPORTED_EXTENSIONS
        if DRACO in required and dracopy() is None:        # supported with the [draco] extra only
            refused.add(DRACO)
        if refused:
            raise required_extension_error(path, refused)
        #: what the loader replaced to load the file anyway (missing texture files, files found in another case or
        #: folder than named), for :attr:`Asset.substitutions`
        self.substitutions = []
        self._relocated = set()      # files found in another case or folder than their URI names (find_file)
        self.buffers = []
        #: meshopt fallback buffers (``extensions.<meshopt>.fallback = true``) or placeholders without data: not
        #: read, only bufferViews that have compressed data refer to them (:meth:`view_bytes`)
        self.placeholders = set()
        uses_meshopt = bool(set(self.header.get("extensionsUsed", [])) & set(MESHOPT_EXTENSIONS))
        for i, b in enumerate(self.header.get("buffers", [])):
            if not isinstance(b, dict):
                raise AssetError(f"{path}: buffer {i} must be an object, got {b!r}")
            claimed = _int(b.get("byteLength", 0), f"buffer {i} byteLength", path)
            uri = b.get("uri")
            if is_fallback_buffer(b) or (uri is None and uses_meshopt and (glb_bin is None or i > 0)):
                self.placeholders.add(i)     # a meshopt fallback: the compressed views are decoded instead
                self.buffers.append(b"")
                continue
            if uri is None:
                if glb_bin is None:
                    raise AssetError(f"{path}: buffer {i} has no uri and there is no GLB binary chunk")
                blob, where = glb_bin, "the GLB binary chunk has"
            else:
                blob = self.read_uri(uri, f"buffer {i}")
                where = "its data URI holds" if uri.startswith("data:") else f"{uri!r} has"
            if len(blob) < claimed:
                raise AssetError(f"{path}: buffer {i} claims {claimed} bytes (byteLength), {where} {len(blob)}")
            self.buffers.append(blob)
        self._acc_cache = {}
        self._img_cache = {}
        self._prefetched = {}        # image index -> (decoded array, label) of prefetch_images
        self._view_cache = {}        # decoded meshopt bufferViews
        #: what the texture budget reduced (one message per image), for the asset's warnings
        self.reductions = []
        #: seconds spent decoding (and reducing) images: :meth:`prefetch_images` and the decodes of :meth:`image_array`
        self.decode_time = 0.0

    def _glb_chunks(self, data):
        """(JSON chunk, binary chunk or None) of GLB bytes; every length checked against the file."""
        path = self.path
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
                raise AssetError(f"{path}: GLB chunk {len(chunks)} at byte {off} claims {clen} bytes, the file "
                                 f"has {length - off - 8} after its header (truncated)")
            chunks.append((ctype, data[off + 8: off + 8 + clen]))
            off += 8 + clen
        if not chunks or chunks[0][0] != _CHUNK_JSON:
            raise AssetError(f"{path}: GLB has no JSON chunk first")
        return chunks[0][1], next((c for t, c in chunks[1:] if t == _CHUNK_BIN), None)

    def resolve(self, uri, what):
        """The local file a relative URI reference names (percent-decoded, from the file's folder, inside the
        model's root: the module docstring).

        Raises
        ------
        AssetError
            For a URI with a scheme (``https://`` ...: pyrt reads no network), an absolute path, a reference that
            leaves the root (:class:`~pyrt.io.assets.find_file.OutsideRootError`), or a missing file.
        """
        if not isinstance(uri, str) or not uri:
            raise AssetError(f"{self.path}: {what}: uri must be a non-empty string, got {uri!r}")
        if _SCHEME.match(uri):
            raise AssetError(f"{self.path}: {what}: uri {uri[:80]!r} is not read: only relative paths and data: "
                             "URIs are allowed (pyrt does not download files)")
        rel = urllib.parse.unquote(uri)
        if os.path.isabs(rel) or rel.startswith(("/", "\\")):
            raise AssetError(f"{self.path}: {what}: uri {uri[:80]!r} is an absolute path; glTF URIs must be "
                             "relative to the file's folder")
        fpath, how = find_file(self.base, rel)
        if fpath is None:
            raise AssetError(f"{self.path}: {what}: file not found: {os.path.join(self.base, rel)}")
        if how is not None and fpath not in self._relocated:   # another case or folder: say which file was read
            self._relocated.add(fpath)
            self.substitutions.append(f"{self.path}: {what}: {rel!r} not found as named; using {fpath} ({how})")
        return fpath

    def read_uri(self, uri, what):
        """The bytes a buffer or image URI names: a ``data:`` URI decoded, or a local file (:meth:`resolve`)."""
        if isinstance(uri, str) and uri.startswith("data:"):
            try:
                head, payload = uri.split(",", 1)
                return base64.b64decode(payload) if head.endswith(";base64") else urllib.parse.unquote_to_bytes(payload)
            except (ValueError, binascii.Error) as exc:
                raise AssetError(f"{self.path}: {what}: malformed data URI: {exc}") from None
        with open(self.resolve(uri, what), "rb") as fh:
            return fh.read()

    def get(self, kind, i):
        """Entry ``i`` of the top-level array ``kind`` (an object), or AssetError naming the reference."""
        arr = self.header.get(kind, [])
        if not isinstance(arr, list):
            raise AssetError(f"{self.path}: '{kind}' must be an array")
        if isinstance(i, bool) or not isinstance(i, int) or not 0 <= i < len(arr):
            raise AssetError(f"{self.path}: reference to {kind}[{i!r}] but the file has {len(arr)}")
        if not isinstance(arr[i], dict):
            raise AssetError(f"{self.path}: {kind}[{i}] must be an object, got {type(arr[i]).__name__}")
        return arr[i]

    def view_bytes(self, vi):
        """The bytes of bufferView ``vi`` and its ``byteStride`` (None if absent), checked against its buffer.

        A view with ``EXT_meshopt_compression`` / ``KHR_meshopt_compression`` data is decoded (once: cached) by
        :meth:`meshopt_view_bytes` and its own ``buffer`` (a fallback or a placeholder) is not read.
        """
        bv = self.get("bufferViews", vi)
        name, ext = meshopt_extension(bv)
        if name is not None:
            stride = bv.get("byteStride")
            if stride is not None:
                _int(stride, f"bufferView {vi} byteStride", self.path, lo=1)
            return self.meshopt_view_bytes(vi, bv, name, ext), stride
        buf_i = bv.get("buffer")
        if isinstance(buf_i, bool) or not isinstance(buf_i, int) or not 0 <= buf_i < len(self.buffers):
            raise AssetError(f"{self.path}: bufferView {vi} refers to missing buffer {buf_i!r}")
        off = _int(bv.get("byteOffset", 0), f"bufferView {vi} byteOffset", self.path)
        length = _int(bv.get("byteLength", 0), f"bufferView {vi} byteLength", self.path)
        stride = bv.get("byteStride")
        if stride is not None:
            _int(stride, f"bufferView {vi} byteStride", self.path, lo=1)
        if buf_i in self.placeholders:
            raise AssetError(f"{self.path}: bufferView {vi} has no meshopt-compressed data but its buffer {buf_i} is a "
                             "meshopt fallback buffer, which is not read")
        buf = self.buffers[buf_i]
        if off + length > len(buf):
            raise AssetError(f"{self.path}: bufferView {vi} (bytes {off}..{off + length}) runs past the end of "
                             f"buffer {buf_i} ({len(buf)} bytes)")
        return buf[off: off + length], stride

    def meshopt_view_bytes(self, vi, bv, name, ext):
        """The decoded bytes of bufferView ``vi`` (dict ``bv``) from its meshopt extension ``name`` (object
        ``ext``): :func:`pyrt.io.assets.gltf_meshopt.decode` of the compressed range, cached per bufferView; the
        view's ``byteLength`` first bytes of the ``count * byteStride`` decoded ones.

        Raises
        ------
        AssetError
            Naming the file and the bufferView: a malformed extension object, a compressed range outside its
            buffer or in a placeholder buffer, a ``byteLength`` larger than ``count * byteStride``, a malformed
            stream (the decoder's reason).
        """
        if vi in self._view_cache:
            return self._view_cache[vi]
        what = f"{self.path}: bufferView {vi} ({name})"
        if not isinstance(ext, dict):
            raise AssetError(f"{what}: must be an object, got {ext!r}")
        try:
            buf_i = _int(ext.get("buffer"), "buffer", what)
            off = _int(ext.get("byteOffset", 0), "byteOffset", what)
            length = _int(ext.get("byteLength"), "byteLength", what)
            stride = _int(ext.get("byteStride"), "byteStride", what, lo=1)
            count = _int(ext.get("count"), "count", what)
        except AssetError as exc:
            raise AssetError(str(exc).replace(f"{what}: ", f"{what}: extension ")) from None
        view_len = _int(bv.get("byteLength", 0), f"bufferView {vi} byteLength", self.path)
        if buf_i >= len(self.buffers):
            raise AssetError(f"{what}: compressed data in missing buffer {buf_i}")
        if buf_i in self.placeholders:
            raise AssetError(f"{what}: compressed data in buffer {buf_i}, a fallback buffer without data")
        buf = self.buffers[buf_i]
        if off + length > len(buf):
            raise AssetError(f"{what}: compressed bytes {off}..{off + length} run past the end of buffer {buf_i} "
                             f"({len(buf)} bytes)")
        if view_len > count * stride:
            raise AssetError(f"{what}: byteLength {view_len} is more than the {count} x {stride} bytes the "
                             "compressed data decodes to")
        try:
            out = gltf_meshopt.decode(buf[off: off + length], count, stride, ext.get("mode"),
                                      ext.get("filter", "NONE"), name)
        except MeshoptError as exc:
            raise AssetError(f"{what}: cannot decode the compressed data: {exc}") from None
        out = out[:view_len]
        self._view_cache[vi] = out
        return out

    def accessor(self, ai):
        """Accessor ``ai`` as float64 (count, ncomp) (normalised integers mapped to [0, 1] / [-1, 1])."""
        if ai in self._acc_cache:
            return self._acc_cache[ai]
        a = self.get("accessors", ai)
        dt, nc = self._layout(ai, a)
        count = _int(a.get("count"), f"accessor {ai} count", self.path)
        if "bufferView" in a:
            raw, stride = self.view_bytes(a["bufferView"])
            off = _int(a.get("byteOffset", 0), f"accessor {ai} byteOffset", self.path)
            elem = dt.itemsize * nc
            stride = stride or elem
            if stride < elem:
                raise AssetError(f"{self.path}: accessor {ai}: byteStride {stride} is shorter than one element "
                                 f"({elem} bytes)")
            need = off + (count - 1) * stride + elem if count else 0
            if need > len(raw):
                raise AssetError(f"{self.path}: accessor {ai} reads {need} bytes past bufferView "
                                 f"{a['bufferView']} of {len(raw)} bytes ({count} elements claimed)")
            u8 = np.frombuffer(raw, dtype=np.uint8, count=need - off if count else 0, offset=off)
            if count:
                rows = np.lib.stride_tricks.as_strided(u8, shape=(count, elem), strides=(stride, 1))
                out = np.ascontiguousarray(rows).view(dt).reshape(count, nc)
            else:
                out = np.zeros((0, nc), dtype=dt)
        else:
            if count > MAX_ZERO_ACCESSOR_COUNT:
                raise AssetError(f"{self.path}: accessor {ai} has no bufferView and claims {count} elements; the "
                                 f"limit is {MAX_ZERO_ACCESSOR_COUNT}")
            out = np.zeros((count, nc), dtype=dt)
        out = self._normalise(out, a.get("normalized", False))
        sp = a.get("sparse")
        if sp:
            out = self._sparse(ai, sp, out, dt, nc, count, a.get("normalized", False))
        if not np.all(np.isfinite(out)):
            raise AssetError(f"{self.path}: accessor {ai} holds NaN or Inf values")
        self._acc_cache[ai] = out
        return out

    def _layout(self, ai, a):
        """(little-endian component dtype, components per element) of accessor ``ai`` (its dict ``a``)."""
        try:
            return np.dtype(_COMPONENT[a["componentType"]]).newbyteorder("<"), _NCOMP[a["type"]]
        except (KeyError, TypeError) as exc:
            raise AssetError(f"{self.path}: accessor {ai}: missing or invalid componentType/type {exc}") from None

    def accessor_values(self, ai, data, what):
        """Values decoded elsewhere (a Draco buffer: :mod:`pyrt.io.assets.gltf_draco`) read as accessor ``ai``
        describes them, in place of its bufferView: float64 (n, ncomp) like :meth:`accessor`.

        ``data`` must have as many components per element as the accessor's ``type``; float values are taken as
        they are (Draco returns its quantized attributes dequantized), integer values as integers of the
        accessor's componentType, normalised when the accessor says ``normalized``. The element count is the
        caller's to check. ``what`` names the values in errors.

        Raises
        ------
        AssetError
            For a component count that differs from the accessor's type, integer values for a float accessor
            or outside its componentType's range, NaN or Inf.
        """
        a = self.get("accessors", ai)
        dt, nc = self._layout(ai, a)
        data = np.asarray(data)
        if data.ndim == 1:
            data = data.reshape(-1, 1)
        if data.ndim != 2 or data.shape[1] != nc:
            raise AssetError(f"{self.path}: {what}: decoded values of shape {data.shape}, accessor {ai} is "
                             f"{a['type']} ({nc} components)")
        if np.issubdtype(data.dtype, np.integer):
            if not np.issubdtype(dt, np.integer):
                raise AssetError(f"{self.path}: {what}: {data.dtype} values for accessor {ai}, whose "
                                 f"componentType is float")
            info = np.iinfo(dt)
            if data.size and (data.min() < info.min or data.max() > info.max):
                raise AssetError(f"{self.path}: {what}: values outside the range of accessor {ai}'s "
                                 f"componentType ({dt})")
            data = data.astype(dt)
        out = self._normalise(data, a.get("normalized", False))
        if not np.all(np.isfinite(out)):
            raise AssetError(f"{self.path}: {what}: NaN or Inf values")
        return out

    def _sparse(self, ai, sp, out, dt, nc, count, normalized):
        """``out`` with accessor ``ai``'s sparse values substituted (every count checked against the bytes)."""
        what = f"accessor {ai} sparse"
        try:
            n = _int(sp["count"], f"{what} count", self.path)
            ind, vals = sp["indices"], sp["values"]
            idt = np.dtype(_COMPONENT[ind["componentType"]]).newbyteorder("<")
        except (KeyError, TypeError) as exc:
            raise AssetError(f"{self.path}: {what}: missing or invalid {exc}") from None
        ib, _ = self.view_bytes(ind["bufferView"])
        vb, _ = self.view_bytes(vals["bufferView"])
        ioff = _int(ind.get("byteOffset", 0), f"{what} indices byteOffset", self.path)
        voff = _int(vals.get("byteOffset", 0), f"{what} values byteOffset", self.path)
        if ioff + n * idt.itemsize > len(ib) or voff + n * nc * dt.itemsize > len(vb):
            raise AssetError(f"{self.path}: {what}: {n} indices/values run past their bufferViews")
        idx = np.frombuffer(ib, dtype=idt, count=n, offset=ioff).astype(np.int64)
        v = np.frombuffer(vb, dtype=dt, count=n * nc, offset=voff).reshape(n, nc)
        if idx.size and (idx.max() >= count or idx.min() < 0):
            raise AssetError(f"{self.path}: {what}: index {int(idx.max())} out of range for {count} elements")
        out = out.copy()
        out[idx] = self._normalise(v, normalized)
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

    def missing_image(self, ii):
        """The path of image ``ii``'s file when it is a relative URI to a file that does not exist, else None.

        (A missing texture file is replaced by its factor: :func:`pyrt.io.assets.gltf.load_gltf`; every other
        problem of an image -- a refused URI, a corrupt or truncated file, a bad bufferView -- stays an error.)
        """
        uri = self.get("images", ii).get("uri")
        if not isinstance(uri, str) or not uri or uri.startswith("data:") or _SCHEME.match(uri):
            return None
        rel = urllib.parse.unquote(uri)
        if os.path.isabs(rel) or rel.startswith(("/", "\\")):
            return None
        return None if find_file(self.base, rel)[0] is not None else os.path.join(self.base, rel)

    def _image_source(self, ii):
        """Image ``ii``'s ``(label, path, blob)``: a file's path (blob None) or the bytes of a data URI or bufferView
        (path None)."""
        im = self.get("images", ii)
        uri = im.get("uri")
        if uri is not None and not (isinstance(uri, str) and uri.startswith("data:")):
            return uri, self.resolve(uri, f"image {ii} ({str(uri)[:80]})"), None
        if uri is not None:
            return f"image {ii} (data URI)", None, self.read_uri(uri, f"image {ii}")
        if "bufferView" in im:
            return f"image {ii} (embedded)", None, self.view_bytes(im["bufferView"])[0]
        raise AssetError(f"{self.path}: image {ii} has neither uri nor bufferView")

    def _quiet_source(self, ii):
        """:meth:`_image_source` for :meth:`prefetch_images`, without its side effects: None for an image it would
        report something about (a file found in another case or folder, a refused or broken URI, a malformed
        entry)."""
        try:
            uri = self.get("images", ii).get("uri")
            if isinstance(uri, str) and uri and not uri.startswith("data:"):
                rel = urllib.parse.unquote(uri)
                if _SCHEME.match(uri) or os.path.isabs(rel) or rel.startswith(("/", "\\")):
                    return None
                fpath, how = find_file(self.base, rel)
                return None if fpath is None or how is not None else (uri, fpath, None)
            return self._image_source(ii)
        except AssetError:
            return None

    def _decode(self, ii, source=None):
        """Image ``ii`` decoded, grey and grey + alpha as RGB(A): ``(arr, label)``; ``source`` as
        :meth:`_image_source` returns it (default: that)."""
        label, fpath, blob = source or self._image_source(ii)
        if fpath is not None:
            arr = _load_image_file(fpath, f"{self.path}: image {ii} ({label})")
        else:
            arr = _decode_image_bytes(blob, f"{self.path}: {label}")
        return colour_texels(arr), label     # grey / grey + alpha -> RGB(A): every slot reads colour channels

    def _whole(self, source):
        """True when the image of ``source`` (:meth:`_image_source`) is within the texture budget (read whole),
        from its header alone; False when it is not or its header cannot be read."""
        if not self.max_texture:
            return True
        try:
            from PIL import Image

            _, fpath, blob = source
            with Image.open(fpath if fpath is not None else io.BytesIO(bytes(blob))) as im:
                w, h = im.size
        except Exception:        # not Pillow's, or broken: decoded serially, where an error names the slot
            return False
        return reduction_factor((h, w), self.max_texture) == 1

    def prefetch_images(self, indices, workers=None):
        """Decode the images ``indices`` on a thread pool (Pillow decodes without the GIL), for
        :meth:`image_array` to find (the helmet-like model's load, five 2048² JPEGs: 0.175 -> 0.129 s on two
        cores). Only images within the texture budget (``_whole``, which :meth:`image_array` caches whole anyway;
        two decodes' temporaries overlap) and files found as named; an image whose decoding fails here is decoded
        again by :meth:`image_array`, which reports the error with the slot reading it. ``workers``: default the
        CPU count (at least 2).
        """
        todo = []
        for ii in dict.fromkeys(int(i) for i in indices):
            if (ii, None) in self._img_cache or ii in self._prefetched:
                continue
            source = self._quiet_source(ii)
            if source is not None and self._whole(source):
                todo.append((ii, source))
        n = min(len(todo), workers or max(2, os.cpu_count() or 1))
        if n < 2:
            return
        t0 = time.perf_counter()
        with ThreadPoolExecutor(n) as ex:
            futures = [(ii, ex.submit(self._decode, ii, source)) for ii, source in todo]
        self.decode_time += time.perf_counter() - t0
        for ii, fut in futures:
            if fut.exception() is None:
                self._prefetched[ii] = fut.result()

    def image_array(self, ii, srgb=False):
        """Image ``ii`` decoded by :func:`pyrt.textures.load_image`: ``((H, W, C) uint8 / uint16 codes (8/16-bit
        PNG and JPEG; :class:`pyrt.textures.ImageTexture` keeps them as they are), label)``, cached; grey and grey +
        alpha images as RGB(A) (:func:`colour_texels`). Embedded images go through a temporary file of their type.

        An image longer than :attr:`max_texture` is reduced as it is decoded (:mod:`.texture_budget`), its colour
        channels in linear light when the slot reading it is a colour slot (``srgb``: what the caller decodes them
        as), its alpha always as values; the reduced image is cached per ``srgb``, a whole one once."""
        for key in ((ii, None), (ii, bool(srgb))):
            if key in self._img_cache:
                return self._img_cache[key]
        t0 = time.perf_counter()
        decoded = self._prefetched.pop(ii, None)
        arr, label = decoded if decoded is not None else self._decode(ii)
        f = reduction_factor(arr.shape, self.max_texture)
        if f > 1:
            full = arr.shape
            arr = reduce_texels(arr, f, min(3, arr.shape[2]) if srgb else 0)
            what = label if label.startswith(f"image {ii}") else f"image {ii} ({label})"
            self.reductions.append(f"{self.path}: {what} {full[1]}x{full[0]} read at {arr.shape[1]}x"
                                   f"{arr.shape[0]} (the texture budget, max_texture={self.max_texture}: its MIP "
                                   f"level {f.bit_length() - 1}{', in linear light' if srgb else ''})")
        self._img_cache[(ii, bool(srgb) if f > 1 else None)] = (arr, label)
        self.decode_time += time.perf_counter() - t0
        return arr, label



def _load_image_file(path, label):
    try:
        return load_image(path, integers=True)[0]
    except TextureError as exc:
        raise AssetError(f"{label}: {exc}") from None


def _decode_image_bytes(blob, label):
    """Decode embedded image bytes (PNG, JPEG; WebP and AVIF for ``EXT_texture_webp`` / ``EXT_texture_avif``) with
    pyrt's image reader (16-bit PNGs stay 16-bit) via a temporary file."""
    kind = image_kind(bytes(blob[:16]))
    if kind not in _EMBEDDED_SUFFIX:
        raise AssetError(f"{label}: not a PNG, JPEG, WebP or AVIF image (first bytes {bytes(blob[:8])!r})")
    ext = _EMBEDDED_SUFFIX[kind]
    fd, tmp = tempfile.mkstemp(suffix=ext)
    try:
        with os.fdopen(fd, "wb") as fh:
            fh.write(blob)
        return _load_image_file(tmp, label)
    finally:
        os.remove(tmp)


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
    path = os.fspath(path)
    with malformed_is_asset_error(path, "glTF"):
        g = GltfFile(path)
    return g.header, g.buffers
