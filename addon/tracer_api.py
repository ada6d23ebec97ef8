"""Where the add-on finds the tracer: its own copy inside the built add-on, else the repository's package.

The copy is imported as a top-level package (`weathervane_tracer`, from the add-on's folder), not as a submodule
of the add-on: the render engine's worker processes are started afresh (not forked from Blender), and they import
the tracer's functions by module name; a submodule would make them import the add-on, which needs bpy.
"""

from __future__ import annotations

import importlib
import sys
from pathlib import Path
from types import ModuleType

_HERE = Path(__file__).resolve().parent
if (_HERE / "weathervane_tracer").is_dir():  # the copy `make addon` puts inside the add-on
    if str(_HERE) not in sys.path:
        sys.path.append(str(_HERE))
    import weathervane_tracer as package
else:  # running from the repository (tests, development)
    import tracer as package

# Importing multiprocessing (the tracer's workers do) lists the __main__ module of the moment again as
# `__mp_main__`. Where that is the module of a script Blender runs (`blender --python script.py`, an add-on enabled
# from such a script), Blender 3.4 frees the module after the script while the second name still holds it, and its
# exit crashes (segmentation fault) in addon_utils.disable_all's walk over sys.modules. Only a started child reads
# the name (it sets its own), so the parent drops it.
if sys.modules.get("__mp_main__") is sys.modules.get("__main__"):
    sys.modules.pop("__mp_main__", None)


def module(name: str) -> ModuleType:
    """A submodule of the tracer package, e.g. module('motion')."""
    return importlib.import_module(f"{package.__name__}.{name}")
