"""``python -m pcgeom.cli``: the same as ``pcgeom``."""

import sys

from . import main

sys.exit(main())
