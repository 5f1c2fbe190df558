"""``python -m gyroid``: the command line."""

import sys

from gyroid.cli import main

if __name__ == "__main__":  # a process spawned by gyroid (the demo's second one) imports this
    sys.exit(main())
