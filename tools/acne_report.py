"""Shadow-acne report: every offset strategy over the acne matrix, a chart, and worst-case images.

Writes to ``--out`` (default ``out/acne``):

- ``table.txt``   the matrix (case x strategy: acne/leak pixels) and per-strategy totals (``python -m pyrt.apps.acne``);
- ``results.csv`` one row per (case, strategy): acne, leak, labelled and don't-care pixels, shadow rays, time;
- ``summary.md``  per strategy: failing cases, acne, leak, error rate, cost (a Markdown table for the README);
- ``chart.png``   error rate ((acne + leak) / labelled pixels over the whole matrix) against cost
                  (microseconds per shadow ray, measured on larger images: origins + tmax + Embree);
- ``worst.png``   for each naive strategy, its worst case rendered next to the default strategy, with the
                  acne (red) and leak (yellow) pixels marked and the don't-care band in grey.

``--docs DIR`` also copies the chart and the worst-case figure there (small PNGs for the README);
``--write-known FILE`` records the failing cases per strategy (tests/acne_known_failures.json, used by
the slow test that checks every strategy's known failures, strictly).

Usage: ``python tools/acne_report.py [--quick] [--size 64x48] [--offset mymodule:myfn]``.
"""
from __future__ import annotations

import argparse
import csv
import json
import shutil
import sys
import time
from pathlib import Path

import numpy as np

sys.path.insert(0, str(Path(__file__).resolve().parents[1]))

import pyrt  # noqa: E402
from pyrt.apps import acne  # noqa: E402
from pyrt.geometry import offsets  # noqa: E402
from _charts import pyplot  # noqa: E402  (tools/_charts.py)

NAIVE = ("none", "ray_epsilon", "normal_epsilon", "scaled_epsilon", "wachter_binder_rtg", "error_bound")
TIMING_CASES = (acne.Case("plane", "point"), acne.Case("sphere_lowpoly", "point"), acne.Case("contact", "point"),
                acne.Case("glass", "directional"))


def _size(text):
    w, h = (int(x) for x in text.lower().split("x"))
    return w, h


def measure_cost(strategies, size, repeats=3):
    """Microseconds per shadow ray per strategy on TIMING_CASES at ``size`` (best of ``repeats``)."""
    w, h = size
    cost = {}
    for case in TIMING_CASES:
        built = acne.build_case(case, w, h)
        truth = acne.truth_labels(built)
        ps = pyrt.PreparedScene(built.scene)
        try:
            for st in strategies:
                best = None
                for _ in range(repeats):
                    r = acne.run_case(case, st, built=built, prepared=ps, truth=truth)
                    if best is None or r.time_shadow < best[0]:
                        best = (r.time_shadow, r.shadow_rays)
                t, n = cost.get(acne.strategy_name(st), (0.0, 0))
                cost[acne.strategy_name(st)] = (t + best[0], n + best[1])
        finally:
            ps.close()
    return {k: 1e6 * t / max(n, 1) for k, (t, n) in cost.items()}


def write_csv(path, results):
    with open(path, "w", newline="") as f:
        wr = csv.writer(f)
        wr.writerow(["case", "geometry", "light", "scale", "translation", "incidence", "strategy", "acne", "leak",
                     "lit_pixels", "shadow_pixels", "dontcare_pixels", "shadow_rays", "us_per_shadow_ray"])
        for r in results:
            c = r.case
            wr.writerow([c.id, c.geometry, c.light, c.scale, c.translation, c.incidence, r.strategy, r.acne, r.leak,
                         r.n_lit, r.n_shadow, r.n_dontcare, r.shadow_rays, f"{r.us_per_shadow_ray:.4f}"])


def summary_markdown(results, cost):
    summ = acne.summarize(results)
    lines = ["| strategy | failing cases | acne px | leak px | (acne+leak) / labelled | us per shadow ray |",
             "|---|---:|---:|---:|---:|---:|"]
    for s, v in summ.items():
        mark = " (default)" if s == offsets.DEFAULT else ""
        lines.append(f"| `{s}`{mark} | {v['failing']} / {v['cases']} | {v['acne']} | {v['leak']} | "
                     f"{100 * v['rate']:.3f} % | {cost.get(s, float('nan')):.2f} |")
    return "\n".join(lines) + "\n"


def draw_chart(path, results, cost):
    plt = pyplot()
    summ = acne.summarize(results)
    floor = 1e-4   # 0 errors are drawn on this line (log axis)
    fig, ax = plt.subplots(figsize=(6.4, 4.0), dpi=100)
    for i, (s, v) in enumerate(sorted(summ.items(), key=lambda kv: -kv[1]["rate"])):
        x = cost.get(s, np.nan)
        y = max(100 * v["rate"], floor)
        default = s == offsets.DEFAULT
        ax.scatter([x], [y], s=70 if default else 40, c="tab:green" if default else "tab:red" if v["leak"] == 0
                   else "tab:orange", edgecolors="black", zorder=3)
        ax.annotate(f"{s} ({v['failing']}/{v['cases']})", (x, y), textcoords="offset points",
                    xytext=(7, 5 if i % 2 == 0 else -11), fontsize=7)
    ax.scatter([], [], c="tab:red", edgecolors="black", label="acne only")
    ax.scatter([], [], c="tab:orange", edgecolors="black", label="acne and leaks")
    ax.scatter([], [], c="tab:green", edgecolors="black", label="default: neither")
    ax.legend(fontsize=7, loc="center right")
    ax.axhline(floor, color="grey", lw=0.8, ls=":")
    ax.text(ax.get_xlim()[0], floor * 1.3, " 0 errors", fontsize=7, color="grey")
    ax.set_yscale("log")
    ax.set_xlabel("cost: microseconds per shadow ray (origin + tmax + Embree occlusion)")
    ax.set_ylabel("(acne + leak) pixels / labelled pixels  [%]")
    ax.set_title(f"Offset strategies over {len({r.case for r in results})} stress cases "
                 "(in brackets: failing cases)", fontsize=9)
    ax.grid(True, which="both", alpha=0.3)
    fig.tight_layout()
    fig.savefig(path)
    plt.close(fig)


