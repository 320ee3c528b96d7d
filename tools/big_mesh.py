"""Preparation speed and memory of a multi-million-triangle mesh in ``pyrt-preview``.

    python tools/big_mesh.py                         # generate /tmp/pyrt_big_mesh.ply (5.24 M triangles), preview it
    python tools/big_mesh.py --python /work/main/.venv/bin/python   # the same run with another checkout's pyrt
    python tools/big_mesh.py --subdivisions 7        # 328 k triangles (quick)
    python tools/big_mesh.py --preview-args="--bvh-quality medium"   # more pyrt-preview options

The mesh is generated in code, never committed: an icosphere of ``--subdivisions`` levels (9: 5,242,880 triangles,
2,621,442 vertices) whose radius is displaced by smooth bumps (a sum of three products of sines, amplitude 5 %) and
a little deterministic noise (1e-4), written as a binary little-endian PLY without normals (what a scanner gives:
vertex positions and triangle faces), so ``pyrt-preview`` computes the crease-angle normals itself.

Then ``pyrt-preview MESH -o OUT.png`` runs at its defaults (640x480, 4 spp) in a child process under
``/usr/bin/time -v`` (peak RSS = "Maximum resident set size"); the tool prints the child's summary line (the phases
it reports), the wall time, the CPU time (user + system: less sensitive than wall time to other processes on a
shared machine) and the peak RSS, with the machine's load average before and after (``os.getloadavg``:
the machine is shared, so absolute times are noisy). Run one at a time: a 5 M-triangle run of an old checkout peaks
at ~12 GB.
"""
from __future__ import annotations

import argparse
import os
import re
import subprocess
import sys
import tempfile
import time

import numpy as np


def make_mesh(subdivisions=9, seed=0):
    """A bumpy icosphere: ``(vertices (V, 3) float64, faces (F, 3) int64)`` with ``F = 20 * 4**subdivisions``.

    Built by repeated 4-to-1 subdivision with shared edge midpoints (vectorised: each level makes one midpoint per
    unique edge), projected to the sphere, then displaced radially by
    ``0.05 sin(5x) sin(7y) sin(3z) + 0.03 sin(11x + 2) sin(13z) + 0.02 sin(9y) sin(17x) + 1e-4 n`` with ``n`` standard
    normal noise from ``seed``.
    """
    t = (1.0 + 5 ** 0.5) / 2
    v = np.array([[-1, t, 0], [1, t, 0], [-1, -t, 0], [1, -t, 0], [0, -1, t], [0, 1, t], [0, -1, -t], [0, 1, -t],
                  [t, 0, -1], [t, 0, 1], [-t, 0, -1], [-t, 0, 1]], dtype=np.float64)
    f = np.array([[0, 11, 5], [0, 5, 1], [0, 1, 7], [0, 7, 10], [0, 10, 11], [1, 5, 9], [5, 11, 4], [11, 10, 2],
                  [10, 7, 6], [7, 1, 8], [3, 9, 4], [3, 4, 2], [3, 2, 6], [3, 6, 8], [3, 8, 9], [4, 9, 5],
                  [2, 4, 11], [6, 2, 10], [8, 6, 7], [9, 8, 1]], dtype=np.int64)
    v /= np.linalg.norm(v, axis=1, keepdims=True)
    for _ in range(subdivisions):
        e = np.concatenate([f[:, [0, 1]], f[:, [1, 2]], f[:, [2, 0]]])          # (3F, 2): edges of faces
        e.sort(axis=1)
        key = e[:, 0] * v.shape[0] + e[:, 1]
        uniq, inv = np.unique(key, return_inverse=True)
        a, b = uniq // v.shape[0], uniq % v.shape[0]
        mid = v[a] + v[b]
        mid /= np.linalg.norm(mid, axis=1, keepdims=True)
        m = (inv.reshape(3, -1) + v.shape[0]).T                                  # (F, 3): midpoints of edges 01 12 20
        v = np.concatenate([v, mid])
        f = np.concatenate([np.stack([f[:, 0], m[:, 0], m[:, 2]], 1), np.stack([f[:, 1], m[:, 1], m[:, 0]], 1),
                            np.stack([f[:, 2], m[:, 2], m[:, 1]], 1), m])
    x, y, z = v.T
    r = (1.0 + 0.05 * np.sin(5 * x) * np.sin(7 * y) * np.sin(3 * z) + 0.03 * np.sin(11 * x + 2) * np.sin(13 * z)
         + 0.02 * np.sin(9 * y) * np.sin(17 * x) + 1e-4 * np.random.default_rng(seed).standard_normal(v.shape[0]))
    return v * r[:, None], f


