"""Models in ZIP archives, as download sites ship them (a ``.gltf`` with its ``.bin`` and ``textures/`` folder, an OBJ
with its MTL and images, a readme and a licence beside them).

:func:`load_zip` picks the model inside, extracts it and the files it names into a temporary folder, loads the model there with the
loader for its format (its textures and buffers found by their relative paths, as in the unpacked folder) and deletes
the folder: textures are decoded during the load, so nothing is read from it later. Paths in the asset, its warnings
and errors read ``ARCHIVE.zip!member`` instead of the temporary folder.

Which model: the members with a supported extension, macOS resource forks (``__MACOSX/``, ``._*``) left out; glTF /
GLB first, then OBJ, PLY, STL, OFF (a scan or a CAD export beside a glTF is usually its source); among those the one
nearest the archive's root. Two or more equally good candidates are an error that lists them; ``ARCHIVE.zip!member``
(e.g. ``pack.zip!models/chair.obj``) names the model to load instead (:func:`split_member`).

Only what the model needs is extracted: the model's member and the members whose file name (in any case) the model
names -- a glTF's JSON (its buffer and image URIs, percent-decoded), an OBJ's ``mtllib`` lines and those MTL files,
a PLY's header (``TextureFile``); a readme, another model or a junk member beside them is left in the archive. The
model reads only the extracted folder: a URI that climbs out of it (``../../../etc/hostname``) is an error naming the
URI (:mod:`pyrt.io.assets.find_file`).

The archive must be safe to extract, checked from its directory before a byte is extracted: a member whose path
leaves the folder (absolute, ``..``) or links elsewhere, more than :data:`MAX_MEMBERS` members, a member to extract
larger than :data:`MAX_MEMBER_BYTES` or (above :data:`RATIO_MIN_BYTES`) compressed more than :data:`MAX_RATIO`
times (a zip bomb: zeros or one repeated line), or more than :data:`MAX_BYTES` to extract in all are errors naming
the archive, the member and the numbers, as are a corrupt or encrypted archive and one without a model. Each member
is extracted by a loop that stops at its stated size, so a directory that lies about a size cannot write more.
"""
from __future__ import annotations

import os
import posixpath
import re
import shutil
import stat
import struct
import tempfile
import urllib.parse
import zipfile

from pyrt.io.assets.common import FORMATS, AssetError
from pyrt.io.assets.find_file import reading_root

#: the most members an archive may have
MAX_MEMBERS = 100_000
#: the most uncompressed bytes an archive may hold (a model with its textures: far less; a zip bomb: more)
MAX_BYTES = 8 << 30
#: the largest member extracted: 1 GiB (a model's OBJ text or glTF buffer; a 1.5 GB OBJ needs ~6 GB to load)
MAX_MEMBER_BYTES = 1 << 30
#: the highest compression ratio (uncompressed / compressed size) accepted for a member above RATIO_MIN_BYTES:
#: OBJ text and glTF buffers compress 2-10x, images about 1x; a zip bomb's zeros or repeated lines 300-1000x
MAX_RATIO = 100
#: members smaller than this (16 MiB) are extracted whatever their ratio (a small MTL of repeated lines may be 50x)
RATIO_MIN_BYTES = 16 << 20
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


def _mib(n):
    """``n`` bytes in bytes, MiB or GiB, for a message."""
    if n < 1 << 20:
        return f"{n} bytes"
    return f"{n / (1 << 30):.1f} GiB" if n >= 1 << 30 else f"{n / (1 << 20):.1f} MiB"


def _check_size(path, info):
    """AssetError naming ``info``'s member and its sizes when it is too large or too compressed to extract."""
    if info.file_size > MAX_MEMBER_BYTES:
        raise AssetError(f"{path}: member {info.filename!r} unpacks to {_mib(info.file_size)} (at most "
                         f"{_mib(MAX_MEMBER_BYTES)} per member are extracted): refused")
    ratio = info.file_size / max(info.compress_size, 1)
    if info.file_size > RATIO_MIN_BYTES and ratio > MAX_RATIO:
        raise AssetError(f"{path}: member {info.filename!r} unpacks from {_mib(info.compress_size)} to "
                         f"{_mib(info.file_size)}, {ratio:.0f} times (at most {MAX_RATIO} for a member above "
                         f"{_mib(RATIO_MIN_BYTES)}): refused as a likely zip bomb")


