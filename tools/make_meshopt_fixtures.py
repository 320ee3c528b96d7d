"""Write the meshopt-compressed glTF fixtures of tests/test_gltf_meshopt.py (tests/data/meshopt/) with an encoder
independent of pyrt: meshoptimizer's own C library, through the PyPI package ``meshoptimizer`` (0.2.30a0, a
ctypes wrapper that builds the library from source; its filter encoders are called through ctypes).

Not needed by the tests (they read the files this writes). To regenerate, in a scratch venv::

    python3 -m venv /tmp/mo-venv && /tmp/mo-venv/bin/pip install meshoptimizer numpy
    /tmp/mo-venv/bin/python tools/make_meshopt_fixtures.py

What it writes (a UV sphere, 559 vertices / 960 triangles, in vertex-cache and vertex-fetch order as gltfpack
would write it):

- ``sphere_ext.glb``: ``EXT_meshopt_compression`` required, buffer 1 a placeholder fallback without data; vertex
  codec version 0; POSITION float32 (NONE), NORMAL int8 normalized (OCTAHEDRAL, 8 bits, ``KHR_mesh_quantization``),
  TEXCOORD_0 float32 (NONE); uint32 indices (TRIANGLES, index codec version 1);
- ``sphere_khr.glb``: ``KHR_meshopt_compression`` required; vertex codec version 1 at compression level 3;
  POSITION float32 (EXPONENTIAL, 18-bit mantissas), NORMAL int16 normalized (OCTAHEDRAL, 12 bits), TEXCOORD_0
  uint16 normalized (NONE); uint16 indices (INDICES, version 1); three ``EXT_mesh_gpu_instancing`` instances
  whose TRANSLATION is float32 (EXPONENTIAL, 23 bits) and ROTATION int16 normalized (QUATERNION, 12 bits);
- ``sphere_used.glb`` + ``sphere_used.bin``: ``EXT_meshopt_compression`` used, not required; the uncompressed
  data in ``sphere_used.bin`` (buffer 1, marked ``fallback``); vertex codec version 0, no filter; uint16 indices
  (TRIANGLES, index codec version 0). Every fallback holds what the C decoder makes of the compressed view (the
  triangle codec may rotate a triangle's corners, winding kept);
- ``expected.npz``: the source arrays (``src_*``) and, for each compressed bufferView, what meshoptimizer's own C
  decoder makes of it (``<file>_view<i>``: bytes as uint8), filters included.
"""
from __future__ import annotations

import argparse
import ctypes
import json
import os
import struct
import sys

import numpy as np

import meshoptimizer as mo
from meshoptimizer._loader import lib

OUT = os.path.join(os.path.dirname(os.path.abspath(__file__)), "..", "tests", "data", "meshopt")

_P, _S, _I = ctypes.c_void_p, ctypes.c_size_t, ctypes.c_int
lib.meshopt_encodeVertexBufferBound.restype = _S
lib.meshopt_encodeVertexBufferLevel.restype = _S
lib.meshopt_encodeVertexBufferLevel.argtypes = [_P, _S, _P, _S, _S, _I, _I]
lib.meshopt_encodeFilterOct.argtypes = [_P, _S, _S, _I, _P]
lib.meshopt_encodeFilterQuat.argtypes = [_P, _S, _S, _I, _P]
lib.meshopt_encodeFilterExp.argtypes = [_P, _S, _S, _I, _P, _I]
for _f in ("Oct", "Quat", "Exp"):
    getattr(lib, "meshopt_decodeFilter" + _f).argtypes = [_P, _S, _S]
lib.meshopt_decodeVertexBuffer.argtypes = [_P, _S, _S, _P, _S]
lib.meshopt_decodeIndexBuffer.argtypes = [_P, _S, _S, _P, _S]
lib.meshopt_decodeIndexSequence.argtypes = [_P, _S, _S, _P, _S]