def write_ply(path, vertices, faces):
    """Binary little-endian PLY: float32 x y z per vertex, uchar-counted int32 lists of 3 per face."""
    v = np.ascontiguousarray(vertices, dtype="<f4")
    rec = np.empty(faces.shape[0], dtype=[("n", "u1"), ("i", "<i4", (3,))])
    rec["n"] = 3
    rec["i"] = faces
    head = (f"ply\nformat binary_little_endian 1.0\ncomment pyrt tools/big_mesh.py\nelement vertex {v.shape[0]}\n"
            "property float x\nproperty float y\nproperty float z\n"
            f"element face {faces.shape[0]}\nproperty list uchar int vertex_indices\nend_header\n")
    with open(path, "wb") as fh:
        fh.write(head.encode("ascii"))
        fh.write(v.tobytes())
        fh.write(rec.tobytes())


def run_preview(python, mesh, out_png, extra=()):
    """Run ``pyrt-preview`` (as ``python -m pyrt.apps.preview``) under ``/usr/bin/time -v``.

    Returns ``(wall seconds, peak RSS bytes, CPU seconds (user + system), the child's stdout, its stderr without the
    time report)``.
    """
    cmd = ["/usr/bin/time", "-v", python, "-m", "pyrt.apps.preview", mesh, "-o", out_png, *extra]
    t0 = time.perf_counter()
    proc = subprocess.run(cmd, capture_output=True, text=True, cwd=tempfile.gettempdir())
    wall = time.perf_counter() - t0
    m = re.search(r"Maximum resident set size \(kbytes\): (\d+)", proc.stderr)
    rss = int(m.group(1)) * 1024 if m else -1
    cpu = sum(float(x) for x in re.findall(r"(?:User|System) time \(seconds\): ([\d.]+)", proc.stderr))
    err = proc.stderr.split("\tCommand being timed")[0]
    if proc.returncode != 0:
        raise SystemExit(f"big_mesh: pyrt-preview failed (exit {proc.returncode}):\n{err}")
    return wall, rss, cpu, proc.stdout, err


def main(argv=None):
    """Generate the mesh (unless it exists), preview it, print phases, wall time and peak RSS."""
    ap = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    ap.add_argument("--subdivisions", type=int, default=9, help="icosphere levels (9: 5.24 M triangles)")
    ap.add_argument("--mesh", help="PLY path (default /tmp/pyrt_big_mesh_<levels>.ply; generated if missing)")
    ap.add_argument("--python", default=sys.executable, help="interpreter whose pyrt runs the preview")
    ap.add_argument("--out", default=None, help="preview PNG (default: a file in the temporary folder)")
    ap.add_argument("--runs", type=int, default=1, help="repeat the preview (one at a time)")
    ap.add_argument("--preview-args", default="", help="more pyrt-preview arguments, e.g. '--bvh-quality medium'")
    args = ap.parse_args(argv)
    mesh = args.mesh or os.path.join(tempfile.gettempdir(), f"pyrt_big_mesh_{args.subdivisions}.ply")
    if not os.path.exists(mesh):
        t0 = time.perf_counter()
        v, f = make_mesh(args.subdivisions)
        write_ply(mesh, v, f)
        print(f"generated {mesh}: {f.shape[0]:,} triangles, {v.shape[0]:,} vertices, "
              f"{os.path.getsize(mesh) / 2**20:.0f} MiB in {time.perf_counter() - t0:.1f} s")
        del v, f
    out = args.out or os.path.join(tempfile.gettempdir(), "pyrt_big_mesh_preview.png")
    for k in range(args.runs):
        load0 = os.getloadavg()
        wall, rss, cpu, stdout, err = run_preview(args.python, mesh, out, args.preview_args.split())
        load1 = os.getloadavg()
        summary = [ln for ln in stdout.splitlines() if "triangles" in ln]
        print(f"run {k + 1}: {args.python} {args.preview_args}".rstrip())
        for ln in summary:
            print(f"  summary: {ln}")
        print(f"  wall {wall:.1f} s, CPU {cpu:.1f} s, peak RSS {rss / 2**30:.2f} GiB, load average {load0[0]:.1f} -> {load1[0]:.1f}"
              f" ({os.cpu_count()} cores)")
        for ln in err.strip().splitlines()[:5]:
            print(f"  stderr: {ln}")


if __name__ == "__main__":
    main()
