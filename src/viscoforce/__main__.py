"""``python -m viscoforce`` runs the command-line interface."""

import sys

from viscoforce.cli import main

sys.exit(main())
