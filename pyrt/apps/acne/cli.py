"""``python -m pyrt.apps.acne``: run the matrix over offset strategies (and your own) and print the table."""
from __future__ import annotations

import importlib
import sys

from pyrt.geometry import offsets
from pyrt.apps.common import ArgumentParser
from pyrt.apps.acne.scenes import default_matrix, quick_matrix
from pyrt.apps.acne.measure import format_table, run_matrix

DESCRIPTION = "The shadow-acne suite: offset strategies against stress scenes with analytic ground truth."


def load_callable(spec):
    """The function named by ``"module:function"`` (``--offset``); SystemExit if ``spec`` has no ``:``.

    Parameters
    ----------
    spec : str

    Returns
    -------
    callable
    """
    mod, _, name = spec.partition(":")
    if not name:
        raise SystemExit(f"--offset must be module:function, got {spec!r}")
    return getattr(importlib.import_module(mod), name)


def main(argv=None):
    """``python -m pyrt.apps.acne [--strategies a,b] [--offset mod:fn] [--quick] [--match S] [--size WxH]``.

    Parameters
    ----------
    argv : list of str, optional
        Arguments (default: ``sys.argv[1:]``).

    Returns
    -------
    int
        The exit status (0).
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
    a = ap.parse_args(argv)
    wdt, hgt = (int(x) for x in a.size.lower().split("x"))
    cases = quick_matrix() if a.quick else default_matrix()
    cases = [c for c in cases if a.match in c.id]
    strategies = []
    explicit = any(arg.startswith("--strategies") for arg in (argv if argv is not None else sys.argv[1:]))
    if not a.offset or explicit:
        strategies += [s for s in a.strategies.split(",") if s]
    strategies += [load_callable(s) for s in a.offset]
    res = run_matrix(cases=cases, strategies=strategies, width=wdt, height=hgt, progress=sys.stderr.isatty())
    print(format_table(res))
    return 0
