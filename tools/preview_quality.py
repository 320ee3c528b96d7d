"""The previewer's quality and time per model: each setting's true relMSE against a high-spp reference.

For every model (the glTF / GLB files under a folder such as ``../shared/khronos-gltf``, one per sub-folder, or
model paths) the default view is rendered by :func:`pyrt.apps.preview.render_preview` with each ``--variant``'s
option overrides, and compared with a reference of the same view and options at ``--ref-spp`` samples per pixel.
The reference is the mean of two renders with different seeds, ``r1`` and ``r2``; what its own noise adds to a
variant's measured relMSE is taken off:

    true relMSE(I) ~= relMSE(I, (r1 + r2) / 2) - relMSE(r1, r2) / 4

(``relMSE(r1, r2)`` estimates twice a reference render's error, the mean of two has half of it; both terms are
divided by ``R^2 + eps`` of the mean reference ``R``, :func:`pyrt.core.metrics.relmse`'s ``eps``, so that a firefly
in one reference weighs the same in both). The references are kept in ``--cache`` (an ``.npz``
per model, seed, spp and option set) so that other variants can be measured later against the same ones.

Per model and variant the table gives: the render path, the samples per pixel reached (the mean over the pixels),
the previewer's own error estimate (adaptive renders), the true relMSE over the whole image and over the pixels that see the model
(:meth:`pyrt.apps.preview.render.PreviewScene.model_mask`: where grain shows; the ground and backdrop are smooth and
make most of a whole image), the render phase's seconds (the median of
``--rounds`` interleaved runs) and the whole preview's seconds (``render_preview``: load, preparation, kernel, render
and encoding; not the interpreter's start and imports, which ``pyrt-preview`` adds once per process). Timings are
wall-clock on this machine: run it idle, and read the load printed with the table.

    python tools/preview_quality.py ../shared/khronos-gltf --variant fixed4:spp=4 \\
        --variant q:target_error=1e-3,max_spp=64 --ref-spp 256 --markdown docs/preview_quality.md
"""
from __future__ import annotations

import argparse
import glob
import hashlib
import json
import os
import statistics
import sys
import time

import numpy as np

from pyrt.apps.preview import PreviewOptions, render_preview
from pyrt.apps.preview.render import PreviewScene
from pyrt.io.assets import load_asset
from pyrt.core.metrics import RELMSE_EPS

#: the two reference seeds (the variants render with the options' own seed, 0 by default)
REF_SEEDS = (1001, 1002)


def parse_fields(text):
    """``"a=1,b=x"`` -> ``{"a": 1, "b": "x"}`` (values parsed as JSON where they are JSON: numbers, null, true)."""
    out = {}
    for item in filter(None, (t.strip() for t in text.split(","))):
        key, _, val = item.partition("=")
        val = val.strip()
        try:
            out[key.strip()] = json.loads(val)
        except ValueError:
            out[key.strip()] = val
    return out


def parse_variant(text):
    """``"NAME:a=1,b=2"`` -> ``(NAME, {...})``."""
    name, _, fields = text.partition(":")
    return name, parse_fields(fields)


def model_files(paths):
    """The model files named by ``paths``: a file as it is; a folder's sub-folders' first ``.gltf`` / ``.glb`` each
    (searched recursively, ``.gltf`` first), in name order."""
    out = []
    for p in paths:
        if os.path.isfile(p):
            out.append(p)
            continue
        for d in sorted(glob.glob(os.path.join(p, "*", ""))):
            found = (sorted(glob.glob(os.path.join(d, "**", "*.gltf"), recursive=True))
                     + sorted(glob.glob(os.path.join(d, "**", "*.glb"), recursive=True)))
            if found:
                out.append(found[0])
    return out


def model_name(path):
    """The model's folder name under the collection (``.../Avocado/glTF/Avocado.gltf`` -> ``Avocado``)."""
    parts = os.path.normpath(path).split(os.sep)
    return parts[-3] if len(parts) > 2 and parts[-2] == "glTF" else os.path.splitext(parts[-1])[0]


def render(path, fields):
    """One preview: its linear image (float64), result and the whole call's seconds."""
    t0 = time.perf_counter()
    r = render_preview(path, PreviewOptions(**fields))
    return np.asarray(r.images[0], dtype=np.float64), r, time.perf_counter() - t0


def reference(path, fields, spp, cache):
    """The two reference images of ``path`` (``fields`` with ``spp`` and the reference seeds), from ``cache`` when
    there, else rendered and stored."""
    images = []
    for seed in REF_SEEDS:
        opts = {**fields, "spp": spp, "seed": seed, "target_error": None, "max_spp": None}
        key = hashlib.sha1(json.dumps([os.path.abspath(path), opts], sort_keys=True).encode()).hexdigest()[:16]
        file = os.path.join(cache, f"{model_name(path)}-{spp}spp-{seed}-{key}.npz")
        if os.path.exists(file):
            images.append(np.load(file)["image"])
            continue
        img, _, t = render(path, opts)
        print(f"  reference {model_name(path)} seed {seed}: {spp} spp in {t:.1f} s", flush=True)
        os.makedirs(cache, exist_ok=True)
        np.savez_compressed(file, image=img)
        images.append(img)
    return images


