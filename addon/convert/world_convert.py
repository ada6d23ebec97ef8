"""scene.world -> the tracer's background and a world light (docs/scene-format.md), and what it approximates.

Cycles shows a uniform world of radiance W = Background Color x Strength to camera and mirror rays, and lights an
unoccluded white diffuse surface to exactly W (measured in Cycles 5.0.1 and 3.4.1: a world (0.3, 0.5, 0.7) gives
(0.3, 0.5, 0.7) on a white plane; tests/addon/test_shading_convert.py). So:

    background  {"type": "solid", "color": W}
    world light {"type": "world", "radiance": "color", "intensity": 1, "color": W, "samples": n}   shadowed by the
                objects over n directions per point (Cycles with no bounces); a W above 1 becomes intensity max(W)
                and colour W / max(W), the same light; the background clips

An Environment Texture (equirectangular) is the background itself: {"type": "image", "pixels": (H, W, 3) linear
float32, top row first, "strength": S, "rotation": a Mapping node's Z rotation in degrees} (docs/scene-format.md), its
pixels read once per image (environment_pixels, kept) and handed to the tracer as an array (F12) or a .npy file
(the Rendered view's and File > Export's documents, which are JSON); it lights as it is seen: {"type": "world",
"intensity": 1, "samples": n} (its mean, weighted by solid angle, times S where the camera does not see it). A
mirror-ball projection, a Mapping the tracer cannot express (anything but a Z rotation) or an input between them other
than a Mapping keep the mean colour as a solid background, named. A sky texture has no colour to read without
rendering it: a clear-sky blue (SKY_MEAN) times its strength, named. No world is black with no world light, as in
Cycles. The light's directions: the engine's Shadows samples, at least WORLD_SAMPLES. The add-on's own world
(twin.py, "WV World") is the panel's background, lighting nothing.
"""

from __future__ import annotations

import math
import os

import bpy

from .. import compat
from . import material_convert, node_tree

OWN_WORLD = "WV World"  # twin.WORLD
SKY_MEAN = (0.2, 0.35, 0.6)  # a clear day's sky, mean radiance at strength 1 (an estimate, named where used)
BLACK = {"type": "solid", "color": [0.0, 0.0, 0.0]}
WORLD_SAMPLES = 16  # the world light's directions per point at the least (a 4 x 4 grid over the hemisphere)

_means: dict[tuple, tuple[float, float, float]] = {}


def environment_mean(image) -> tuple[float, float, float] | None:
    """An equirectangular image's mean linear colour over the sphere (rows weighted by cos(latitude)), cached."""
    key = (image.name, tuple(image.size), image.filepath)
    if key not in _means:
        rgb = material_convert.linear_rgb(image)
        if rgb is None:
            return None
        height = rgb.shape[0]
        weights = [math.cos((row + 0.5) / height * math.pi - math.pi / 2.0) for row in range(height)]
        rows = rgb.mean(axis=1)  # (height, 3)
        _means[key] = tuple(float(c) for c in (rows * [[weight] for weight in weights]).sum(axis=0) / sum(weights))
    return _means[key]


_pixels: dict[tuple, object] = {}


def _image_key(image) -> tuple:
    return (image.name, tuple(image.size), image.filepath, image.colorspace_settings.name, image.is_float)


def environment_pixels(image):
    """An image's linear RGB (H, W, 3) float32, top row first, read-only, read once and kept (the last few)."""
    import numpy as np

    key = _image_key(image)
    if key not in _pixels:
        rgb = material_convert.linear_rgb(image)  # Blender's rows run from the bottom
        if rgb is None:
            return None
        pixels = np.ascontiguousarray(rgb[::-1], dtype=np.float32)
        pixels.flags.writeable = False
        while len(_pixels) >= 4:
            _pixels.pop(next(iter(_pixels)))
        _pixels[key] = pixels
    return _pixels[key]


_files: dict[int, tuple[object, str]] = {}


def background_for_json(background: dict) -> dict:
    """An image background for a JSON document (the Rendered view's, File > Export's): its pixels written once to
    a .npy file in a temporary folder (kept while the pixels are) and named by "image" instead, so that the document
    stays small and changes when the picture does (the file's name is the pixels' digest). Other backgrounds as
    they are."""
    pixels = background.get("pixels")
    if background.get("type") != "image" or pixels is None or isinstance(pixels, list):
        return background
    import hashlib
    import tempfile

    import numpy as np

    kept = _files.get(id(pixels))
    if kept is None or kept[0] is not pixels:
        digest = hashlib.blake2b(pixels.tobytes(), digest_size=12).hexdigest()
        folder = os.path.join(tempfile.gettempdir(), f"weathervane-worlds-{os.getuid()}")
        os.makedirs(folder, exist_ok=True)
        path = os.path.join(folder, f"world-{digest}.npy")
        if not os.path.exists(path):
            partial = f"{path}.{os.getpid()}.partial"
            np.save(partial, pixels)  # np.save adds .npy to a name without it
            os.replace(partial + ".npy" if not partial.endswith(".npy") else partial, path)
        while len(_files) >= 4:
            _files.pop(next(iter(_files)))
        kept = _files[id(pixels)] = (pixels, path)
    document = {key: value for key, value in background.items() if key != "pixels"}
    document["image"] = kept[1]
    return document


