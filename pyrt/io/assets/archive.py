"""Models in ZIP archives, as download sites ship them (a ``.gltf`` with its ``.bin`` and ``textures/`` folder, an OBJ
with its MTL and images, a readme and a licence beside them).

:func:`load_zip` picks the model inside, extracts the archive into a temporary folder, loads the model there with the
loader for its format (its textures and buffers found by their relative paths, as in the unpacked folder) and deletes
the folder: textures are decoded during the load, so nothing is read from it later. Paths in the asset, its warnings
and errors read ``ARCHIVE.zip!member`` instead of the temporary folder.

Which model: the members with a supported extension, macOS resource forks (``__MACOSX/``, ``._*``) left out; glTF /
GLB first, then OBJ, PLY, STL, OFF (a scan or a CAD export beside a glTF is usually its source); among those the one
nearest the archive's root. Two or more equally good candidates are an error that lists them; ``ARCHIVE.zip!member``
(e.g. ``pack.zip!models/chair.obj``) names the model to load instead (:func:`split_member`). The archive must be safe to extract: a member whose path leaves the folder (absolute, ``..``)
or links elsewhere, more than :data:`MAX_MEMBERS` members or more than :data:`MAX_BYTES` of uncompressed data are
errors naming the archive, as are a corrupt or encrypted archive and one without a model.
"""
from __future__ import annotations

import os
import posixpath
import shutil
import stat
import tempfile
import zipfile

from pyrt.io.assets.common import FORMATS, AssetError

#: the most members an archive may have
MAX_MEMBERS = 100_000
#: the most uncompressed bytes an archive may hold (a model with its textures: far less; a zip bomb: more)
MAX_BYTES = 8 << 30
#: formats in the order a model is preferred when an archive holds several
PREFERENCE = ("gltf", "obj", "ply", "stl", "off")


def _member_ok(name):
    """True when ``name`` stays inside the extraction folder (relative, no ``..``)."""
    if name.startswith(("/", "\\")) or (len(name) > 1 and name[1] == ":"):
        return False
    parts = name.replace("\\", "/").split("/")
    return ".." not in parts


def _junk(name):
    """macOS's resource forks: ``__MACOSX/`` folders and ``._name`` files."""
    parts = name.split("/")
    return "__MACOSX" in parts or parts[-1].startswith("._")


def model_member(path, names):
    """The member of archive ``path`` (its member ``names``) that holds the model (module docstring)."""
    found = []
    for n in names:
        if n.endswith("/") or _junk(n):
            continue
        fmt = FORMATS.get(posixpath.splitext(n)[1].lower())
        if fmt is not None and fmt in PREFERENCE:
            found.append((PREFERENCE.index(fmt), n.count("/"), n))
    if not found:
        raise AssetError(f"{path}: the archive holds no model file (looked for "
                         f"{', '.join(sorted(k for k, v in FORMATS.items() if v in PREFERENCE))})")
    found.sort()
    best = [n for r, d, n in found if (r, d) == found[0][:2]]
    if len(best) > 1:
        shown = ", ".join(best[:6]) + (f" and {len(best) - 6} more" if len(best) > 6 else "")
        raise AssetError(f"{path}: the archive holds {len(best)} models ({shown}): name one as "
                         f"'{path}!{best[0]}'")
    return best[0]


def split_member(path):
    """``(archive, member)`` for a path ``ARCHIVE.zip!member`` whose archive is a file, else None."""
    head, sep, member = path.rpartition("!")
    if not sep or not head.lower().endswith(".zip") or not member or not os.path.isfile(head):
        return None
    return head, member.replace("\\", "/").lstrip("/")


def load_zip(path, load, member=None):
    """Load the model in ZIP archive ``path`` with ``load(extracted_path)`` (module docstring); returns its Asset.
    ``member``: the archive's member to load (None: the one :func:`model_member` picks)."""
    try:
        zf = zipfile.ZipFile(path)
    except (zipfile.BadZipFile, OSError) as exc:
        raise AssetError(f"{path}: not a readable ZIP archive ({exc})") from None
    with zf:
        infos = zf.infolist()
        if len(infos) > MAX_MEMBERS:
            raise AssetError(f"{path}: the archive has {len(infos)} members (at most {MAX_MEMBERS} are extracted)")
        total = sum(i.file_size for i in infos)
        if total > MAX_BYTES:
            raise AssetError(f"{path}: the archive unpacks to {total / (1 << 30):.1f} GiB (at most "
                             f"{MAX_BYTES >> 30} GiB are extracted)")
        for i in infos:
            if not _member_ok(i.filename):
                raise AssetError(f"{path}: member {i.filename!r} would be extracted outside its folder: refused")
            if stat.S_ISLNK(i.external_attr >> 16):
                raise AssetError(f"{path}: member {i.filename!r} is a symbolic link: refused")
            if i.flag_bits & 0x1:
                raise AssetError(f"{path}: member {i.filename!r} is encrypted: pyrt cannot read it")
        names = [i.filename for i in infos]
        if member is None:
            member = model_member(path, names)
        elif member not in names:
            raise AssetError(f"{path}: the archive has no member {member!r}")
        elif FORMATS.get(posixpath.splitext(member)[1].lower()) not in PREFERENCE:
            raise AssetError(f"{path}!{member}: unsupported file type {posixpath.splitext(member)[1]!r}")
        tmp = tempfile.mkdtemp(prefix="pyrt-zip-")
        try:
            try:
                zf.extractall(tmp)
            except (zipfile.BadZipFile, OSError, RuntimeError, EOFError) as exc:
                raise AssetError(f"{path}: the archive cannot be extracted ({exc})") from None
            inner = os.path.join(tmp, *member.split("/"))
            shown = f"{path}!{member}"
            try:
                asset = load(inner)
            except AssetError as exc:
                raise AssetError(str(exc).replace(inner, shown).replace(tmp + os.sep, f"{path}!")) from None
        finally:
            shutil.rmtree(tmp, ignore_errors=True)
    asset.path = shown
    asset.warnings = [w.replace(inner, shown).replace(tmp + os.sep, f"{path}!") for w in asset.warnings]
    asset.substitutions = [w.replace(inner, shown).replace(tmp + os.sep, f"{path}!") for w in asset.substitutions]
    return asset
