"""Finding the files a model names where they really are: OBJ's ``mtllib`` and the MTL's texture maps.

Models found on the internet name their textures as the exporter's machine had them. Three cases are common:

- a Windows absolute path (``map_Kd C:\\Users\\me\\Desktop\\car\\textures\\paint.jpg``);
- the right name in the wrong case (``Paint.JPG`` for ``paint.jpg``: Windows and macOS do not care, Linux does);
- the file moved into or out of a ``textures/`` folder when the model was zipped.

Blender's and MeshLab's importers look further than the literal path, and so does :func:`find_file`:

1. the path as named (backslashes read as separators), relative to the model's folder unless absolute;
2. the same path, each component matched without regard to case;
3. the file name alone, without regard to case, in the model's folder and its subfolders up to
   :data:`SEARCH_DEPTH` levels down (at most :data:`SEARCH_ENTRIES` directory entries are looked at, so a
   model saved in a huge folder does not make loading slow). If several files match, the one with the
   shortest path is taken, and then the first in sorted order.

Any answer but the first is a substitution: the loaders name the file they used in a warning, so a wrong
guess is visible.
"""
from __future__ import annotations

import ntpath
import os

__all__ = ["find_file", "SEARCH_DEPTH", "SEARCH_ENTRIES"]

#: subfolder levels below the model's folder searched for a file by its name
SEARCH_DEPTH = 2
#: directory entries looked at, at most, in that search
SEARCH_ENTRIES = 20000


def _case_insensitive(base, rel):
    """``rel`` (components separated by "/") under ``base`` with every component matched without regard to case,
    or None."""
    cur = base
    for part in rel.split("/"):
        if part in ("", "."):
            continue
        if part == "..":
            cur = os.path.dirname(cur)
            continue
        try:
            names = os.listdir(cur)
        except OSError:
            return None
        if part in names:
            cur = os.path.join(cur, part)
            continue
        low = part.lower()
        hits = sorted(n for n in names if n.lower() == low)
        if not hits:
            return None
        cur = os.path.join(cur, hits[0])
    return cur if os.path.isfile(cur) else None


def _by_name(base, name):
    """Files called ``name`` (any case) in ``base`` and its subfolders, :data:`SEARCH_DEPTH` levels at most."""
    low = name.lower()
    found, seen = [], 0
    top = base.rstrip(os.sep).count(os.sep)
    for root, dirs, files in os.walk(base):
        seen += len(dirs) + len(files)
        found += [os.path.join(root, f) for f in files if f.lower() == low]
        if root.count(os.sep) - top >= SEARCH_DEPTH or seen > SEARCH_ENTRIES:
            dirs[:] = []
        else:
            dirs.sort()
        if seen > SEARCH_ENTRIES:
            break
    return sorted(found, key=lambda p: (p.count(os.sep), p))


def find_file(base, name):
    """Where the file a model names ``name`` is: ``(path, how)``. ``base`` is the model's folder.

    ``how`` is None when the file is where it is named. Otherwise it is a phrase for the loader's warning
    ("found by its name in another case", "found by its file name"). The result is ``(None, None)`` when
    nothing matches. See the module docstring for the search order.
    """
    norm = name.replace("\\", "/")
    windows_abs = ntpath.isabs(name) and (ntpath.splitdrive(name)[0] != "" or name.startswith("\\"))
    if not windows_abs:
        direct = norm if os.path.isabs(norm) else os.path.join(base, norm)
        if os.path.isfile(direct):
            return direct, None
        if not os.path.isabs(norm):
            hit = _case_insensitive(base, norm)
            if hit is not None:
                return hit, "found by its name in another case"
    leaf = ntpath.basename(name) if windows_abs else os.path.basename(norm)
    if leaf:
        hits = _by_name(base, leaf)
        if hits:
            return hits[0], "found by its file name"
    return None, None
