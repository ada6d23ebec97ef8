"""The exact twin's set-up (addon/exact_twin.py) changes only what the render needs, and restore() puts it back.

Where Cycles has no OSL (Debian's 3.4.1) it refuses with the reason, and changes nothing."""

from __future__ import annotations

import bpy
import pytest

from addon.convert import exact_twin


def _build():
    scene = bpy.context.scene
    assert bpy.ops.weathervane.build() == {"FINISHED"}
    scene.render.resolution_x, scene.render.resolution_y = 32, 24
    return scene


def _state(scene):
    slots = {(obj.name, index): slot.material for obj in scene.objects for index, slot in enumerate(obj.material_slots)}
    lights = {obj.name: obj.hide_render for obj in scene.objects if obj.type == "LIGHT"}
    return slots, lights, scene.world


def test_apply_swaps_materials_hides_lights_and_restore_puts_them_back() -> None:
    if exact_twin.unavailable() is not None:
        pytest.skip(exact_twin.unavailable())
    scene = _build()
    before = _state(scene)
    twin = exact_twin.apply(bpy.context, samples=1)
    slots, lights, world = _state(scene)
    assert slots and all(material.get("weathervane_exact_twin") for material in slots.values())
    assert lights and all(lights.values()) and world.name == exact_twin.WORLD
    assert scene.cycles.shading_system and "trace(P" in twin.source
    twin.restore()
    assert _state(scene) == before


def test_without_osl_it_refuses_with_the_reason_and_changes_nothing() -> None:
    reason = exact_twin.unavailable()
    if reason is None:
        pytest.skip("this Blender's Cycles has OSL")
    scene = _build()
    before = _state(scene)
    with pytest.raises(RuntimeError, match=r"no exact twin: .*OSL"):
        exact_twin.apply(bpy.context, samples=1)
    assert _state(scene) == before