def sphere(nu=32, nv=16):
    """Unit UV sphere: positions, normals, uv (glTF v down), triangles (F, 3), reordered for the codecs."""
    u, v = np.meshgrid(np.arange(nu + 1) / nu, np.arange(nv + 1) / nv)
    th, ph = v.ravel() * np.pi, u.ravel() * 2 * np.pi
    pos = np.stack([np.sin(th) * np.cos(ph), np.cos(th), -np.sin(th) * np.sin(ph)], axis=1)
    i, j = np.meshgrid(np.arange(nv), np.arange(nu), indexing="ij")
    a = (i * (nu + 1) + j).ravel()
    faces = np.concatenate([np.stack([a, a + nu + 1, a + 1], 1), np.stack([a + 1, a + nu + 1, a + nu + 2], 1)])
    area = np.linalg.norm(np.cross(pos[faces[:, 1]] - pos[faces[:, 0]], pos[faces[:, 2]] - pos[faces[:, 0]]), axis=1)
    faces = faces[area > 1e-9].astype(np.uint32)
    uv = np.stack([u.ravel(), v.ravel()], 1)
    opt = np.zeros(faces.size, np.uint32)
    mo.optimize_vertex_cache(opt, faces.ravel(), faces.size, len(pos))
    _, first = np.unique(opt, return_index=True)
    order = np.unique(opt, return_index=True)[0][np.argsort(first)]        # vertices by first use
    remap = np.empty(len(pos), np.int64)
    remap[order] = np.arange(len(order))
    return pos[order], pos[order].copy(), uv[order], remap[opt].reshape(-1, 3)


def encode_vertex(data, version, level=2):
    data = np.ascontiguousarray(data)
    count, stride = data.shape[0], data.nbytes // data.shape[0]
    mo.encode_vertex_version(version)
    bound = lib.meshopt_encodeVertexBufferBound(count, stride)
    out = np.zeros(bound, np.uint8)
    n = lib.meshopt_encodeVertexBufferLevel(out.ctypes.data, bound, data.ctypes.data, count, stride, level, version)
    assert n and out[0] == 0xA0 | version
    return bytes(out[:n])


def filter_encode(name, values, stride, bits, *extra):
    values = np.ascontiguousarray(values, np.float32)
    out = np.zeros(len(values) * stride, np.uint8)
    getattr(lib, "meshopt_encodeFilter" + name)(out.ctypes.data, len(values), stride, bits, values.ctypes.data,
                                                 *extra)
    return out.reshape(len(values), stride)


def reference_decode(blob, count, stride, mode, filt):
    """What meshoptimizer's C decoder makes of a compressed view (filters applied in place, as its JS decoder)."""
    src = np.frombuffer(blob, np.uint8)
    out = np.zeros(count * stride, np.uint8)
    fn = {"ATTRIBUTES": lib.meshopt_decodeVertexBuffer, "TRIANGLES": lib.meshopt_decodeIndexBuffer,
          "INDICES": lib.meshopt_decodeIndexSequence}[mode]
    assert fn(out.ctypes.data, count, stride, src.ctypes.data, len(src)) == 0
    if filt != "NONE":
        name = {"OCTAHEDRAL": "Oct", "QUATERNION": "Quat", "EXPONENTIAL": "Exp"}[filt]
        getattr(lib, "meshopt_decodeFilter" + name)(out.ctypes.data, count, stride)
    return out


class Glb:
    """A minimal GLB writer: buffer 0 the binary chunk (compressed data), buffer 1 the fallback."""

    def __init__(self, ext):
        self.ext, self.bin, self.fallback = ext, bytearray(), bytearray()
        self.views, self.accessors, self.expected = [], [], {}

    def _put(self, blob, data):
        off = len(blob)
        blob.extend(data)
        blob.extend(b"\0" * (-len(blob) % 4))
        return off

    def view(self, raw, count, stride, mode, filt="NONE", *, compressed, byte_stride=True, target=None):
        """A bufferView of ``raw`` (the uncompressed bytes) whose extension holds ``compressed``."""
        raw = bytes(raw)
        assert len(raw) == count * stride
        ext = {"buffer": 0, "byteOffset": self._put(self.bin, compressed), "byteLength": len(compressed),
               "byteStride": stride, "count": count, "mode": mode}
        if filt != "NONE":
            ext["filter"] = filt
        decoded = reference_decode(compressed, count, stride, mode, filt)
        if filt == "NONE" and mode != "TRIANGLES":
            assert decoded.tobytes() == raw                   # lossless (TRIANGLES may rotate triangles)
        # the fallback holds the decoded data, as KHR_meshopt_compression recommends (filters are lossy, and the
        # triangle codec may start a triangle at another corner)
        bv = {"buffer": 1, "byteOffset": self._put(self.fallback, decoded.tobytes()), "byteLength": len(raw),
              "extensions": {self.ext: ext}}
        if byte_stride:
            bv["byteStride"] = stride
        if target:
            bv["target"] = target
        self.views.append(bv)
        self.expected[len(self.views) - 1] = decoded
        return len(self.views) - 1

    def accessor(self, view, comp, typ, count, **extra):
        self.accessors.append({"bufferView": view, "componentType": comp, "count": count, "type": typ, **extra})
        return len(self.accessors) - 1

    def write(self, name, header, *, required=True, fallback_uri=None):
        header = {"asset": {"version": "2.0", "generator": "pyrt tools/make_meshopt_fixtures.py (meshoptimizer "
                                                          "0.2.30a0 from PyPI)"},
                  **header, "accessors": self.accessors, "bufferViews": self.views}
        fb = {"byteLength": len(self.fallback), "extensions": {self.ext: {"fallback": True}}}
        if fallback_uri:
            fb["uri"] = fallback_uri
            with open(os.path.join(OUT, fallback_uri), "wb") as fh:
                fh.write(self.fallback)
        header["buffers"] = [{"byteLength": len(self.bin)}, fb]
        used = header.setdefault("extensionsUsed", [])
        used.insert(0, self.ext)
        if required:
            header.setdefault("extensionsRequired", []).insert(0, self.ext)
        js = json.dumps(header, separators=(",", ":")).encode()
        js += b" " * (-len(js) % 4)
        binary = bytes(self.bin) + b"\0" * (-len(self.bin) % 4)
        body = struct.pack("<II", len(js), 0x4E4F534A) + js + struct.pack("<II", len(binary), 0x004E4942) + binary
        with open(os.path.join(OUT, name), "wb") as fh:
            fh.write(struct.pack("<III", 0x46546C67, 2, 12 + len(body)) + body)
        return {f"{name[:-4]}_view{i}": v for i, v in self.expected.items()}


