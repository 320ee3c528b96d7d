"""What a process and its descendants use -- memory sampled while it runs, CPU time -- for the benchmark tools.

A render on forked worker processes (:mod:`pyrt.render.pool`) is several processes sharing the parent's pages
copy-on-write, so no one process's peak resident set (``ru_maxrss``) says what the machine holds: summing the
RSS counts every shared page once per process. The proportional set size (PSS: each page divided by the number
of processes mapping it, ``/proc/PID/smaps_rollup``) adds up over the tree to the physical memory it holds.
:class:`TreeMemory` sums it over the process and its descendants every ``interval`` seconds on a thread and
keeps the peak (a spike shorter than the interval can be missed: the renders' working sets live for a
chunk, tenths of a second). Linux only; elsewhere the peak is NaN.

:func:`cpu_seconds` likewise counts the render's worker processes: ``time.process_time()`` is this process's
threads only.
"""
from __future__ import annotations

import os
import threading


def cpu_seconds():
    """User + system CPU seconds of this process and of its children that have ended (a render's worker
    processes end, and are counted, when the render returns)."""
    t = os.times()
    return t.user + t.system + t.children_user + t.children_system


def _children(pid):
    out = []
    try:
        for tid in os.listdir(f"/proc/{pid}/task"):
            with open(f"/proc/{pid}/task/{tid}/children") as fh:
                out.extend(int(c) for c in fh.read().split())
    except OSError:
        pass
    return out


def _pss_kb(pid):
    try:
        with open(f"/proc/{pid}/smaps_rollup") as fh:
            for line in fh:
                if line.startswith("Pss:"):
                    return int(line.split()[1])
    except OSError:
        pass
    return 0


def tree_pss_mb(pid):
    """PSS of ``pid`` and all its descendants, MB (0 once it has exited)."""
    total, todo = 0, [pid]
    while todo:
        p = todo.pop()
        total += _pss_kb(p)
        todo.extend(_children(p))
    return total / 1024.0


class TreeMemory:
    """``with TreeMemory(pid) as m: ...`` then ``m.peak_mb``: the peak summed PSS of ``pid``'s process tree."""

    def __init__(self, pid, interval=0.03):
        self.pid, self.interval = pid, interval
        self.peak_mb = float("nan") if not os.path.exists("/proc/self/smaps_rollup") else 0.0
        self._stop = threading.Event()
        self._thread = threading.Thread(target=self._run, daemon=True)

    def _run(self):
        while not self._stop.is_set():
            self.peak_mb = max(self.peak_mb, tree_pss_mb(self.pid))
            self._stop.wait(self.interval)

    def __enter__(self):
        if self.peak_mb == self.peak_mb:          # not NaN: /proc is there
            self._thread.start()
        return self

    def __exit__(self, *exc):
        self._stop.set()
        if self._thread.is_alive():
            self._thread.join()
