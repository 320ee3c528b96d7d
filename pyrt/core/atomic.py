"""Writing a file all at once (:func:`atomic_write`), checking before a long computation that it can be written
(:func:`check_writable`), and removing what killed writers left behind.

A file is written to a temporary file ``.NAME.XXXXXXXX.tmp`` beside the target and renamed over it when complete,
so a failed or interrupted write keeps the previous file. The writer holds an exclusive ``flock`` on its temporary
file while it writes. A process killed during a write cannot remove its temporary file; the next write of the same
target (or :func:`check_writable`) removes every ``.NAME.*.tmp`` of that target whose lock it can take, i.e. whose
writer is gone (a write in progress in another process keeps its lock and its file). Without ``fcntl`` (Windows)
nothing is locked and stale temporaries are left alone. Errors name the target, never the temporary file.
"""
from __future__ import annotations

import os
import re
import secrets

from pyrt.core.errors import Error

try:
    import fcntl
except ImportError:          # Windows
    fcntl = None


class ImageWriteError(Error, ValueError):
    """An image cannot be written: wrong shape, non-finite values, or the target is a folder."""



def _temporary(path):
    """Create the temporary file for ``path`` (the permissions of the file it will replace, else ``0o666`` minus
    the umask), locked: ``(tmp, fd)``; the lock lasts until ``fd`` is closed. ImageWriteError naming ``path`` (not
    the temporary file) when it cannot be created."""
    folder, base = os.path.split(os.path.abspath(path))
    try:
        mode = os.stat(path).st_mode & 0o7777
    except OSError:
        mode = 0o666
    tmp = os.path.join(folder, f".{base}.{secrets.token_hex(4)}.tmp")
    try:
        fd = os.open(tmp, os.O_WRONLY | os.O_CREAT | os.O_EXCL, mode)
    except OSError as exc:
        raise ImageWriteError(f"cannot write {path}: cannot create a file in its folder {folder} "
                              f"({exc.strerror or exc})") from None
    if fcntl is not None:
        try:
            fcntl.flock(fd, fcntl.LOCK_EX | fcntl.LOCK_NB)
        except OSError:
            pass             # a file system without locks: the file is still ours (O_EXCL)
    return tmp, fd


def remove_stale_temporaries(path):
    """Remove the ``.NAME.XXXXXXXX.tmp`` files of target ``path`` whose writer is gone (module docstring); returns
    how many were removed."""
    if fcntl is None:
        return 0
    folder, base = os.path.split(os.path.abspath(path))
    pattern = re.compile(r"\." + re.escape(base) + r"\.[0-9a-f]{8}\.tmp")
    try:
        names = [n for n in os.listdir(folder) if pattern.fullmatch(n)]
    except OSError:
        return 0
    removed = 0
    for n in names:
        p = os.path.join(folder, n)
        try:
            fd = os.open(p, os.O_RDONLY)
        except OSError:
            continue
        try:
            fcntl.flock(fd, fcntl.LOCK_EX | fcntl.LOCK_NB)     # taken: no writer holds it any more
            os.remove(p)
            removed += 1
        except OSError:
            pass                                               # a write in progress, or not ours to remove
        finally:
            os.close(fd)
    return removed


def check_writable(path):
    """Check that ``path`` can be written by :func:`atomic_write`, by creating (and removing) its temporary file
    now: as root ``os.access`` says yes to ``/proc`` and ``/sys``, where no file can be created. Removes stale
    temporaries of ``path`` too. ImageWriteError naming ``path`` otherwise."""
    path = os.fspath(path)
    if os.path.isdir(path):
        raise ImageWriteError(f"cannot write {path}: it is a folder")
    folder = os.path.dirname(os.path.abspath(path))
    if not os.path.isdir(folder):
        raise ImageWriteError(f"cannot write {path}: the folder {folder} does not exist")
    remove_stale_temporaries(path)
    tmp, fd = _temporary(path)
    os.close(fd)
    try:
        os.remove(tmp)
    except OSError:
        pass


def atomic_write(path, write):
    """Create or replace the file ``path`` all at once: ``write(tmp)`` writes a temporary file, renamed over it.

    Parameters
    ----------
    path : str or os.PathLike
        The target. Its folder must exist.
    write : callable
        ``write(tmp_path)`` writes the whole file at ``tmp_path`` (a new, empty file named
        ``.NAME.XXXXXXXX.tmp`` in the target's folder, so the rename never crosses file systems; locked while
        it is written, and stale ones of the same target removed first: module docstring).

    The temporary file is flushed to disk and ``os.replace``-d over ``path`` (atomic on POSIX and
    Windows). If ``write`` raises -- any exception, ``KeyboardInterrupt`` included -- the temporary file
    is removed, the previous ``path`` (if any) is left as it was, and the exception propagates. The new
    file gets the permissions of the file it replaces, or the usual ones (``0o666`` minus the umask).
    """
    path = os.fspath(path)
    folder = os.path.dirname(os.path.abspath(path))
    if os.path.isdir(path):
        raise ImageWriteError(f"cannot write {path}: it is a folder")
    if not os.path.isdir(folder):
        raise ImageWriteError(f"cannot write {path}: the folder {folder} does not exist")
    remove_stale_temporaries(path)
    tmp, lock = _temporary(path)
    try:
        write(tmp)
        fd = os.open(tmp, os.O_RDONLY)
        try:
            os.fsync(fd)
        finally:
            os.close(fd)
        try:
            os.replace(tmp, path)
        except OSError as exc:
            raise ImageWriteError(f"cannot write {path}: {exc.strerror or exc}") from None
    except BaseException:
        try:
            os.remove(tmp)
        except OSError:
            pass
        raise
    finally:
        os.close(lock)


def write_bytes(path, data):
    """Write ``data`` (bytes, or str as UTF-8) to ``path`` through :func:`atomic_write`."""
    blob = data.encode("utf-8") if isinstance(data, str) else bytes(data)

    def put(tmp):
        with open(tmp, "wb") as fh:
            fh.write(blob)

    atomic_write(path, put)