def scene_header(attrs, indices, node=None):
    return {"scene": 0, "scenes": [{"nodes": [0]}], "nodes": [{"mesh": 0, **(node or {})}],
            "meshes": [{"name": "ball", "primitives": [{"attributes": attrs, "indices": indices, "mode": 4,
                                                        "material": 0}]}],
            "materials": [{"pbrMetallicRoughness": {"baseColorFactor": [0.8, 0.5, 0.3, 1.0], "roughnessFactor": 0.6,
                                                    "metallicFactor": 0.0}}]}


def main():
    argparse.ArgumentParser(description=__doc__.split("\n")[0]).parse_args()
    os.makedirs(OUT, exist_ok=True)
    pos, nrm, uv, faces = sphere()
    nv, ni = len(pos), faces.size
    p32, uv32 = pos.astype(np.float32), uv.astype(np.float32)
    bounds = {"min": p32.min(0).tolist(), "max": p32.max(0).tolist()}
    expected = {"src_pos": pos, "src_normals": nrm, "src_uv": uv, "src_faces": faces}

    # --- sphere_ext.glb: EXT, vertex codec v0, TRIANGLES v1 uint32, OCTAHEDRAL int8
    g = Glb("EXT_meshopt_compression")
    mo.encode_index_version(1)
    oct8 = filter_encode("Oct", np.c_[nrm, np.zeros(nv)], 4, 8)
    i32 = faces.ravel().astype(np.uint32)
    attrs = {"POSITION": g.accessor(g.view(p32.tobytes(), nv, 12, "ATTRIBUTES", compressed=encode_vertex(p32, 0),
                                           target=34962), 5126, "VEC3", nv, **bounds),
             "NORMAL": g.accessor(g.view(oct8.tobytes(), nv, 4, "ATTRIBUTES", "OCTAHEDRAL",
                                         compressed=encode_vertex(oct8, 0), target=34962), 5120, "VEC3", nv,
                                  normalized=True),
             "TEXCOORD_0": g.accessor(g.view(uv32.tobytes(), nv, 8, "ATTRIBUTES", compressed=encode_vertex(uv32, 0),
                                             target=34962), 5126, "VEC2", nv)}
    idx = g.accessor(g.view(i32.tobytes(), ni, 4, "TRIANGLES", compressed=mo.encode_index_buffer(i32, ni, nv),
                            byte_stride=False, target=34963), 5125, "SCALAR", ni)
    expected.update(g.write("sphere_ext.glb", {**scene_header(attrs, idx),
                                               "extensionsUsed": ["KHR_mesh_quantization"],
                                               "extensionsRequired": ["KHR_mesh_quantization"]}))

    # --- sphere_khr.glb: KHR, vertex codec v1 level 3, EXPONENTIAL / OCTAHEDRAL 16 / QUATERNION, INDICES uint16
    g = Glb("KHR_meshopt_compression")
    mo.encode_index_version(1)
    pexp = filter_encode("Exp", p32, 12, 18, 0)                                # meshopt_EncodeExpSeparate
    oct16 = filter_encode("Oct", np.c_[nrm, np.ones(nv)], 8, 12)
    uv16 = np.round(uv * 65535).astype(np.uint16)
    i16 = faces.ravel().astype(np.uint16)
    attrs = {"POSITION": g.accessor(g.view(pexp.tobytes(), nv, 12, "ATTRIBUTES", "EXPONENTIAL",
                                           compressed=encode_vertex(pexp, 1, 3)), 5126, "VEC3", nv, **bounds),
             "NORMAL": g.accessor(g.view(oct16.tobytes(), nv, 8, "ATTRIBUTES", "OCTAHEDRAL",
                                         compressed=encode_vertex(oct16, 1, 3)), 5122, "VEC3", nv, normalized=True),
             "TEXCOORD_0": g.accessor(g.view(uv16.tobytes(), nv, 4, "ATTRIBUTES", compressed=encode_vertex(uv16, 1, 3)),
                                      5123, "VEC2", nv, normalized=True)}
    idx = g.accessor(g.view(i16.tobytes(), ni, 2, "INDICES", compressed=mo.encode_index_sequence(i16, ni, nv),
                            byte_stride=False), 5123, "SCALAR", ni)
    tr = np.array([[-2.5, 0.0, 0.0], [0.0, 0.0, 0.0], [2.5, 0.5, -1.0]], np.float32)
    ang = np.array([0.3, 1.1, 2.0])
    ax = np.array([[0.0, 1.0, 0.0], [1.0, 0.0, 0.0], [0.6, 0.0, 0.8]])
    quat = np.c_[ax * np.sin(ang / 2)[:, None], np.cos(ang / 2)]                # glTF x, y, z, w
    texp = filter_encode("Exp", tr, 12, 23, 0)
    qenc = filter_encode("Quat", quat, 8, 12)
    inst = {"TRANSLATION": g.accessor(g.view(texp.tobytes(), 3, 12, "ATTRIBUTES", "EXPONENTIAL",
                                             compressed=encode_vertex(texp, 1, 3)), 5126, "VEC3", 3),
            "ROTATION": g.accessor(g.view(qenc.tobytes(), 3, 8, "ATTRIBUTES", "QUATERNION",
                                          compressed=encode_vertex(qenc, 1, 3)), 5122, "VEC4", 3, normalized=True)}
    expected.update({"src_uv16": uv16, "src_translation": tr, "src_rotation": quat})
    expected.update(g.write("sphere_khr.glb", {**scene_header(attrs, idx,
                                                              {"extensions": {"EXT_mesh_gpu_instancing":
                                                                              {"attributes": inst}}}),
                                               "extensionsUsed": ["KHR_mesh_quantization", "EXT_mesh_gpu_instancing"],
                                               "extensionsRequired": ["KHR_mesh_quantization",
                                                                      "EXT_mesh_gpu_instancing"]}))

    # --- sphere_used.glb: EXT used only, real fallback file, v0 codecs, no filters
    g = Glb("EXT_meshopt_compression")
    mo.encode_index_version(0)
    n32 = nrm.astype(np.float32)
    attrs = {"POSITION": g.accessor(g.view(p32.tobytes(), nv, 12, "ATTRIBUTES", compressed=encode_vertex(p32, 0)),
                                    5126, "VEC3", nv, **bounds),
             "NORMAL": g.accessor(g.view(n32.tobytes(), nv, 12, "ATTRIBUTES", compressed=encode_vertex(n32, 0)),
                                  5126, "VEC3", nv),
             "TEXCOORD_0": g.accessor(g.view(uv32.tobytes(), nv, 8, "ATTRIBUTES", compressed=encode_vertex(uv32, 0)),
                                      5126, "VEC2", nv)}
    idx = g.accessor(g.view(i16.tobytes(), ni, 2, "TRIANGLES", compressed=mo.encode_index_buffer(i16, ni, nv),
                            byte_stride=False), 5123, "SCALAR", ni)
    expected.update(g.write("sphere_used.glb", scene_header(attrs, idx), required=False,
                            fallback_uri="sphere_used.bin"))

    np.savez_compressed(os.path.join(OUT, "expected.npz"), **expected)
    for f in sorted(os.listdir(OUT)):
        print(f, os.path.getsize(os.path.join(OUT, f)), file=sys.stderr)


if __name__ == "__main__":
    main()
