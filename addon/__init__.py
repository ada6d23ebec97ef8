"""Weathervane for Blender, two products: a weathervane builder (vane/: the vane, its wind-driven motion, materials,
lights and camera in the sidebar) and the documented Whitted tracer as a render engine for any scene (engine/), with
the conversion between Blender's scenes and the tracer's between them (convert/).

Only registration lives here; each module registers its own classes, and unregistration runs in reverse.
"""

bl_info = {
    "name": "Weathervane",
    "author": "Weathervane developers",
    "version": (0, 1, 0),
    "blender": (3, 4, 0),
    "location": "View3D > Sidebar > Weathervane; Render Properties > Render Engine > Weathervane Tracer",
    "description": "Builds a wind-driven weathervane, and renders any scene with the documented Whitted ray tracer",
    "category": "Render",
}

from .engine import engine as render_engine  # noqa: E402  (`engine` stays the name of the folder)
from .engine import motion_panel, render_panels  # noqa: E402
from .vane import operators, panels, properties, sync  # noqa: E402

MODULES = (properties, operators, panels, render_engine, render_panels, motion_panel, sync)


def register() -> None:
    for module in MODULES:
        module.register()


def unregister() -> None:
    for module in reversed(MODULES):
        module.unregister()