def _extract(zf, info, folder):
    """Write member ``info`` under ``folder``, at most its stated size (a lying directory cannot write more)."""
    dest = os.path.join(folder, *info.filename.split("/"))
    os.makedirs(os.path.dirname(dest), exist_ok=True)
    left = info.file_size
    with zf.open(info) as src, open(dest, "wb") as out:
        while left > 0:
            block = src.read(min(left, 1 << 20))
            if not block:
                break
            out.write(block)
            left -= len(block)
    return dest


def _named_text(fmt, dest):
    """The text of extracted file ``dest`` in which a model names its other files, lower case: a glTF's JSON
    (percent-decoded), an OBJ's ``mtllib`` lines, an MTL whole, a PLY's header; "" for the other formats."""
    if fmt == "gltf":
        with open(dest, "rb") as fh:
            data = fh.read()
        if data[:4] == b"glTF" and len(data) >= 20:      # GLB: the JSON chunk
            n = struct.unpack_from("<I", data, 12)[0]
            data = data[20:20 + n]
        return urllib.parse.unquote(data.decode("utf-8", "replace")).lower()
    if fmt in ("obj", "mtl", "ply"):
        out = []
        with open(dest, "rb") as fh:
            for raw in fh:
                line = raw.decode("utf-8", "replace")
                if fmt == "mtl" or (fmt == "obj" and re.match(r"\s*mtllib\s", line)) or fmt == "ply":
                    out.append(line)
                if fmt == "ply" and line.strip() == "end_header":
                    break
        return "".join(out).lower()
    return ""


def _extract_needed(path, zf, infos, member, folder):
    """Extract ``member`` and the members it names (module docstring) into ``folder``, each checked first."""
    by_name = {i.filename: i for i in infos}
    others = [i for i in infos if not i.filename.endswith("/") and not _junk(i.filename) and i.filename != member]
    todo, done, total = [by_name[member]], set(), 0
    while todo:
        info = todo.pop(0)
        if info.filename in done:
            continue
        _check_size(path, info)
        total += info.file_size
        if total > MAX_BYTES:
            raise AssetError(f"{path}: the members the model needs unpack to {_mib(total)} or more, with "
                             f"{info.filename!r} (at most {_mib(MAX_BYTES)} are extracted): refused")
        try:
            dest = _extract(zf, info, folder)
        except (zipfile.BadZipFile, OSError, RuntimeError, EOFError, NotImplementedError) as exc:
            raise AssetError(f"{path}: member {info.filename!r} cannot be extracted ({exc})") from None
        done.add(info.filename)
        ext = posixpath.splitext(info.filename)[1].lower()
        fmt = "mtl" if ext == ".mtl" else FORMATS.get(ext) if info.filename == member else None
        text = _named_text(fmt, dest) if fmt else ""
        if text:
            todo += [i for i in others if i.filename not in done
                     and posixpath.basename(i.filename).lower() in text]


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
            _extract_needed(path, zf, infos, member, tmp)
            inner = os.path.join(tmp, *member.split("/"))
            shown = f"{path}!{member}"
            try:
                with reading_root(tmp, f"the archive {path}"):
                    asset = load(inner)
            except AssetError as exc:      # the same class (OutsideRootError stays one), the paths as the user knows them
                raise type(exc)(str(exc).replace(inner, shown).replace(tmp + os.sep, f"{path}!")) from None
        finally:
            shutil.rmtree(tmp, ignore_errors=True)
    asset.path = shown
    asset.warnings = [w.replace(inner, shown).replace(tmp + os.sep, f"{path}!") for w in asset.warnings]
    asset.substitutions = [w.replace(inner, shown).replace(tmp + os.sep, f"{path}!") for w in asset.substitutions]
    return asset
