"""``python -m pyrt``: the command line (:mod:`pyrt.apps.cli`)."""
import sys

from pyrt.apps.cli import main

if __name__ == "__main__":
    sys.exit(main())
