"""View Layer > Passes -> the tracer's passes to trace, Blender's passes to register, and the traced passes written
into a render result (Blender's names: Depth, Mist, Normal, Position, IndexOB, IndexMA, DiffDir, GlossDir, Emit,
Env, Shadow, CryptoObject00..., CryptoMaterial00...; from Blender 5.0 its new ones: Object Index, Material Index,
Diffuse Direct, Glossy Direct, Emission, Environment; Ambient, Reflection and Transmission as the engine's own).

Cryptomatte as Cycles writes it in each Blender: the view layer's Levels (pass_cryptomatte_depth) in
`(min(16, levels) + 1) // 2` RGBA layers per pass whose channels are "r", "g", "b", "a" (Cycles registers them so),
the IDs and manifests under Blender's names (the objects', the instanced objects', the materials', Cycles'
"default_surface" for a face without one), and the manifest of materials with Cycles' own shaders as it lists them."""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from .. import compat
from .. import tracer_api as tracer


@dataclass(frozen=True)
class BlenderPass:
    """tracer: the tracer's pass; flag: the View Layer property that asks for it (on scene.weathervane where Blender
    has none); name, channel letters and kind as RenderEngine.register_pass takes them."""

    tracer: str
    flag: str
    name: str
    letters: str
    kind: str  # VALUE, VECTOR or COLOR
    own: bool = False  # the flag is the add-on's (view_layer.weathervane), not Blender's own on the view layer


PASSES = (
    BlenderPass("depth", "use_pass_z", "Depth", "Z", "VALUE"),
    BlenderPass("mist", "use_pass_mist", "Mist", "Z", "VALUE"),
    BlenderPass("normal", "use_pass_normal", "Normal", "XYZ", "VECTOR"),
    BlenderPass("position", "use_pass_position", "Position", "XYZ", "VECTOR"),
    BlenderPass("object_index", "use_pass_object_index", "IndexOB", "X", "VALUE"),
    BlenderPass("material_index", "use_pass_material_index", "IndexMA", "X", "VALUE"),
    BlenderPass("ambient", "use_pass_ambient", "Ambient", "RGB", "COLOR", own=True),
    BlenderPass("diffuse", "use_pass_diffuse_direct", "DiffDir", "RGB", "COLOR"),
    BlenderPass("specular", "use_pass_glossy_direct", "GlossDir", "RGB", "COLOR"),
    BlenderPass("emission", "use_pass_emit", "Emit", "RGB", "COLOR"),
    BlenderPass("reflection", "use_pass_reflection", "Reflection", "RGB", "COLOR", own=True),
    BlenderPass("environment", "use_pass_environment", "Env", "RGB", "COLOR"),
    BlenderPass("transmission", "use_pass_transmission", "Transmission", "RGB", "COLOR", own=True),
    BlenderPass("shadow", "use_pass_shadow", "Shadow", "RGB", "COLOR"),  # EEVEE's is RGB: the share, grey
    # one RGBA layer's channels, lower case as Cycles registers them; a layer per two of the view layer's levels
    BlenderPass("cryptomatte_object", "use_pass_cryptomatte_object", "CryptoObject", "rgba", "COLOR"),
    BlenderPass("cryptomatte_material", "use_pass_cryptomatte_material", "CryptoMaterial", "rgba", "COLOR"),
)
# Blender 5.0 renamed its passes (Cycles' and EEVEE's results, the compositor's Render Layers sockets, multilayer
# files): the engine's take the same names there, so a compositor made with Cycles reads them
BLENDER_5_NAMES = {
    "IndexOB": "Object Index",
    "IndexMA": "Material Index",
    "DiffDir": "Diffuse Direct",
    "GlossDir": "Glossy Direct",
    "Emit": "Emission",
    "Env": "Environment",
}
# View Layer passes the tracer has nothing for: named in the render's one warning line when ticked.
NOT_MADE = {
    "use_pass_vector": "Vector",
    "use_pass_uv": "UV",
    "use_pass_ambient_occlusion": "AO",
    "use_pass_diffuse_indirect": "Diffuse Indirect",
    "use_pass_diffuse_color": "Diffuse Color",
    "use_pass_glossy_indirect": "Glossy Indirect",
    "use_pass_glossy_color": "Glossy Color",
    "use_pass_transmission_direct": "Transmission Direct",
    "use_pass_transmission_indirect": "Transmission Indirect",
    "use_pass_transmission_color": "Transmission Color",
    "use_pass_subsurface_direct": "Subsurface Direct",
    "use_pass_subsurface_indirect": "Subsurface Indirect",
    "use_pass_subsurface_color": "Subsurface Color",
    "use_pass_cryptomatte_asset": "Cryptomatte Asset",
    "use_pass_grease_pencil": "Grease Pencil",
}


