"""Weathervane for Blender: builds the vane, bakes its wind-driven motion, maps materials, lights and camera.

Only registration lives here; each module registers its own classes, and unregistration runs in reverse.
"""

bl_info = {
    "name": "Weathervane",
    "author": "Weathervane developers",
    "version": (0, 1, 0),
    "blender": (3, 4, 0),
    "location": "View3D > Sidebar > Weathervane",
    "description": "A wind-driven weathervane and the documented Whitted tracer's scene settings",
    "category": "Add Mesh",
}

from . import engine, operators, panels, properties, render_panels, sync  # noqa: E402

MODULES = (properties, operators, panels, engine, render_panels, sync)


def register() -> None:
    for module in MODULES:
        module.register()


def unregister() -> None:
    for module in reversed(MODULES):
        module.unregister()
