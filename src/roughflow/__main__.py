"""``python -m roughflow`` runs the command line."""

import sys

from roughflow.cli import main

sys.exit(main())