def _mapping_rotation(node, notes: list[str]) -> float | None:
    """The Z rotation (degrees) of what feeds an Environment Texture's Vector: 0 unlinked (the ray's direction) or
    from a Texture Coordinate's Generated/Object output, a Mapping (Point or Vector) of a Z rotation alone over
    that; None (named) for anything else."""
    source, output = node_tree.source(node.inputs["Vector"])
    if source is None:
        return 0.0
    if source.bl_idname == "ShaderNodeTexCoord":
        if _the_direction(source, output):
            return 0.0
        notes.append(f"{source.name} {output.name} on the environment texture's Vector: its mean colour")
        return None
    if source.bl_idname == "ShaderNodeMapping" and source.vector_type in ("POINT", "VECTOR"):
        inputs = source.inputs
        names = ("Rotation", "Location", "Scale")
        rotation, location, scale = (node_tree.constant_color(inputs[name]) for name in names)
        location = location if source.vector_type == "POINT" else (0.0, 0.0, 0.0)
        coordinates, given = node_tree.source(inputs["Vector"])
        plain = None not in (rotation, location, scale) and (coordinates is None or _the_direction(coordinates, given))
        if plain and rotation[0] == rotation[1] == 0.0 and not any(location) and all(k == 1.0 for k in scale):
            return math.degrees(rotation[2])
    notes.append(f"{source.name} on the environment texture's Vector: its mean colour")
    return None


def _the_direction(coordinates, output) -> bool:
    """Whether a Texture Coordinate output in a world is the ray's direction, as an unlinked Vector is: Generated, or
    Object with no object (Window, Reflection, Camera, or an object's space, are other directions)."""
    return output.name == "Generated" or (output.name == "Object" and coordinates.object is None)


def _environment_background(node, strength: float, notes: list[str]) -> dict | None:
    """An equirectangular Environment Texture as the tracer's image background; None where it cannot be one."""
    if node.bl_idname != "ShaderNodeTexEnvironment" or node.image is None:
        return None
    if node.projection != "EQUIRECTANGULAR":
        notes.append(f"environment texture's {node.projection.lower().replace('_', ' ')} projection: its mean colour")
        return None
    if material_convert.missing_file(node.image) is not None:
        notes.append(material_convert.missing_note(node.image, "the world"))
    rotation = _mapping_rotation(node, notes)
    pixels = environment_pixels(node.image) if rotation is not None else None
    if pixels is None:
        return None
    interpolation = "closest" if node.interpolation == "Closest" else "linear"
    if node.interpolation not in ("Linear", "Closest"):
        notes.append(f"environment texture's {node.interpolation} interpolation: linear")
    return {
        "type": "image",
        "pixels": pixels,
        "colorspace": "linear",
        "rotation": rotation,
        "strength": strength,
        "interpolation": interpolation,
    }


def picture_name(world) -> str:
    """The name of the image an Environment Texture gives the world's Background Color ("" where none does)."""
    if world is None or not compat.uses_nodes(world):
        return ""
    for background in node_tree.nodes(world.node_tree):
        if background.bl_idname == "ShaderNodeBackground":
            node, _ = node_tree.source(background.inputs["Color"])
            if node is not None and node.bl_idname == "ShaderNodeTexEnvironment" and node.image is not None:
                return node.image.name
    return ""


def _own_background(blender_scene) -> dict:
    settings = blender_scene.weathervane
    return {
        "type": settings.background,
        "color": list(settings.background_color),
        "horizon": list(settings.horizon),
        "zenith": list(settings.zenith),
    }


def _color_of(socket, notes: list[str]) -> tuple[float, float, float]:
    """The Background node's Color: its own, an RGB node's, an environment image's mean or a sky's estimate."""
    folded = node_tree.constant_color(socket)
    if folded is not None:
        return folded
    own = tuple(float(c) for c in socket.default_value[:3])
    node, _ = node_tree.source(socket)
    if node.bl_idname == "ShaderNodeTexEnvironment" and node.image is not None:
        mean = environment_mean(node.image)
        if mean is not None:
            return mean
    if node.bl_idname == "ShaderNodeTexSky":
        notes.append(f"sky texture: a clear-sky blue {SKY_MEAN}")
        return SKY_MEAN
    notes.append(f"{node.path_name} on the world's Color: the input's own value")
    return own


