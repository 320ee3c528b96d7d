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

What a model may read (the rule for files a model names)
--------------------------------------------------------
Only files inside its *root*: the model file's own folder and its subfolders, or, for a model loaded from a ZIP
archive, the archive (:mod:`pyrt.io.assets.archive`). :func:`pyrt.load_asset`'s ``root=`` names a wider folder
for loose files (a model pack whose models share a ``textures/`` folder beside theirs). The test is made on the
real path, so a symbolic link inside the root that points outside it is outside. A relative reference that
leaves the root (``../../../etc/hostname``) or a link out of it is an :class:`~pyrt.io.assets.common.AssetError`
naming the reference and the root; nothing is opened and no byte of the file is quoted. An absolute path outside
the root (an exporter's ``/Users/me/car/paint.jpg``) is read as a Windows absolute path is: its file name is
searched for inside the root (step 3), else it is not found. :func:`reading_root` sets the root for a load.
"""
from __future__ import annotations

from contextlib import contextmanager
import contextvars
import ntpath
import os

from pyrt.io.assets.common import AssetError

__all__ = ["find_file", "reading_root", "active_root", "OutsideRootError", "SEARCH_DEPTH", "SEARCH_ENTRIES"]

#: subfolder levels below the model's folder searched for a file by its name
SEARCH_DEPTH = 2
#: directory entries looked at, at most, in that search
SEARCH_ENTRIES = 20000


class OutsideRootError(AssetError):
    """A model names a file outside the folder or archive it may read (module docstring)."""


#: the folder (real path) and its description a load may read files from: set by :func:`reading_root`
_ROOT = contextvars.ContextVar("pyrt_asset_root", default=None)


@contextmanager
def reading_root(folder, label=None):
    """Within this ``with`` block, :func:`find_file` answers only files inside ``folder`` (module docstring).

    ``label`` describes the root in error messages (default: "the model's folder FOLDER"). Blocks nest; each
    thread and task has its own root (a context variable)."""
    real = os.path.realpath(os.fspath(folder))
    token = _ROOT.set((real, label or f"the model's folder {folder}"))
    try:
        yield
    finally:
        _ROOT.reset(token)


def active_root():
    """The ``(real folder, label)`` of the innermost :func:`reading_root` block, or None outside any."""
    return _ROOT.get()


def _inside(path, root):
    """True when ``path`` (lexically normalised; no links resolved) is ``root`` or below it."""
    path = os.path.normpath(path)
    return path == root or path.startswith(root.rstrip(os.sep) + os.sep)


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
    nothing matches. See the module docstring for the search order and for the root outside which nothing is
    answered (that of :func:`reading_root`, else ``base`` itself).

    Raises
    ------
    OutsideRootError
        ``name`` is a relative path that leaves the root, or names a link to a file outside it.
    """
    root, label = _ROOT.get() or (os.path.realpath(base), f"the model's folder {base}")
    rbase = os.path.realpath(base)

    def outside(hit):
        """True when the file ``hit`` really is (its links resolved) outside the root."""
        return not _inside(os.path.realpath(hit), root)

    norm = name.replace("\\", "/")
    windows_abs = ntpath.isabs(name) and (ntpath.splitdrive(name)[0] != "" or name.startswith("\\"))
    unix_abs = not windows_abs and os.path.isabs(norm)
    if unix_abs and not _inside(norm, root):
        windows_abs = True                   # an exporter's path: looked for by its file name inside the root
    elif not windows_abs:
        if not unix_abs and not _inside(os.path.join(rbase, norm), root):
            raise OutsideRootError(f"{name[:200]!r} leaves {label}: not read (a model reads only files inside its folder "
                             "or archive)")
        direct = norm if unix_abs else os.path.join(base, norm)
        hit, how = (direct, None) if os.path.isfile(direct) else (None, None)
        if hit is None and not unix_abs:
            hit = _case_insensitive(base, norm)
            how = "found by its name in another case"
        if hit is not None:
            if outside(hit):
                raise OutsideRootError(f"{name[:200]!r} is a link to a file outside {label}: not read")
            return hit, how
    leaf = ntpath.basename(name) if windows_abs else os.path.basename(norm)
    if leaf:
        hits = [h for h in _by_name(base, leaf) if not outside(h)]
        if hits:
            return hits[0], "found by its file name"
    return None, None
