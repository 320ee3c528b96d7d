"""Thin wrapper around the ``pyrt-preview`` command (:func:`pyrt.apps.preview.main`), for a checkout without install.

    python tools/preview.py assets/models/studio_sample.glb -o out/sample.png
    python tools/preview.py assets/models/ --out-dir out/previews --turntable 8
    python tools/preview.py "assets/models/*.obj" --out-dir out/previews --dask        # LocalCluster
"""
import os
import sys

sys.path.insert(0, os.path.dirname(os.path.dirname(os.path.abspath(__file__))))

from pyrt.apps.preview import main  # noqa: E402

if __name__ == "__main__":
    sys.exit(main())
