"""`python -m tracer ...`: see tracer.cli."""

import sys

from .cli import main

sys.exit(main())
