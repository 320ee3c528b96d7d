"""Batches: expand folders and globs, preview every asset (locally or one Dask task per asset) and
write the summary table."""
from __future__ import annotations

import csv
from dataclasses import dataclass, field
import glob
import io
import os
import time
import traceback

from pyrt.core.image_io import write_bytes
from pyrt.io.assets import FORMATS, AssetError
from pyrt.apps.preview.options import BudgetExceeded, PreviewError, PreviewInterrupted, PreviewOptions
from pyrt.apps.preview.render import PHASES, PREPARE_PHASES, format_phases, render_preview, write_files


# ============================================================================ batches

@dataclass
class AssetReport:
    """One line of the batch summary."""

    path: str
    name: str
    status: str = "ok"                  # "ok" | "failed" | "timeout" | "interrupted" | "skipped" (not started)
    triangles: int = 0
    load_time: float = 0.0
    render_time: float = 0.0
    warnings: list = field(default_factory=list)
    error: str = ""
    outputs: list = field(default_factory=list)
    exposure: float | None = None
    files: dict | None = None           # encoded outputs (Dask mode, before the client writes them)
    #: seconds per phase (:data:`pyrt.apps.preview.render.PHASES`: load, decode, frame, ..., render, encode, write)
    phases: dict = field(default_factory=dict)
    #: what the loader replaced to render the model anyway (a missing texture, MTL, ...): also in ``warnings``
    substitutions: list = field(default_factory=list)
    #: camera samples per pixel reached (the mean over the views; adaptive renders vary it per pixel)
    spp: float = 0.0
    #: adaptive renders: the largest estimated relMSE of a view (:attr:`pyrt.RenderResult.estimated_error`); None at a
    #: fixed spp
    estimated_error: float | None = None
    #: the views' render path (:attr:`pyrt.apps.preview.render.PreviewResult.backend`): ``"compiled"``, ``"numpy"``
    #: (some view took the NumPy path) or "" (nothing rendered)
    backend: str = ""
    #: adaptive renders: why the passes stopped (:attr:`pyrt.apps.preview.render.PreviewResult.stop_reason`:
    #: ``"target_error"``, ``"time_budget"``, ``"max_spp"``, ``"cancelled"``); None at a fixed spp
    stop_reason: str | None = None

    @property
    def prepare_time(self):
        """Seconds between loading and rendering: the sum of the :data:`pyrt.apps.preview.render.PREPARE_PHASES` (up
        axis and bounds, normals, tangents, scene, emitters, geometry tables, BVH, MIP pyramids, irradiance grid,
        compiled tables and kernel load, the exposure's model mask)."""
        return float(sum(self.phases.get(k, 0.0) for k in PREPARE_PHASES))


def output_name(path, taken=None):
    """Output stem for a model path: ``duck.glb`` -> ``duck_glb`` (``_2``, ... if already ``taken``)."""
    base = os.path.basename(path).replace(".", "_")
    name, k = base, 2
    while taken is not None and name in taken:
        name, k = f"{base}_{k}", k + 1
    if taken is not None:
        taken.add(name)
    return name


def preview_asset(path, out_dir=None, options=None, *, name=None, return_files=False, cancel=None):
    """Preview one model for a batch; never raises. Writes under ``out_dir`` unless ``return_files``.

    Returns an :class:`AssetReport`; a failing asset has ``status="failed"`` and the error message,
    a budget overrun ``status="timeout"``, a turntable cancelled between views (``cancel`` set)
    ``status="interrupted"`` (no files written for it).
    """
    o = options or PreviewOptions()
    name = name or output_name(path)
    rep = AssetReport(path=os.fspath(path), name=name)
    t0 = time.perf_counter()
    deadline = t0 + o.time_budget if o.time_budget else None
    try:
        res = render_preview(path, o, name=name, deadline=deadline, cancel=cancel)
    except PreviewInterrupted as exc:
        rep.status, rep.error = "interrupted", str(exc)
        return rep
    except BudgetExceeded as exc:
        rep.status, rep.error = "timeout", str(exc)
        rep.load_time = time.perf_counter() - t0
        return rep
    except (AssetError, PreviewError, ValueError, OSError) as exc:
        rep.status, rep.error = "failed", f"{type(exc).__name__}: {exc}"
        return rep
    except Exception as exc:  # a bug or an unexpected library error: report it, keep the batch going
        tb = traceback.extract_tb(exc.__traceback__)[-1]
        rep.status = "failed"
        rep.error = f"{type(exc).__name__}: {exc} (at {os.path.basename(tb.filename)}:{tb.lineno})"
        return rep
    rep.triangles, rep.load_time, rep.render_time = res.triangles, res.load_time, res.render_time
    rep.warnings, rep.exposure = list(dict.fromkeys(res.warnings)), res.exposure
    rep.phases, rep.substitutions = dict(res.phases), list(res.substitutions)
    rep.spp, rep.estimated_error = res.mean_spp, res.worst_error
    rep.backend, rep.stop_reason = res.backend, res.stop_reason
    if return_files:
        rep.files = res.files
        rep.outputs = sorted(res.files)
    else:
        t_write = time.perf_counter()
        rep.outputs = write_files(res.files, out_dir or ".")
        rep.phases["write"] = time.perf_counter() - t_write
    return rep


