"""The command line meant for a script, under `blender -b ... --python X.py -- ARGS` or `python X.py ARGS`."""

from __future__ import annotations

import sys
from pathlib import Path


def script_arguments() -> list[str]:
    """ARGS: what follows `--` inside Blender (none without it), or everything after the script's name."""
    if "--" in sys.argv:
        return sys.argv[sys.argv.index("--") + 1 :]
    if sys.argv and Path(sys.argv[0]).suffix == ".py":
        return sys.argv[1:]
    return []
