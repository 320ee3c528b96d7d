"""``python -m pyrt.apps.acne``."""
import sys

from pyrt.apps.acne.cli import main

sys.exit(main())
