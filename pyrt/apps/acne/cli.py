"""``python -m pyrt.apps.acne``: run the matrix over offset strategies (and your own) and print the table."""
from __future__ import annotations

import importlib
import re
import sys
import traceback

from pyrt.core.errors import Error
from pyrt.geometry import offsets
from pyrt.apps.common import EXIT_ERROR, ArgumentParser
from pyrt.apps.acne.scenes import default_matrix, quick_matrix
from pyrt.apps.acne.measure import format_table, run_matrix

DESCRIPTION = "The shadow-acne suite: offset strategies against stress scenes with analytic ground truth."


class AcneArgumentError(Error, ValueError):
    """A ``pyrt-acne`` argument that names something that does not exist or cannot be used."""


def load_callable(spec):
    """The function named by ``"module:function"`` (``--offset``).

    Parameters
    ----------
    spec : str

    Returns
    -------
    callable

    Raises
    ------
    AcneArgumentError
        ``spec`` has no ``:``, its module cannot be imported, or has no such callable (the message names them).
    """
    mod, _, name = spec.partition(":")
    if not mod or not name:
        raise AcneArgumentError(f"--offset must be module:function, got {spec!r}")
    try:
        module = importlib.import_module(mod)
    except ImportError as exc:
        raise AcneArgumentError(f"--offset {spec}: cannot import module {mod!r} ({exc})") from None
    except Exception as exc:      # the user's module raised while importing: say so in one line
        raise AcneArgumentError(f"--offset {spec}: importing module {mod!r} failed: "
                                f"{type(exc).__name__}: {exc}") from None
    fn = getattr(module, name, None)
    if fn is None:
        raise AcneArgumentError(f"--offset {spec}: module {mod!r} has no function {name!r}")
    if not callable(fn):
        raise AcneArgumentError(f"--offset {spec}: {mod}.{name} is not a function (it is a {type(fn).__name__})")
    return fn


def _size(text):
    """``WxH`` -> (W, H), positive integers; AcneArgumentError otherwise."""
    m = re.fullmatch(r"\s*(\d+)\s*[xX]\s*(\d+)\s*", text)
    if m is None or int(m.group(1)) < 1 or int(m.group(2)) < 1:
        raise AcneArgumentError(f"--size must be WxH with positive integers (e.g. 64x48), got {text!r}")
    return int(m.group(1)), int(m.group(2))


def main(argv=None):
    """``python -m pyrt.apps.acne [--strategies a,b] [--offset mod:fn] [--quick] [--match S] [--size WxH]``.

    Parameters
    ----------
    argv : list of str, optional
        Arguments (default: ``sys.argv[1:]``).

    Returns
    -------
    int
        The exit status: 0, or 2 after a one-line ``pyrt-acne: error: ...`` (a module or function that cannot be
        loaded, a function returning the wrong shape or NaN, an unknown strategy, a bad ``--size``).
    """
    ap = ArgumentParser(prog="pyrt-acne", description=DESCRIPTION)
    ap.add_argument("--strategies", default=",".join(offsets.STRATEGIES),
                    help="comma-separated names from pyrt.geometry.offsets.STRATEGIES (default: all)")
    ap.add_argument("--offset", action="append", default=[],
                    help="module:function of your own offset f(surf, w) -> origins (repeatable); replaces "
                         "--strategies unless they are also given explicitly")
    ap.add_argument("--quick", action="store_true", help="base cases and sweep extremes only")
    ap.add_argument("--match", default="", help="only cases whose id contains this substring")
    ap.add_argument("--size", default="64x48", help="image size WxH (default 64x48)")
    ap.add_argument("--debug", action="store_true", help="show the traceback of an error")
    a = ap.parse_args(argv)
    try:
        return _run(a, argv)
    except (Error, ValueError, OSError) as exc:     # the user's function failing inside the render included
        if a.debug:
            traceback.print_exc()
        print(f"pyrt-acne: error: {exc}", file=sys.stderr)
        return EXIT_ERROR


def _run(a, argv):
    """:func:`main` after the arguments are parsed: check them, run the matrix, print the table."""
    wdt, hgt = _size(a.size)
    strategies = []
    explicit = any(arg.startswith("--strategies") for arg in (argv if argv is not None else sys.argv[1:]))
    if not a.offset or explicit:
        names = [s for s in a.strategies.split(",") if s]
        unknown = [n for n in names if n not in offsets.STRATEGIES]
        if unknown or not names:
            raise AcneArgumentError(f"--strategies: unknown strategy name(s) {unknown or [a.strategies]}; choose "
                                    f"from {', '.join(sorted(offsets.STRATEGIES))}")
        strategies += names
    strategies += [load_callable(s) for s in a.offset]
    cases = quick_matrix() if a.quick else default_matrix()
    cases = [c for c in cases if a.match in c.id]
    if not cases:
        raise AcneArgumentError(f"--match {a.match!r}: no case id contains it")
    res = run_matrix(cases=cases, strategies=strategies, width=wdt, height=hgt, progress=sys.stderr.isatty())
    print(format_table(res))
    return 0