def _ticked(entry: BlenderPass, scene, view_layer) -> bool:
    owner = getattr(view_layer, "weathervane", None) if entry.own else view_layer
    return bool(getattr(owner, entry.flag, False))


def wanted(scene, view_layer) -> tuple[str, ...]:
    """The tracer passes the view layer (and the add-on's own boxes) ask for, in the tracer's order."""
    names = {entry.tracer for entry in PASSES if _ticked(entry, scene, view_layer)}
    return tuple(name for name in tracer.PASSES if name in names)


def not_made(view_layer) -> list[str]:
    """The ticked passes the tracer cannot make, in Blender's words."""
    return [f"{label} pass" for flag, label in NOT_MADE.items() if getattr(view_layer, flag, False)]


# the shaders Cycles lists in every material manifest beside the scene's materials, in its order (3.4 to 5.0)
CYCLES_SHADERS = ("default_surface", "default_volume", "default_light", "default_background", "default_empty")
DEFAULT_SURFACE = "default_surface"  # what Cycles names a face without a material


def layer_names(entry: BlenderPass, levels: int = tracer.CRYPTOMATTE_LEVELS) -> list[str]:
    """This Blender's pass names for an entry (Blender 5's where it renamed them): a Cryptomatte pass is one RGBA
    pass per two of its levels (CryptoObject00, 01, 02 for Blender's default 6), as Cycles makes them."""
    if entry.name.startswith("Crypto"):
        return [f"{entry.name}{index:02d}" for index in range(tracer.cryptomatte_layers(levels))]
    return [blender_name(entry.name)]


def levels(view_layer) -> int:
    """The view layer's Cryptomatte levels (View Layer > Passes > Cryptomatte > Levels; 6 where it has none)."""
    return int(getattr(view_layer, "pass_cryptomatte_depth", tracer.CRYPTOMATTE_LEVELS))


def cryptomatte(view_layer) -> dict:
    """The view layer's Cryptomatte levels as the scene file's render field (the ranks its passes keep)."""
    return {"cryptomatte_levels": levels(view_layer)}


def blender_name(name: str) -> str:
    """A pass's name as this Blender calls it ("IndexOB" before 5.0, "Object Index" from 5.0)."""
    return BLENDER_5_NAMES.get(name, name) if compat.passes_named_in_words() else name


def register_passes(engine, scene, view_layer) -> None:
    """RenderEngine.update_render_passes' work: Combined (the compositor's Render Layers node has an Image socket
    only for a registered pass) and every ticked pass, under Blender's names."""
    if getattr(view_layer, "use_pass_combined", True):
        engine.register_pass(scene, view_layer, "Combined", 4, "RGBA", "COLOR")
    for entry in PASSES:
        if _ticked(entry, scene, view_layer):
            for name in layer_names(entry, levels(view_layer)):
                engine.register_pass(scene, view_layer, name, len(entry.letters), entry.letters, entry.kind)


def mist(world) -> dict:
    """The World's Mist Pass settings as the scene file's render fields."""
    settings = getattr(world, "mist_settings", None)
    if settings is None:
        return {}
    return {"mist_start": settings.start, "mist_depth": settings.depth, "mist_falloff": settings.falloff}


