"""Runs the add-on tests inside a Blender executable (Debian's 3.4.1 here), with that Blender's own Python:

    blender -b --factory-startup --python-exit-code 1 --python tests/addon/run_in_blender.py -- [pytest arguments]

Blender exits with pytest's exit code. pytest comes from the system (Debian's python3-pytest), as Blender 3.4 on
Debian runs the system's Python 3.11.
"""

import sys
from pathlib import Path

ROOT = Path(__file__).resolve().parents[2]
sys.path.insert(0, str(ROOT))

import pytest  # noqa: E402

arguments = sys.argv[sys.argv.index("--") + 1 :] if "--" in sys.argv else []
code = pytest.main(["-p", "no:cacheprovider", "--rootdir", str(ROOT), *(arguments or [str(ROOT / "tests" / "addon")])])
sys.exit(int(code))