def model_mask(path, fields):
    """(H, W) bool: the pixels whose centre ray sees the model in the default view
    (:meth:`pyrt.apps.preview.render.PreviewScene.model_mask`)."""
    o = PreviewOptions(**fields).validate()
    ps = PreviewScene(load_asset(path, max_texture=o.texture_budget(), root=o.root), o)
    try:
        return ps.model_mask(ps.camera(ps.azimuth))
    finally:
        ps.close()


def _terms(image, refs, mask):
    """Per pixel and channel: ``image``'s squared error against the references' mean and the references' noise term,
    both over ``R^2 + eps``."""
    r1, r2, im = refs[0], refs[1], image
    if mask is not None:
        r1, r2, im = r1[mask], r2[mask], im[mask]
    ref = 0.5 * (r1 + r2)
    den = ref * ref + RELMSE_EPS
    return (im - ref) ** 2 / den, 0.25 * (r1 - r2) ** 2 / den


def true_error(image, refs, mask=None):
    """``image``'s relMSE against the mean ``R`` of the two references, less what their noise adds (module
    docstring), both divided by ``R^2 + eps``; over the pixels of ``mask`` when given."""
    err, noise = _terms(image, refs, mask)
    return float(np.mean(err) - np.mean(noise))


def reference_error(refs, mask=None):
    """The relMSE the mean of the two references has itself (what :func:`true_error` takes off)."""
    return float(np.mean(_terms(refs[0], refs, mask)[1]))


def measure(path, variants, common, ref_spp, rounds, cache):
    """Per variant: path taken, spp reached, estimated error, true error, median render and whole seconds."""
    refs = reference(path, common, ref_spp, cache)
    mask = model_mask(path, common)
    runs = {name: [] for name, _ in variants}
    for rnd in range(rounds):
        k = rnd % len(variants)
        for name, fields in variants[k:] + variants[:k]:
            img, res, whole = render(path, {**common, **fields})
            runs[name].append((img, res, whole))
    rows = []
    for name, _ in variants:
        img, res, _ = runs[name][0]
        rows.append(dict(
            model=model_name(path), variant=name, path="/".join(sorted(set(res.backends))), spp=res.mean_spp,
            estimated=res.worst_error, true=true_error(img, refs), ref_noise=reference_error(refs),
            model_true=true_error(img, refs, mask) if mask.any() else float("nan"),
            render=statistics.median(r.render_time for _, r, _ in runs[name]),
            whole=statistics.median(w for _, _, w in runs[name])))
    return rows


def table(rows, header):
    """The rows as a Markdown table under ``header`` lines."""
    out = list(header) + ["", "| model | variant | path | spp | estimated relMSE | true relMSE | on the model | render s "
                          "| preview s |", "|---|---|---|---:|---:|---:|---:|---:|---:|"]
    for r in rows:
        est = "—" if r["estimated"] is None else f"{r['estimated']:.2e}"
        out.append(f"| {r['model']} | {r['variant']} | {r['path']} | {r['spp']:.3g} | {est} | {r['true']:.2e} | "
                   f"{r['model_true']:.2e} | {r['render']:.2f} | {r['whole']:.2f} |")
    return "\n".join(out) + "\n"


def main(argv=None):
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("models", nargs="+", help="model files, or folders of model folders")
    ap.add_argument("--variant", action="append", required=True, help="NAME:FIELD=VALUE,... (repeatable)")
    ap.add_argument("--common", default="", help="overrides for every variant and the reference")
    ap.add_argument("--ref-spp", type=int, default=256)
    ap.add_argument("--rounds", type=int, default=1)
    ap.add_argument("--only", default="", help="comma-separated model names to keep")
    ap.add_argument("--cache", default=os.path.join(os.path.expanduser("~"), ".cache", "pyrt", "preview-refs"))
    ap.add_argument("--markdown", help="write the table here")
    ap.add_argument("--append", action="store_true", help="add the table to the --markdown file instead")
    args = ap.parse_args(argv)
    variants = [parse_variant(v) for v in args.variant]
    common = parse_fields(args.common)
    keep = set(filter(None, args.only.split(",")))
    files = [f for f in model_files(args.models) if not keep or model_name(f) in keep]
    load0 = os.getloadavg()[0]
    rows = []
    for f in files:
        for r in measure(f, variants, common, args.ref_spp, args.rounds, args.cache):
            rows.append(r)
            est = "-" if r["estimated"] is None else f"{r['estimated']:.2e}"
            print(f"{r['model']:26s} {r['variant']:10s} {r['path']:8s} spp {r['spp']:6.3g}  est {est:>8s}  "
                  f"true {r['true']:.2e} model {r['model_true']:.2e} (ref {r['ref_noise']:.1e})  "
                  f"render {r['render']:.2f} s  "
                  f"preview {r['whole']:.2f} s", flush=True)
    header = ["", f"`python tools/preview_quality.py {' '.join(argv if argv is not None else sys.argv[1:])}`", "",
              f"{os.cpu_count()} cores; reference: {args.ref_spp} spp x {len(REF_SEEDS)} seeds; variants: "
              + "; ".join(f"`{n}` {f or 'defaults'}" for n, f in variants)
              + (f"; common {common}" if common else "") + f"; {args.rounds} round(s); load "
              f"{load0:.2f} -> {os.getloadavg()[0]:.2f}."]
    text = table(rows, header)
    print(text)
    if args.markdown:
        with open(args.markdown, "a" if args.append else "w") as fh:
            fh.write(text)


if __name__ == "__main__":
    main()
