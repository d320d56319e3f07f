"""``python -m sklearn_ifog`` runs the command line."""

import sys

from sklearn_ifog.cli import main

sys.exit(main())
