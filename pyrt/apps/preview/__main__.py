"""``python -m pyrt.apps.preview`` = ``pyrt-preview``."""
import sys

from pyrt.apps.preview.cli import main

sys.exit(main())
