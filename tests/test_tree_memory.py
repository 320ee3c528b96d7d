"""tools/_usage.py: the summed PSS of a process tree counts a forked child's own pages and the shared ones once."""
import os
import subprocess
import sys
import time

import pytest

ROOT = os.path.dirname(os.path.dirname(os.path.abspath(__file__)))
sys.path.insert(0, os.path.join(ROOT, "tools"))
from _usage import TreeMemory, tree_pss_mb  # noqa: E402

pytestmark = pytest.mark.skipif(not os.path.exists("/proc/self/smaps_rollup"), reason="Linux /proc")

CHILD = """
import os, sys, time, numpy as np
shared = np.ones(150 * 2**20 // 8)            # 150 MB touched before the fork: shared copy-on-write
pid = os.fork()
if pid == 0:
    own = np.ones(100 * 2**20 // 8)           # 100 MB of the child's own
    print("ready", flush=True)
    time.sleep(1.5)
    os._exit(0)
time.sleep(1.6)
os.waitpid(pid, 0)
"""


def test_tree_pss_counts_shared_pages_once_and_the_childs_own_pages():
    proc = subprocess.Popen([sys.executable, "-c", CHILD], stdout=subprocess.PIPE, text=True)
    with TreeMemory(proc.pid, interval=0.02) as mem:
        assert proc.stdout.readline().strip() == "ready"
        time.sleep(0.3)
        now = tree_pss_mb(proc.pid)
        proc.wait()
    # interpreter + NumPy ~30-60 MB per process (shared too), 150 MB shared, 100 MB the child's: 250 + overhead;
    # summing the two RSS would count the 150 MB twice (>= 400)
    assert 250 <= now <= 380, now
    assert now <= mem.peak_mb <= 400, mem.peak_mb
    assert tree_pss_mb(proc.pid) == 0.0          # gone
