"""A minimal glTF writer for generated models: one triangle primitive, its vertex attributes, one material and its
images, all embedded as ``data:`` URIs in one JSON header (tests, the tools' example models).

:func:`embedded_gltf` returns the header; ``json.dump`` it to a ``.gltf`` file, or give it with its buffer to
:func:`pyrt.io.assets.gltf_file.pack_glb` for a GLB. Accessor types follow the arrays: ``(N,)`` SCALAR, ``(N, k)``
VECk; component types their dtypes (float32, uint32, uint16, uint8); VEC3 accessors get the ``min`` / ``max`` the
spec requires of POSITION.
"""
from __future__ import annotations

import base64
import io

import numpy as np

#: glTF component types of the dtypes an accessor may have
COMPONENT_TYPES = {np.dtype(np.float32): 5126, np.dtype(np.uint32): 5125, np.dtype(np.uint16): 5123,
                   np.dtype(np.uint8): 5121}


def _png_uri(texels):
    """A ``data:image/png`` URI of uint8 texels ``(H, W, C)``."""
    from PIL import Image       # Pillow: a dependency of the image readers already
    buf = io.BytesIO()
    Image.fromarray(np.asarray(texels, dtype=np.uint8)).save(buf, format="PNG")
    return "data:image/png;base64," + base64.b64encode(buf.getvalue()).decode()


def embedded_gltf(attributes, indices, material, images=()):
    """The JSON header (dict) of a glTF 2.0 file holding one mesh of one triangle primitive, every byte embedded.

    Parameters
    ----------
    attributes : dict
        glTF attribute name (``"POSITION"``, ``"NORMAL"``, ``"TEXCOORD_0"``, ``"TANGENT"``, ...) -> array (float32,
        or another dtype of :data:`COMPONENT_TYPES`), one row per vertex.
    indices : (F, 3) integer array
        Triangles (written as uint32).
    material : dict
        The glTF material (textures refer to ``images`` by index: texture ``i`` is image ``i``).
    images : sequence of (H, W, C) uint8 arrays
        PNG-encoded into the file.
    """
    blob = bytearray()
    views, accessors = [], []

    def add(arr):
        a = np.ascontiguousarray(arr)
        views.append({"buffer": 0, "byteOffset": len(blob), "byteLength": a.nbytes})
        blob.extend(a.tobytes())
        blob.extend(b"\0" * (-len(blob) % 4))
        typ = "SCALAR" if a.ndim == 1 else f"VEC{a.shape[1]}"
        acc = {"bufferView": len(views) - 1, "componentType": COMPONENT_TYPES[a.dtype], "count": int(a.shape[0]),
               "type": typ}
        if typ == "VEC3":
            acc["min"], acc["max"] = a.min(0).tolist(), a.max(0).tolist()
        accessors.append(acc)
        return len(accessors) - 1

    attrs = {name: add(np.asarray(a)) for name, a in attributes.items()}
    idx = add(np.asarray(indices).astype(np.uint32).ravel())
    header = {"asset": {"version": "2.0"}, "scene": 0, "scenes": [{"nodes": [0]}], "nodes": [{"mesh": 0}],
              "meshes": [{"primitives": [{"attributes": attrs, "indices": idx, "material": 0}]}],
              "materials": [material], "accessors": accessors, "bufferViews": views,
              "buffers": [{"byteLength": len(blob), "uri": "data:application/octet-stream;base64,"
                           + base64.b64encode(bytes(blob)).decode()}]}
    if images:
        header["images"] = [{"uri": _png_uri(im)} for im in images]
        header["textures"] = [{"source": i} for i in range(len(images))]
    return header
