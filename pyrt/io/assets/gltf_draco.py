"""``KHR_draco_mesh_compression``: the Draco-compressed geometry of a glTF primitive, decoded by DracoPy (Google's
Draco decoder in a maintained wheel; the optional ``[draco]`` extra, imported only when a file has Draco data).

What a primitive with the extension becomes (the extension's conformance rules):

- its ``bufferView`` is decoded to a Draco mesh, whose faces are the primitive's indices (a triangle list: the
  primitive's mode must be 4, TRIANGLES);
- the extension's ``attributes`` map glTF attribute names (``POSITION``, ``NORMAL``, ``TEXCOORD_n``,
  ``COLOR_n``...) to Draco unique ids; those attributes (the ones pyrt reads: not the skin's ``JOINTS_n`` /
  ``WEIGHTS_n``, nor ``TANGENT``) are read from the Draco mesh, not from their accessors,
  which only say how to read them (:meth:`GltfFile.accessor_values`: type, componentType, ``normalized``;
  DracoPy returns quantized attributes dequantized, as float32). Attributes the extension does not list are read
  from their accessors as usual;
- the decoded vertex count must be the ``POSITION`` accessor's ``count``; the loader checks the index range
  and that every attribute has a row per vertex.

Without DracoPy: a file that *requires* the extension is refused with the install hint
(:class:`pyrt.io.assets.gltf_file.GltfFile`); a primitive with an uncompressed fallback (its ``POSITION`` accessor
has a bufferView) is read from the fallback; one without is an :class:`AssetError` with the hint.
"""
from __future__ import annotations

import re

import numpy as np

from pyrt.io.assets.common import AssetError

DRACO = "KHR_draco_mesh_compression"
INSTALL_HINT = "pip install 'pyrt-embree[draco]'"
#: the reason a file that requires the extension is refused without DracoPy
DRACO_MISSING = f"Draco-compressed geometry, which needs the DracoPy package: {INSTALL_HINT}"
#: the attributes the loader reads (others, e.g. JOINTS_0 / WEIGHTS_0 / TANGENT, are not converted)
_READ = re.compile(r"POSITION|NORMAL|TEXCOORD_\d+|COLOR_\d+")


def dracopy():
    """The ``DracoPy`` module, or None when it cannot be imported (the ``[draco]`` extra is not installed)."""
    try:
        import DracoPy
    except ImportError:
        return None
    return DracoPy


def decode_draco_primitive(g, p, where):
    """The indices and attributes of primitive ``p``, decoded from its ``KHR_draco_mesh_compression`` data.

    Parameters
    ----------
    g : GltfFile
        The file (its bufferViews and accessors).
    p : dict
        The primitive: ``p["extensions"]`` has ``KHR_draco_mesh_compression``, ``p["attributes"]`` a
        ``POSITION``.
    where : str
        The primitive in error messages (``"mesh 0 (name) primitive 1"``).

    Returns
    -------
    tuple of (ndarray, dict) or None
        ``(indices, attributes)``: the (3F,) int64 vertex indices of the triangles, and a dict from each glTF
        attribute name the extension lists (that the primitive has and pyrt reads) to its float64 (n, ncomp)
        values, integers normalised as its accessor says. None when DracoPy is not installed and the primitive
        has an uncompressed fallback: its accessors are read instead.

    Raises
    ------
    AssetError
        Naming the file and the primitive: DracoPy missing and no fallback (with :data:`INSTALL_HINT`), a
        malformed extension object, a mode other than TRIANGLES, data the Draco decoder rejects (with its
        message) or that decodes to a point cloud, an attribute id the Draco data does not have, a vertex count
        that differs from the ``POSITION`` accessor's.
    """
    ext = p["extensions"][DRACO]
    attrs = p.get("attributes", {})
    draco = dracopy()
    if draco is None:
        if "POSITION" in attrs and "bufferView" in g.get("accessors", attrs["POSITION"]):
            return None
        raise AssetError(f"{g.path}: {where}: Draco-compressed geometry ({DRACO}) without an uncompressed "
                         f"fallback needs the DracoPy package: {INSTALL_HINT}")
    what = f"{g.path}: {where}: {DRACO}"
    if not isinstance(ext, dict) or not isinstance(ext.get("attributes"), dict):
        raise AssetError(f"{what}: must be an object with an 'attributes' object, got {ext!r}")
    mode = p.get("mode", 4)
    if mode != 4:
        raise AssetError(f"{what}: mode {mode}: Draco data decodes to a triangle list (mode 4, TRIANGLES)")
    raw, _ = g.view_bytes(ext.get("bufferView"))
    try:
        mesh = draco.decode(bytes(raw))
    except Exception as exc:     # DracoPy raises FileTypeException, TypeError, ValueError... for bad data
        raise AssetError(f"{what}: bufferView {ext.get('bufferView')}: the Draco decoder failed: "
                         f"{type(exc).__name__}: {exc}") from None
    if not isinstance(mesh, draco.DracoMesh):
        raise AssetError(f"{what}: the Draco data is a point cloud, not a triangle mesh")
    out = {}
    for name, uid in ext["attributes"].items():
        if name not in attrs or not _READ.fullmatch(name):     # (a subset of the primitive's; skins are not read)
            continue
        att = mesh.get_attribute_by_unique_id(uid) if isinstance(uid, int) and not isinstance(uid, bool) else None
        if att is None:
            raise AssetError(f"{what}: {name}: the Draco data has no attribute with unique id {uid!r}")
        out[name] = g.accessor_values(attrs[name], att["data"], f"{where}: {name} (Draco attribute {uid})")
    nv = out["POSITION"].shape[0] if "POSITION" in out else len(mesh.points)
    count = g.get("accessors", attrs["POSITION"]).get("count")
    if count != nv:
        raise AssetError(f"{what}: the Draco data has {nv} vertices, the POSITION accessor says {count!r}")
    return np.asarray(mesh.faces).astype(np.int64).ravel(), out
