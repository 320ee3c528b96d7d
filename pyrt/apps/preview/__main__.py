"""``python -m pyrt.apps.preview`` = ``pyrt-preview``."""
import sys

from pyrt.apps.common import process_age
from pyrt.apps.preview.cli import main

sys.exit(main(started=process_age()))
