import sys

from gyroid.cli import main

sys.exit(main())
