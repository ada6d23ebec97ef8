"""What Blender's own editors change, shown at once where the add-on shows it too.

- A vane material's Color, Shininess and Reflectivity are its "WV Surface" group node's inputs (the Material tab) and
  the sidebar's Materials entries: an edit of the node is copied to the entry before the depsgraph evaluates it (so
  the Rendered view's export and F12 read the new value the first time), before each frame F12 or an animation
  renders (an edit by a script, with no evaluation between), and after undo, redo and loading a file. The entry's
  own edits reach the node in its update callback (properties.py). Each side is written only where it differs, so
  nothing calls back and forth.
- A light's type changed in the Light tab, or an entry that the node's edit changed, redraws the sidebar and the
  Properties editor (Blender redraws them for their own data, not for what the add-on derives from it).
"""

from __future__ import annotations

import bpy

from . import materials

REDRAWN = ("VIEW_3D", "PROPERTIES")


def redraw() -> None:
    """Redraw the 3D Views (their sidebar) and Properties editors of every window."""
    manager = bpy.context.window_manager if bpy.context else None
    for window in getattr(manager, "windows", ()):
        for area in window.screen.areas if window.screen else ():
            if area.type in REDRAWN:
                area.tag_redraw()


def _sync(scene) -> bool:
    changed = materials.sync_from_nodes(scene) if scene is not None else False
    if changed:
        redraw()
    return changed


@bpy.app.handlers.persistent
def _before_evaluation(scene, *_depsgraph) -> None:
    _sync(scene)


@bpy.app.handlers.persistent
def _before_render(scene, *_args) -> None:
    _sync(scene)


@bpy.app.handlers.persistent
def _after_undo(*_args) -> None:
    for scene in bpy.data.scenes:
        _sync(scene)


@bpy.app.handlers.persistent
def _after_evaluation(_scene, depsgraph) -> None:
    """A light's data (its type) or a light object changed: the sidebar's Lights list shows the type it has now."""
    for update in depsgraph.updates:
        identifier = update.id
        if isinstance(identifier, bpy.types.Light) or (
            isinstance(identifier, bpy.types.Object) and identifier.type == "LIGHT"
        ):
            redraw()
            return


HANDLERS = (
    ("depsgraph_update_pre", _before_evaluation),
    ("depsgraph_update_post", _after_evaluation),
    ("render_pre", _before_render),
    ("undo_post", _after_undo),
    ("redo_post", _after_undo),
    ("load_post", _after_undo),
)


def register() -> None:
    for name, handler in HANDLERS:
        handlers = getattr(bpy.app.handlers, name)
        if handler not in handlers:
            handlers.append(handler)


def unregister() -> None:
    for name, handler in HANDLERS:
        handlers = getattr(bpy.app.handlers, name)
        if handler in handlers:
            handlers.remove(handler)