def write_passes(render_result, passes: dict[str, np.ndarray], fast: bool) -> None:
    """The traced passes ((H, W, C), rows top-down) into the result's passes of the same names (Blender's rows go
    bottom-up); fast: the pass takes foreach_set (Blender 4+), else a list (3.4)."""
    layer = render_result.layers[0]
    for entry in PASSES:
        values = passes.get(entry.tracer)
        if values is None:
            continue
        values = np.flipud(values).astype(np.float32)
        if entry.tracer == "shadow":
            values = np.repeat(values, 3, axis=2)
        for index, name in enumerate(layer_names(entry, _levels_of(values))):
            target = layer.passes.find(name)
            if target < 0:
                continue
            part = values[..., 4 * index : 4 * index + 4] if entry.name.startswith("Crypto") else values
            rect = layer.passes[target].rect
            if fast:
                rect.foreach_set(np.ascontiguousarray(part).ravel())
            else:
                rect = part.reshape(-1, part.shape[-1]).tolist()
                layer.passes[target].rect = rect


def exr_channels(passes: dict[str, np.ndarray], layer: str) -> dict[str, np.ndarray]:
    """The traced passes ((H, W, C), rows top-down) as a multilayer EXR's channels as Blender names them,
    "<layer>.<pass>.<channel>" -> (H, W) float32, rows top-down (Blender 3.4 reads them with
    RenderResult.load_from_file)."""
    channels: dict[str, np.ndarray] = {}
    for entry in PASSES:
        values = passes.get(entry.tracer)
        if values is None:
            continue
        values = values.astype(np.float32, copy=False)
        if entry.tracer == "shadow":
            values = np.repeat(values, 3, axis=2)
        for index, name in enumerate(layer_names(entry, _levels_of(values))):
            part = values[..., 4 * index : 4 * index + 4] if entry.name.startswith("Crypto") else values
            for k, letter in enumerate(entry.letters):
                channels[f"{layer}.{name}.{letter}"] = part[..., k]
    return channels


def _levels_of(values: np.ndarray) -> int:
    """A traced pass's Cryptomatte levels as its RGBA layers give them (two ranks a layer)."""
    return 2 * max(1, values.shape[-1] // 4)


def cryptomatte_metadata(scene, view_layer_name: str) -> dict[str, str]:
    """The Cryptomatte layers' header fields (name, hash, conversion, manifest) for the render result's metadata,
    where Blender's Cryptomatte node and its EXR writer find them: the manifests under the names the IDs hash
    (render.cryptomatte_names: Blender's), the materials' after Cycles' own shaders, as Cycles lists them."""
    fields: dict[str, str] = {}
    if "cryptomatte_object" in scene.render.passes:
        names = tracer.cryptomatte_matte_names([obj.name for obj in scene.objects], scene.render, "object")
        fields.update(tracer.cryptomatte_layer_header(f"{view_layer_name}.CryptoObject", names, "object"))
    if "cryptomatte_material" in scene.render.passes:
        names = tracer.cryptomatte_matte_names(list(scene.materials), scene.render, "material")
        layer = f"{view_layer_name}.CryptoMaterial"
        fields.update(tracer.cryptomatte_layer_header(layer, [*CYCLES_SHADERS, *names], "material"))
    return fields


def blender_names(materials: dict, objects: dict[str, str], vane_material_name) -> dict:
    """render.cryptomatte_names for an export: the scene file's objects and materials whose Blender names (those
    Cycles' Cryptomatte hashes) are not theirs. objects: scene-file name -> Blender object name (an instance's: the
    instanced object's, as Cycles names it); materials: the document's, "blender:<name>" for a Blender material,
    "blender:default" for faces without one (Cycles' default_surface), and the vane's under their own names (their
    Blender material is vane_material_name(name))."""
    renamed_materials = {}
    for name in materials:
        if name == "blender:default":
            renamed_materials[name] = DEFAULT_SURFACE
        elif name.startswith("blender:"):
            renamed_materials[name] = name[len("blender:") :]
        else:
            renamed_materials[name] = vane_material_name(name)
    renamed = {
        "objects": {name: blender for name, blender in objects.items() if blender and blender != name},
        "materials": {name: blender for name, blender in renamed_materials.items() if blender != name},
    }
    return {key: table for key, table in renamed.items() if table}
