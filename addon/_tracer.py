"""Where the add-on finds the tracer: its own copy inside the built add-on, else the repository's package."""

from __future__ import annotations

import importlib
from types import ModuleType

try:
    from . import tracer as package  # the copy `make addon` puts inside the add-on
except ImportError:
    import tracer as package  # running from the repository (tests, development)


def module(name: str) -> ModuleType:
    """A submodule of the tracer package, e.g. module('motion')."""
    return importlib.import_module(f"{package.__name__}.{name}")