def _display(img):
    lum = img.max(axis=2)
    pos = lum[lum > 0]
    scale = np.percentile(pos, 99) / 0.8 if pos.size else 1.0
    return np.clip(img / max(scale, 1e-30), 0, 1) ** (1 / 2.2)


def _overlay(r):
    """Grey image of the render with acne red, leak yellow, don't-care dark grey."""
    base = 0.35 + 0.5 * _display(r.image).mean(axis=2, keepdims=True).repeat(3, axis=2)
    out = base.copy()
    out[r.truth == acne.UNSURE] = (0.25, 0.25, 0.25)
    out[(r.truth == acne.LIT) & ~r.lit] = (1.0, 0.0, 0.0)
    out[(r.truth == acne.SHADOW) & r.lit] = (1.0, 0.9, 0.0)
    return out


def draw_worst(path, results, size, naive=NAIVE):
    plt = pyplot()
    w, h = size
    rows = []
    shown = set()
    for s in naive:
        # the worst case of this strategy among geometries not shown yet (one figure, many failure modes)
        mine = [r for r in results if r.strategy == s and not r.ok]
        fresh = [r for r in mine if r.case.geometry not in shown] or mine
        if not fresh:
            continue
        worst = max(fresh, key=lambda r: (r.acne + r.leak) / max(r.n_lit + r.n_shadow, 1))
        shown.add(worst.case.geometry)
        bad = acne.run_case(worst.case, s, width=w, height=h)
        good = acne.run_case(worst.case, offsets.DEFAULT, width=w, height=h)
        rows.append((s, worst.case, bad, good))
    fig, axes = plt.subplots(len(rows), 3, figsize=(7.2, 1.95 * len(rows)), dpi=100, squeeze=False)
    for i, (s, case, bad, good) in enumerate(rows):
        for j, (img, title) in enumerate(((_display(bad.image), f"{s}: {bad.acne} acne, {bad.leak} leak px"),
                                         (_overlay(bad), "errors (red acne, yellow leak)"),
                                         (_display(good.image), f"default ({offsets.DEFAULT}): "
                                                                f"{good.acne} acne, {good.leak} leak"))):
            ax = axes[i, j]
            ax.imshow(img, interpolation="nearest")
            ax.set_xticks([])
            ax.set_yticks([])
            ax.set_title(title, fontsize=7)
        axes[i, 0].set_ylabel(case.id.replace("-", "\n", 1), fontsize=6)
    fig.tight_layout()
    fig.savefig(path)
    plt.close(fig)
    return rows


def main(argv=None):
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("--out", default="out/acne")
    ap.add_argument("--docs", default=None, help="also copy chart.png and worst.png there (acne_*.png)")
    ap.add_argument("--size", default="64x48", help="image size of the matrix run (default 64x48, as the tests)")
    ap.add_argument("--timing-size", default="192x144", help="image size of the cost measurement")
    ap.add_argument("--worst-size", default="192x144", help="image size of the worst-case figure")
    ap.add_argument("--quick", action="store_true", help="pyrt.apps.acne.quick_matrix() instead of the full matrix")
    ap.add_argument("--offset", action="append", default=[], help="module:function of an extra offset to test")
    ap.add_argument("--write-known", default=None, help="write the failing cases per strategy to this JSON file")
    a = ap.parse_args(argv)
    out = Path(a.out)
    out.mkdir(parents=True, exist_ok=True)
    strategies = list(offsets.STRATEGIES) + [acne.load_callable(s) for s in a.offset]
    cases = acne.quick_matrix() if a.quick else acne.default_matrix()
    size = _size(a.size)
    t0 = time.perf_counter()
    results = acne.run_matrix(cases=cases, strategies=strategies, width=size[0], height=size[1],
                              progress=sys.stderr.isatty())
    t_matrix = time.perf_counter() - t0
    cost = measure_cost(strategies, _size(a.timing_size))
    table = acne.format_table(results)
    (out / "table.txt").write_text(table + "\n")
    write_csv(out / "results.csv", results)
    md = summary_markdown(results, cost)
    (out / "summary.md").write_text(md)
    draw_chart(out / "chart.png", results, cost)
    rows = draw_worst(out / "worst.png", results, _size(a.worst_size))
    print(table)
    print()
    print(md)
    print("worst cases:", ", ".join(f"{s}: {c.id}" for s, c, _, _ in rows))
    print(f"matrix: {len(cases)} cases x {len(strategies)} strategies at {a.size} in {t_matrix:.1f} s; "
          f"cost measured at {a.timing_size} on {', '.join(c.id for c in TIMING_CASES)}")
    if a.docs:
        d = Path(a.docs)
        d.mkdir(parents=True, exist_ok=True)
        shutil.copy(out / "chart.png", d / "acne_chart.png")
        shutil.copy(out / "worst.png", d / "acne_worst.png")
    if a.write_known:
        known = {s: sorted(r.case.id for r in results if r.strategy == s and not r.ok)
                 for s in dict.fromkeys(r.strategy for r in results)}
        Path(a.write_known).write_text(json.dumps({"size": list(size), "cases": "quick" if a.quick else "full",
                                                   "failures": known}, indent=1) + "\n")
    return 0


if __name__ == "__main__":
    sys.exit(main())
