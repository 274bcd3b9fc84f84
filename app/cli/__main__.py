"""``python -m app.cli`` runs the ``homebot`` command."""

import sys

from app.cli import main

sys.exit(main())
