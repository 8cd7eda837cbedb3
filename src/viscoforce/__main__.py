"""``python -m viscoforce`` runs the command-line interface."""

import sys

from viscoforce.cli import main

if __name__ == "__main__":
    sys.exit(main())