def collect_inputs(specs):
    """Expand files, folders and glob patterns into model paths. A folder is searched recursively (a folder of model
    folders, as the Khronos samples come: ``Duck/glTF-Binary/Duck.glb``) for the files of the supported formats, in
    sorted order, skipping hidden folders (``.git``)."""
    out = []
    for s in specs:
        s = os.fspath(s)
        if os.path.isdir(s):
            found = []
            for top, dirs, files in os.walk(s):
                dirs[:] = sorted(d for d in dirs if not d.startswith("."))
                found += [os.path.join(top, f) for f in files if os.path.splitext(f)[1].lower() in FORMATS]
            out += sorted(found)
        elif any(ch in s for ch in "*?["):
            out += sorted(p for p in glob.glob(s, recursive=True) if os.path.isfile(p))
        else:
            out.append(s)
    return list(dict.fromkeys(out))


def preview_batch(inputs, out_dir, options=None, *, dask=None, n_workers=2, processes=False, progress=True,
                  cancel=None):
    """Preview every model of ``inputs`` (files, folders, globs) into ``out_dir``.

    Parameters
    ----------
    dask : None, True, str or distributed.Client
        None: render here, one asset after another. True: a ``distributed.LocalCluster`` with
        ``n_workers`` single-threaded workers (``processes`` as given). A string: the address of an
        existing scheduler. A Client: use it. Each asset is one task.
    progress : bool
        A tqdm progress bar over the assets.
    cancel : threading.Event, optional
        Once set, the asset (locally: the view) in progress finishes and no new one starts; the assets
        not started are reported ``skipped`` and the summary is written as usual.

    Returns
    -------
    list of AssetReport, in input order. The summary table is also written to
    ``out_dir/summary.csv`` and ``out_dir/summary.txt``.

    Raises
    ------
    PreviewError
        Invalid options, or ``dask`` asked for while dask/distributed are not installed (before
        anything is rendered or written).
    """
    from tqdm.auto import tqdm

    o = (options or PreviewOptions()).validate()
    use_dask = not (dask is None or dask is False)
    dist = _distributed() if use_dask else None
    paths = collect_inputs(inputs)
    taken = set()
    names = [output_name(p, taken) for p in paths]
    os.makedirs(out_dir, exist_ok=True)
    if not use_dask:
        reports = []
        for p, nm in tqdm(list(zip(paths, names)), desc="preview", unit="asset", disable=not progress):
            if cancel is not None and cancel.is_set():
                reports.append(_skipped(p, nm))
            else:
                reports.append(preview_asset(p, out_dir, o, name=nm, cancel=cancel))
    else:
        reports = _batch_dask(dist, paths, names, out_dir, o, dask, n_workers, processes, progress, cancel)
    write_summary(reports, out_dir)
    return reports


def _skipped(path, name):
    return AssetReport(path=os.fspath(path), name=name, status="skipped", error="not started: interrupted")


def _distributed():
    """The ``distributed`` module (Dask's scheduler client), or a :class:`PreviewError` saying how to get it."""
    try:
        import distributed
    except ImportError as exc:
        raise PreviewError(f"running a batch on Dask needs the packages dask and distributed ({exc}): "
                           "pip install 'pyrt-embree[preview]' (the 'preview' extra)") from None
    return distributed


