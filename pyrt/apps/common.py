"""What the command-line programs share: argparse value types, output-path checks made before any
rendering, and the two-stage handling of SIGINT / SIGTERM (the first stops cleanly, the second aborts).

Exit codes of the programs: 0 done, 2 an error (one line ``PROG: error: <message>``, bad arguments included:
:class:`ArgumentParser`), 130 interrupted.
"""
from __future__ import annotations

import argparse
from contextlib import contextmanager
import math
import os
import signal
import sys
import threading

from pyrt.core.atomic import ImageWriteError, check_writable
from pyrt.core.errors import Error

#: The exit code of a program stopped by SIGINT / SIGTERM (128 + SIGINT, what shells report for Ctrl-C).
EXIT_INTERRUPTED = 130
#: The exit code of a run that ended with an error message.
EXIT_ERROR = 2
#: The output formats the renderers write, by file extension.
OUTPUT_EXTENSIONS = (".exr", ".png")


class OutputPathError(Error, ValueError):
    """An output path that cannot be written (no such folder, not writable, unknown extension, repeated)."""


# ============================================================================ console scripts

def run_console(main):
    """Run a program's ``main()`` as its console script and exit with its code without the interpreter's teardown.

    Once ``main`` returns, every file is written, closed and renamed into place; what remains is freeing the
    render's arrays and every imported module, ~0.3 s after a preview (``time pyrt-preview Duck.glb``: 2.85 s against
    2.48 s, medians of 3, docs/preview.md). So stdout and stderr are flushed and the process ends with
    ``os._exit``. An exception (``SystemExit`` from argparse's errors included) propagates as usual. The programs'
    ``main(argv)`` itself returns normally (tests and ``python -m`` call it).
    """
    rc = main()
    sys.stdout.flush()
    sys.stderr.flush()
    os._exit(int(rc or 0))


def process_age():
    """Seconds since this process started (the interpreter's start and the imports, when asked on entering
    ``main``), from Linux's ``/proc`` (10 ms resolution); None where that cannot be read (another system)."""
    try:
        with open("/proc/self/stat") as fh:
            stat = fh.read()
        with open("/proc/uptime") as fh:
            uptime = float(fh.read().split()[0])
        # the fields after "pid (name)": state is field 3 of proc(5), starttime (clock ticks after boot) field 22
        ticks = int(stat.rsplit(")", 1)[1].split()[19])
        return max(0.0, uptime - ticks / os.sysconf("SC_CLK_TCK"))
    except (OSError, ValueError, IndexError):
        return None


# ============================================================================ argparse types

class ArgumentParser(argparse.ArgumentParser):
    """argparse's parser whose errors are one line, ``PROG: error: <message> (PROG --help: the options)``, exit 2,
    instead of the usage block and then the message (sub-commands inherit it: ``pyrt render``'s say ``pyrt``)."""

    def error(self, message):
        """Print the one-line error to stderr and exit with :data:`EXIT_ERROR`."""
        prog = self.prog.split()[0] if self.prog else "pyrt"
        self.exit(EXIT_ERROR, f"{prog}: error: {message} ({self.prog} --help: the options)\n")


def _integer(text):
    try:
        return int(text, 10)
    except ValueError:
        raise argparse.ArgumentTypeError(f"expected an integer, got {text!r}") from None


def positive_int(text):
    """argparse type: an integer >= 1."""
    v = _integer(text)
    if v < 1:
        raise argparse.ArgumentTypeError(f"must be a positive integer, got {text!r}")
    return v


def nonnegative_int(text):
    """argparse type: an integer >= 0."""
    v = _integer(text)
    if v < 0:
        raise argparse.ArgumentTypeError(f"must be a non-negative integer, got {text!r}")
    return v


def finite_float(text):
    """argparse type: a finite number (no nan, no inf)."""
    try:
        v = float(text)
    except ValueError:
        raise argparse.ArgumentTypeError(f"expected a number, got {text!r}") from None
    if not math.isfinite(v):
        raise argparse.ArgumentTypeError(f"must be a finite number, got {text!r}")
    return v


def positive_float(text):
    """argparse type: a finite number > 0."""
    v = finite_float(text)
    if not v > 0:
        raise argparse.ArgumentTypeError(f"must be a number > 0, got {text!r}")
    return v


# ============================================================================ output paths

def check_output_folder(folder):
    """Make sure ``folder`` is a writable directory, creating it (and its parents) when it does not exist, as
    ``write_exr``/``write_png`` do; raise :class:`OutputPathError` when it cannot be."""
    folder = os.fspath(folder) or "."
    if not os.path.isdir(folder):
        if os.path.exists(folder):
            raise OutputPathError(f"output folder is not a folder: {folder}")
        try:
            os.makedirs(folder, exist_ok=True)
        except OSError as exc:
            raise OutputPathError(f"cannot create output folder {folder}: {exc.strerror or exc}") from None
    if not os.access(folder, os.W_OK | os.X_OK):
        raise OutputPathError(f"output folder is not writable: {folder}")


def check_outputs(paths, extensions=OUTPUT_EXTENSIONS):
    """Check output files before anything is rendered; raise :class:`OutputPathError` naming the first problem.

    Each path must end in one of ``extensions`` (any case), sit in a writable folder (created if missing), not be a
    folder itself, not be an existing read-only file, and no two paths may name the same file. Writability is
    tested by creating (and removing) the temporary file the write will use
    (:func:`pyrt.core.atomic.check_writable`: ``os.access`` says yes to root under ``/proc`` and ``/sys``), which
    also removes the temporaries a killed earlier run left beside the target.
    """
    seen = {}
    for p in paths:
        p = os.fspath(p)
        if not p.lower().endswith(tuple(extensions)):
            raise OutputPathError(f"output must end in {' or '.join(extensions)}: {p}")
        check_output_folder(os.path.dirname(p))
        if os.path.isdir(p):
            raise OutputPathError(f"output is a folder: {p}")
        if os.path.exists(p) and not os.access(p, os.W_OK):
            raise OutputPathError(f"output file is not writable: {p}")
        key = os.path.normcase(os.path.realpath(p))
        if key in seen:
            raise OutputPathError(f"the same output file is given twice: {seen[key]} and {p}")
        seen[key] = p
        try:
            check_writable(p)
        except ImageWriteError as exc:
            raise OutputPathError(str(exc)) from None


# ============================================================================ interrupts

@contextmanager
def interrupts(cancel, prog, what="the chunks in progress"):
    """SIGINT and SIGTERM while inside: the first sets ``cancel``, the second raises ``KeyboardInterrupt``.

    ``cancel`` is a :class:`threading.Event` the work polls; on the first signal a line
    ``PROG: stopping after WHAT (press Ctrl-C again to abort)`` goes to stderr. The previous handlers are
    restored on exit. Outside the main thread (where Python cannot install handlers) nothing is changed.
    """
    if threading.current_thread() is not threading.main_thread():
        yield cancel
        return

    def handler(signum, frame):
        if cancel.is_set():
            raise KeyboardInterrupt
        cancel.set()
        # os.write, not print: a signal handler may run in the middle of another write to sys.stderr
        os.write(2, f"\n{prog}: stopping after {what} (press Ctrl-C again to abort)\n".encode())

    previous = {s: signal.signal(s, handler) for s in (signal.SIGINT, signal.SIGTERM)}
    try:
        yield cancel
    finally:
        for s, h in previous.items():
            signal.signal(s, h)
