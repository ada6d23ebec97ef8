"""Blender's process -> the interpreter and start method for the tracer's worker processes (no bpy needed)."""

from __future__ import annotations


def spawn_with_blenders_python() -> str:
    """The start method for worker processes inside Blender: "spawn", with Blender's Python as the interpreter.
    Workers are started afresh, never forked from Blender's own process: a fork copies a process with threads
    running (Blender's, Python's) and can crash in the child; a crash of Blender loses the artist's unsaved work."""
    import multiprocessing

    multiprocessing.set_executable(_python())
    return "spawn"


def _python() -> str:
    """The Python interpreter Blender runs (its sys.executable may be the Blender binary or another Python on the
    PATH): a virtual environment's own (the bpy wheel), else the interpreter under Blender's Python prefix."""
    import sys
    from pathlib import Path

    if sys.prefix != sys.base_prefix:
        return sys.executable
    version = f"{sys.version_info.major}.{sys.version_info.minor}"
    for candidate in (Path(sys.base_prefix) / "bin" / f"python{version}", Path(sys.base_prefix) / "bin" / "python3"):
        if candidate.exists():
            return str(candidate)
    return sys.executable