def _batch_dask(dist, paths, names, out_dir, o, dask, n_workers, processes, progress, cancel):
    from tqdm.auto import tqdm

    Client, LocalCluster, as_completed = dist.Client, dist.LocalCluster, dist.as_completed

    cluster = client = None
    own = True
    if isinstance(dask, Client):
        client, own = dask, False
    elif dask is True:
        cluster = LocalCluster(n_workers=n_workers, threads_per_worker=1, processes=processes,
                               dashboard_address=None)
        client = Client(cluster)
    else:
        client = Client(str(dask))
    try:
        futures = [client.submit(preview_asset, os.path.abspath(p), None, o, name=nm, return_files=True,
                                 key=f"pyrt-preview-{k}-{nm}", pure=False)
                   for k, (p, nm) in enumerate(zip(paths, names))]
        index = {f.key: k for k, f in enumerate(futures)}
        reports = [None] * len(futures)
        for fut in tqdm(as_completed(futures), total=len(futures), desc="preview (dask)", unit="asset",
                        disable=not progress):
            k = index[fut.key]
            try:
                rep = fut.result()
            except Exception as exc:  # the task itself died (worker lost, ...)
                rep = AssetReport(path=paths[k], name=names[k], status="failed",
                                  error=f"task failed: {type(exc).__name__}: {exc}")
            if rep.files is not None:
                t_write = time.perf_counter()
                rep.outputs = write_files(rep.files, out_dir)
                rep.phases["write"] = time.perf_counter() - t_write
                rep.files = None
            rep.path = paths[k]
            reports[k] = rep
            if cancel is not None and cancel.is_set():
                break
        pending = [f for k, f in enumerate(futures) if reports[k] is None]
        if pending:
            client.cancel(pending)
        return [r if r is not None else _skipped(paths[k], names[k]) for k, r in enumerate(reports)]
    finally:
        if own:
            client.close()
            if cluster is not None:
                cluster.close()


def summary_rows(reports):
    """The summary table as rows of strings (header first); "prepare s" is :attr:`AssetReport.prepare_time`, "spp"
    the samples per pixel reached, "rel. err." the estimated relMSE of an adaptive render ("-" at a fixed spp),
    "subst." the number of substitutions (listed under the table by :func:`format_summary`)."""
    rows = [["asset", "status", "triangles", "load s", "prepare s", "render s", "spp", "rel. err.", "warnings",
             "subst.", "message"]]
    for r in reports:
        msg = r.error or (r.warnings[0] if r.warnings else "")
        rows.append([os.path.basename(r.path), r.status, str(r.triangles), f"{r.load_time:.2f}",
                     f"{r.prepare_time:.2f}", f"{r.render_time:.2f}", f"{r.spp:.3g}" if r.spp else "-",
                     "-" if r.estimated_error is None else f"{r.estimated_error:.2g}", str(len(r.warnings)),
                     str(len(r.substitutions)), msg])
    return rows


def format_summary(reports):
    """A text table of :func:`summary_rows`, columns aligned, the message column (last) whole."""
    rows = summary_rows(reports)
    w = [max(len(r[i]) for r in rows) for i in range(len(rows[0]))]
    last = len(rows[0]) - 1
    lines = ["  ".join(c.ljust(w[i]) if i in (0, 1, last) else c.rjust(w[i]) for i, c in enumerate(r)) for r in rows]
    lines.insert(1, "  ".join("-" * x for x in w))
    ok = sum(r.status == "ok" for r in reports)
    lines.append(f"{ok}/{len(reports)} assets ok")
    timed = [r for r in reports if r.phases]
    if timed:
        lines += ["", "phases (s):"] + [f"  {os.path.basename(r.path)}: {format_phases(r.phases)}" for r in timed]
    subst = [r for r in reports if r.substitutions]
    if subst:
        lines += ["", "substitutions (what was replaced to render the model anyway):"]
        for r in subst:
            lines += [f"  {os.path.basename(r.path)}:"] + [f"    - {m}" for m in r.substitutions]
    return "\n".join(lines)


def write_summary(reports, out_dir):
    """Write ``out_dir/summary.csv`` (one row per asset) and ``summary.txt`` (:func:`format_summary`), atomically."""
    buf = io.StringIO(newline="")
    wr = csv.writer(buf)
    wr.writerow(["asset", "status", "triangles", "load_s", "render_s", "n_warnings", "error", "warnings",
                 "prepare_s", *(f"{k}_s" for k in PHASES), "substitutions", "spp", "estimated_relmse"])
    for r in reports:
        wr.writerow([r.path, r.status, r.triangles, f"{r.load_time:.4f}", f"{r.render_time:.4f}",
                     len(r.warnings), r.error, " | ".join(r.warnings), f"{r.prepare_time:.4f}",
                     *(f"{r.phases[k]:.4f}" if k in r.phases else "" for k in PHASES), " | ".join(r.substitutions),
                     f"{r.spp:.4g}", "" if r.estimated_error is None else f"{r.estimated_error:.4g}"])
    write_bytes(os.path.join(out_dir, "summary.csv"), buf.getvalue())
    write_bytes(os.path.join(out_dir, "summary.txt"), format_summary(reports) + "\n")
