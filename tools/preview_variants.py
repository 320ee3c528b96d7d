"""Time and error of previewer settings side by side: the same models rendered with option overrides.

Each ``--variant NAME:FIELD=VALUE,FIELD=VALUE`` is a :class:`pyrt.apps.preview.PreviewOptions` with those fields
changed from the defaults (the first variant is usually ``default:``, no change). Every model is rendered
``--rounds`` times per variant, interleaved (the order rotates each round), in one process; the render phase's
median and the runs are printed. With ``--ref FIELD=VALUE,...`` a reference is rendered once (e.g. ``spp=64``)
and each variant's relMSE against it (:func:`pyrt.core.metrics.relmse`, all pixels), its mean against the
reference's and relMSE x time (the cost of a given error, lower is better) are printed. The reference and the
variants share the exposure-free linear image, so only the estimate is compared.

    python tools/preview_variants.py MODEL [MODEL ...] --variant default: --variant gd1:glossy_depth=1 \\
        --ref spp=64 --rounds 3

Timings are wall-clock seconds of the render phase on this machine: run it idle, or read the ratios.
"""
from __future__ import annotations

import argparse
import ast
import os
import statistics

import numpy as np

from pyrt.apps.preview import PreviewOptions, render_preview
from pyrt.core.metrics import relmse


def parse_fields(text):
    """``"a=1,b=x"`` -> ``{"a": 1, "b": "x"}`` (values parsed as Python literals where they are ones)."""
    out = {}
    for item in filter(None, (t.strip() for t in text.split(","))):
        key, _, val = item.partition("=")
        try:
            out[key.strip()] = ast.literal_eval(val.strip())
        except (ValueError, SyntaxError):
            out[key.strip()] = val.strip()
    return out


def parse_variant(text):
    """``"NAME:a=1,b=2"`` -> ``(NAME, {...})``."""
    name, _, fields = text.partition(":")
    return name, parse_fields(fields)


def render(path, fields):
    """The preview's linear image (float64) and render-phase seconds with ``fields`` set on the default options."""
    r = render_preview(path, PreviewOptions(**fields))
    return np.asarray(r.images[0], dtype=np.float64), r.render_time


def main(argv=None):
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("models", nargs="+")
    ap.add_argument("--variant", action="append", required=True, help="NAME:FIELD=VALUE,... (repeatable)")
    ap.add_argument("--ref", help="reference overrides, e.g. spp=64 (relMSE is printed against it)")
    ap.add_argument("--rounds", type=int, default=3)
    ap.add_argument("--common", default="", help="overrides applied to every variant and the reference")
    args = ap.parse_args(argv)
    variants = [parse_variant(v) for v in args.variant]
    common = parse_fields(args.common)
    print(f"load {os.getloadavg()[0]:.2f}; {args.rounds} interleaved rounds; common {common}", flush=True)
    for path in args.models:
        model = os.path.basename(path)
        ref = None
        if args.ref:
            ref, t_ref = render(path, {**common, **parse_fields(args.ref)})
            print(f"{model}: reference {args.ref} rendered in {t_ref:.1f} s, mean {ref.mean():.5f}", flush=True)
        times = {name: [] for name, _ in variants}
        images = {}
        for rnd in range(args.rounds):
            order = variants[rnd % len(variants):] + variants[:rnd % len(variants)]
            for name, fields in order:
                img, t = render(path, {**common, **fields})
                times[name].append(t)
                images.setdefault(name, img)
        base = statistics.median(times[variants[0][0]])
        for name, fields in variants:
            med = statistics.median(times[name])
            line = (f"{model:28s} {name:12s} render median {med:6.2f} s (x{med / base:.3f})  runs "
                    f"{[round(x, 2) for x in times[name]]}")
            if ref is not None:
                e = relmse(images[name], ref)
                line += f"  relMSE {e:.3e}  mean {images[name].mean():.5f}  relMSE*t {e * med:.3e}"
            print(line, flush=True)


if __name__ == "__main__":
    main()
