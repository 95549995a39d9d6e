"""``python -m pcgeom``: the same as ``pcgeom``."""

import sys

from .cli import main

sys.exit(main())
