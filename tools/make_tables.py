"""Write the precomputed tables pyrt ships (rerun after changing how they are built; tests check them).

- ``pyrt/materials/dfg_tables.npz``: the split sum's directional-albedo tables (:func:`shaders.dfg.specular_albedo_tables`
  for the shipped Smith terms, :func:`shaders.dfg.schlick_diffuse_loss_table`), :func:`pyrt.materials.preview.write_tables`;
- ``pyrt/apps/preview/studio_prefiltered.npz``: the GGX-prefiltered stack of the previewer's studio map,
  :func:`pyrt.apps.preview.studio.write_shipped_prefiltered`.

Both are pure functions of constants in the code, built in ~0.3 s together by every preview process otherwise.
``tests/test_split_sum.py`` and ``tests/test_preview_studio.py`` compare the files with a fresh build.

    python tools/make_tables.py
"""
from __future__ import annotations

import argparse
import os

from pyrt.apps.preview import studio
from pyrt.materials import preview


def main():
    argparse.ArgumentParser(description=__doc__.split("\n")[0]).parse_args()
    for path in (preview.write_tables(), studio.write_shipped_prefiltered()):
        print(f"wrote {path} ({os.path.getsize(path)} bytes)")


if __name__ == "__main__":
    main()