def scene_world(blender_scene, view_layer):
    """The World a view layer renders: its World Override (Blender 4.2+), else the scene's."""
    return getattr(view_layer, "world_override", None) or blender_scene.world


def convert_world(world, *, blender_scene=None) -> tuple[dict, dict | None, list[str]]:
    """scene.world (or None) -> (tracer background dict, ambient light dict or None, notes)."""
    blender_scene = blender_scene or bpy.context.scene
    notes: list[str] = []
    picture = None
    if world is None:
        return dict(BLACK), None, notes
    if world.name == OWN_WORLD and hasattr(blender_scene, "weathervane"):
        return _own_background(blender_scene), None, notes
    if not compat.uses_nodes(world):
        color = [float(c) for c in world.color[:3]]
    else:
        tree = world.node_tree
        outputs = [n for n in tree.nodes if n.bl_idname == "ShaderNodeOutputWorld" and n.target in ("ALL", "CYCLES")]
        output = ([n for n in outputs if n.is_active_output] or outputs or [None])[0]
        shader, _ = node_tree.source(output.inputs["Surface"]) if output is not None else (None, None)
        if shader is None:
            return dict(BLACK), None, notes
        if node_tree.wrap(output).inputs["Volume"].is_linked:
            notes.append("world volume: ignored")
        if shader.bl_idname != "ShaderNodeBackground":
            notes.append(f"{shader.bl_label} as the world: black")
            return dict(BLACK), None, notes
        color = _color_of(shader.inputs["Color"], notes)
        strength = node_tree.constant_number(shader.inputs["Strength"])
        if strength is None:
            feeding, _ = node_tree.source(shader.inputs["Strength"])
            notes.append(f"{feeding.name} on the world's Strength: the input's own value")
            strength = float(shader.inputs["Strength"].default_value)
        color = [c * strength for c in color]
        picture = None
        source, _ = node_tree.source(shader.inputs["Color"])
        if source is not None:
            picture = _environment_background(source, strength, notes)
            if source.bl_idname == "ShaderNodeTexEnvironment" and picture is None and source.image is not None:
                notes.append("environment texture: its mean colour")
    if not compat.uses_nodes(world) or picture is None:
        background = {"type": "solid", "color": [min(1.0, c) for c in color]}
        if max(color) > 1.0:
            notes.append("world brighter than 1: background clipped at 1, as the display shows it")
    else:
        background = picture
    visibility = getattr(world, "cycles_visibility", None)
    if visibility is not None and not visibility.camera:
        background = dict(BLACK)  # Cycles' camera rays do not see it
    if not all(math.isfinite(c) for c in color):  # a picture with NaN or infinite texels: the loader names it
        return background, None, notes
    if not any(c > 0.0 for c in color) or (visibility is not None and not visibility.diffuse):
        return background, None, notes
    # a uniform radiance W as intensity 1 and colour W; a W above 1 (the format's colours lie in [0, 1]) puts its
    # largest channel in the intensity: the same light
    brightest = max(1.0, max(color))
    uniform = {"intensity": brightest, "color": [c / brightest for c in color]}
    settings = getattr(blender_scene, "weathervane", None)
    if getattr(settings, "world_light", "SHADOWED") == "AMBIENT":  # the user picked speed over the shadows
        notes.append("world light: unshadowed ambient (Render Properties > World Light)")
        return background, {"type": "ambient", **uniform}, notes
    samples = world_samples(blender_scene)
    bounces = int(getattr(settings, "diffuse_bounces", 0))
    shadowed = f"shadowed, {samples} directions per point, " + (
        f"{bounces} diffuse bounce{'s' if bounces > 1 else ''}" if bounces else "no bounces"
    )
    if picture is not None and background is picture:  # the picture lights as the camera sees it
        notes.append(f"world light: the picture, {shadowed}")
        return background, {"type": "world", "intensity": 1.0, "samples": samples}, notes
    notes.append(f"world light: {shadowed}" + (", the picture's mean colour" if picture is not None else ""))
    return background, {"type": "world", "radiance": "color", "samples": samples, **uniform}, notes


def world_samples(blender_scene) -> int:
    """The world light's directions per point: the engine's Shadows samples, at least WORLD_SAMPLES (a world of
    one direction would be a sun)."""
    settings = getattr(blender_scene, "weathervane", None)
    return max(WORLD_SAMPLES, int(getattr(settings, "shadow_samples", "1")))
