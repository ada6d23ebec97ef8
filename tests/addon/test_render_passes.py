"""View Layer > Passes with the tracer as the engine: the passes ticked come out in Blender's render result and in
the multilayer EXR Blender saves, holding what the scene says (a plane at a known distance, its normal, each
object's pass index), the Whitted passes add up to Combined, Cryptomatte picks each object, and a pass the tracer
cannot make is named in the warning."""

from __future__ import annotations

import json
import subprocess
import sys
from pathlib import Path

import bpy
import numpy as np
import pytest

from addon.convert.pass_map import blender_name  # Blender 5 renamed its passes: the names this Blender uses

ROOT = Path(__file__).resolve().parents[2]
WHITTED = tuple(blender_name(name) for name in ("Ambient", "DiffDir", "GlossDir", "Emit", "Reflection", "Env"))
WHITTED += ("Transmission",)
# Reads a multilayer EXR (single- or multi-part) into {channel: (H, W) float32} plus the header's text fields.
READER = """
import json, sys
import numpy as np
sys.path.insert(0, sys.argv[3])
from tracer.tracing.exr import read_exr_channels
found, header = read_exr_channels(sys.argv[1])
np.savez(sys.argv[2], **found)
print(json.dumps({key: value.decode() if isinstance(value, bytes) else value for key, value in header.items()
                  if isinstance(value, (str, bytes))}))
"""


def read_exr(path: Path, tmp_path: Path) -> tuple[dict[str, np.ndarray], dict[str, str]]:
    """The channels and header of an EXR Blender saved, read with the OpenEXR bindings in the project's .venv (Blender
    3.4's own Python has none)."""
    python = ROOT / ".venv" / "bin" / "python"
    arrays = tmp_path / "channels.npz"
    result = subprocess.run(
        [str(python if python.exists() else sys.executable), "-c", READER, str(path), str(arrays), str(ROOT)],
        capture_output=True,
        text=True,
        timeout=120,
    )
    assert result.returncode == 0, result.stderr
    with np.load(arrays) as loaded:
        return {name: loaded[name] for name in loaded.files}, json.loads(result.stdout)


def plane_and_cube_scene() -> bpy.types.Scene:
    """A camera 5 m above a large plane, looking straight down; a 2 m cube on the plane below the camera's centre
    (its top face 3 m from the camera); pass indices 4 (plane) and 9 (cube), material pass index 6 on the cube."""
    bpy.ops.wm.read_factory_settings(use_empty=True)
    scene = bpy.context.scene
    scene.render.engine = "WEATHERVANE_TRACER"
    scene.render.resolution_x, scene.render.resolution_y, scene.render.resolution_percentage = 64, 48, 100
    bpy.ops.mesh.primitive_plane_add(size=100.0)
    bpy.context.object.pass_index = 4
    bpy.ops.mesh.primitive_cube_add(size=2.0, location=(0.0, 0.0, 1.0))
    cube = bpy.context.object
    cube.pass_index = 9
    material = bpy.data.materials.new("red")
    material.pass_index = 6
    cube.data.materials.append(material)
    bpy.ops.object.camera_add(location=(0.0, 0.0, 5.0), rotation=(0.0, 0.0, 0.0))
    scene.camera = bpy.context.object
    bpy.ops.object.light_add(type="POINT", location=(2.0, -3.0, 8.0))
    world = bpy.data.worlds.new("World")
    scene.world = world
    return scene


def add_glass_ball(location: tuple[float, float, float]) -> None:
    """A glass ball (Principled Transmission 1, IOR 1.45) of radius 0.5."""
    from addon import compat

    bpy.ops.mesh.primitive_uv_sphere_add(radius=0.5, location=location)
    material = bpy.data.materials.new("glass")
    compat.enable_nodes(material)
    principled = next(node for node in material.node_tree.nodes if node.bl_idname == "ShaderNodeBsdfPrincipled")
    compat.principled_input(principled, "transmission").default_value = 1.0
    bpy.context.object.data.materials.append(material)


def tick(scene: bpy.types.Scene, *flags: str) -> None:
    view_layer = scene.view_layers[0]
    for flag in flags:
        setattr(view_layer, flag, True)


def save_multilayer(scene: bpy.types.Scene, path: Path) -> None:
    settings = scene.render.image_settings
    if hasattr(settings, "media_type"):  # Blender 5: the multilayer file is a media type of its own
        settings.media_type = "MULTI_LAYER_IMAGE"
    settings.file_format = "OPEN_EXR_MULTILAYER"
    settings.color_depth = "32"
    bpy.data.images["Render Result"].save_render(str(path))


def test_ticked_passes_hold_the_scenes_distances_normals_indices_and_add_up_to_combined(tmp_path: Path) -> None:
    scene = plane_and_cube_scene()
    tick(scene, "use_pass_z", "use_pass_normal", "use_pass_object_index", "use_pass_material_index", "use_pass_mist")
    tick(scene, "use_pass_diffuse_direct", "use_pass_glossy_direct", "use_pass_emit", "use_pass_environment")
    own = scene.view_layers[0].weathervane  # the engine's own boxes, on the view layer as Blender's
    own.use_pass_ambient = own.use_pass_reflection = own.use_pass_transmission = True
    add_glass_ball(location=(1.8, 1.2, 0.5))  # off the pixels checked below: the Transmission pass has a share
    scene.world.mist_settings.start, scene.world.mist_settings.depth = 1.0, 10.0
    scene.world.mist_settings.falloff = "LINEAR"
    bpy.ops.render.render()
    save_multilayer(scene, tmp_path / "passes.exr")
    channels, _ = read_exr(tmp_path / "passes.exr", tmp_path)
    depth = channels["ViewLayer.Depth.Z"]
    # rows bottom-up in the file as in Blender: the image's centre is the cube's top, its corners the plane
    assert depth.shape == (48, 64)
    assert abs(depth[24, 32] - 3.0) < 1e-4 and abs(depth[0, 0] - 5.0) < 1e-4 and abs(depth[47, 63] - 5.0) < 1e-4
    for axis, value in zip("XYZ", (0.0, 0.0, 1.0), strict=True):
        normal = channels[f"ViewLayer.Normal.{axis}"]
        assert abs(normal[24, 32] - value) < 1e-5 and abs(normal[0, 0] - value) < 1e-5
    index = channels[f"ViewLayer.{blender_name('IndexOB')}.X"]
    assert index[24, 32] == 9.0 and index[0, 0] == 4.0
    assert (
        channels[f"ViewLayer.{blender_name('IndexMA')}.X"][24, 32] == 6.0
        and channels[f"ViewLayer.{blender_name('IndexMA')}.X"][0, 0] == 0.0
    )
    mist = channels["ViewLayer.Mist.Z"]
    distance = 3.0  # straight down to the cube's top at the centre
    assert abs(mist[24, 32] - (distance - 1.0) / 10.0) < 1e-4
    for letter in "RGB":
        total = sum(channels[f"ViewLayer.{name}.{letter}"].astype(np.float64) for name in WHITTED)
        assert np.allclose(total, channels[f"ViewLayer.Combined.{letter}"], atol=2e-6), letter
    transmitted = channels["ViewLayer.Transmission.G"]
    # the ball's pixels, not the cube's; dim: the ground it shows is shadowed by the ball from the lamp and the world
    assert (transmitted > 0.001).sum() > 10 and transmitted[24, 32] == 0.0


def test_cryptomatte_picks_each_object_as_its_coverage(tmp_path: Path) -> None:
    """A matte read from the saved EXR alone (the specification's decoding: each rank's id equal to the name's
    hash adds its coverage) equals the object's coverage, seen in the Object Index pass."""
    from tracer.tracing.cryptomatte import name_hash

    scene = plane_and_cube_scene()
    scene.weathervane.samples = "4"
    tick(scene, "use_pass_cryptomatte_object", "use_pass_object_index")
    bpy.ops.render.render()
    save_multilayer(scene, tmp_path / "crypto.exr")
    channels, header = read_exr(tmp_path / "crypto.exr", tmp_path)
    manifests = [json.loads(value) for key, value in header.items() if key.endswith("/manifest")]
    assert manifests and {"Plane", "Cube"} <= set(manifests[0])
    for name, index in (("Cube", 9.0), ("Plane", 4.0)):
        target = np.float32(name_hash(name)[1])
        matte = np.zeros((48, 64))
        for layer in ("00", "01", "02"):  # Blender's default levels, 6: three layers
            for id_letter, coverage_letter in (("r", "g"), ("b", "a")):
                ids = channels[f"ViewLayer.CryptoObject{layer}.{id_letter}"].astype(np.float32)
                matte += np.where(ids == target, channels[f"ViewLayer.CryptoObject{layer}.{coverage_letter}"], 0.0)
        # the centre sample's object (the Object Index pass) has some coverage, and full coverage inside the object
        first = channels[f"ViewLayer.{blender_name('IndexOB')}.X"] == index
        assert np.all(matte[first] > 0.0)
        inner = first & (matte == 1.0)
        assert inner.sum() > 0.9 * first.sum() - 2 * (64 + 48)  # all but a silhouette's width of pixels


def test_a_ticked_pass_the_tracer_cannot_make_is_named_in_the_warning(capfd: pytest.CaptureFixture) -> None:
    scene = plane_and_cube_scene()
    tick(scene, "use_pass_vector", "use_pass_uv", "use_pass_z")
    bpy.ops.render.render()
    printed = capfd.readouterr()
    assert "does not render: Vector pass, UV pass" in printed.out + printed.err


def test_passes_go_over_without_lists_where_blender_takes_only_lists(tmp_path: Path, monkeypatch) -> None:
    """Blender 3.4's passes take only Python lists (0.5 s a channel at 1920x1080): there the image and the passes
    go in through one multilayer OpenEXR file Blender reads itself, and no pass is written as a list; Blender 4+
    takes an array a pass."""
    from addon.convert import pass_map
    from addon.engine import engine

    calls, write_passes = [], pass_map.write_passes
    monkeypatch.setattr(pass_map, "write_passes", lambda *args, fast: calls.append(fast) or write_passes(*args, fast))
    scene = plane_and_cube_scene()
    tick(scene, "use_pass_z", "use_pass_normal", "use_pass_cryptomatte_object")
    bpy.ops.render.render()
    save_multilayer(scene, tmp_path / "passes.exr")
    channels, _ = read_exr(tmp_path / "passes.exr", tmp_path)
    assert (
        abs(channels["ViewLayer.Depth.Z"][24, 32] - 3.0) < 1e-4 and abs(channels["ViewLayer.Normal.Z"][0, 0] - 1) < 1e-5
    )
    assert channels["ViewLayer.CryptoObject00.g"][24, 32] == 1.0  # the cube's whole coverage, rank 0
    assert calls == ([] if engine._FAST_WRITE == [False] else [True])


def test_the_passes_take_the_names_cycles_gives_them_in_this_blender(tmp_path: Path) -> None:
    """A compositor set up with Cycles reads the engine's passes by the same names: Blender 5 renamed them (Object
    Index, Diffuse Direct, ...), 3.4-4.5 keep IndexOB, DiffDir, ... The truth is Cycles' own multilayer file."""
    scene = plane_and_cube_scene()
    tick(scene, "use_pass_z", "use_pass_mist", "use_pass_normal", "use_pass_position", "use_pass_object_index")
    tick(scene, "use_pass_material_index", "use_pass_diffuse_direct", "use_pass_glossy_direct", "use_pass_emit")
    tick(scene, "use_pass_environment", "use_pass_cryptomatte_object", "use_pass_cryptomatte_material")
    names = {}
    for engine in ("CYCLES", "WEATHERVANE_TRACER"):
        scene.render.engine = engine
        scene.cycles.samples, scene.cycles.use_denoising = 1, False
        bpy.ops.render.render()
        save_multilayer(scene, tmp_path / f"{engine}.exr")
        channels, _ = read_exr(tmp_path / f"{engine}.exr", tmp_path)
        names[engine] = {name.rsplit(".", 1)[0] for name in channels} - {"ViewLayer.Noisy Image"}
    assert names["WEATHERVANE_TRACER"] == names["CYCLES"], names["WEATHERVANE_TRACER"] ^ names["CYCLES"]


def _cryptomatte_of(channels: dict[str, np.ndarray], header: dict[str, str]) -> tuple[set, dict, set]:
    """A multilayer file's Cryptomatte: its channel names, each layer's manifest names (by the layer's name) and the
    names whose IDs its pixels hold (by the manifest)."""
    names = {name for name in channels if ".Crypto" in name}
    manifests = {
        header[key[: -len("manifest")] + "name"]: json.loads(value)
        for key, value in header.items()
        if key.startswith("cryptomatte/") and key.endswith("/manifest")
    }
    by_id = {int(hex_id, 16): name for manifest in manifests.values() for name, hex_id in manifest.items()}
    seen = set()
    for name in names:
        if name.endswith((".r", ".b")):  # the ranks' IDs
            bits = channels[name].astype(np.float32).view(np.uint32)
            seen |= {by_id.get(int(value), f"{int(value):08x}") for value in np.unique(bits) if value}
    return names, {layer: set(manifest) for layer, manifest in manifests.items()}, seen


@pytest.mark.parametrize("levels", [2, 6, 10])
def test_cryptomatte_has_cycles_layers_channels_and_manifests_at_the_view_layers_levels(tmp_path: Path, levels) -> None:
    """Cycles' own multilayer file is the truth: (levels + 1) // 2 RGBA layers per pass with channels r, g, b, a, the
    objects under their Blender names (an instanced object's: its own, not the instancer's), the materials under
    theirs ("default_surface" for faces without one) after Cycles' own shaders, the same names in the pixels. Cycles
    also lists a light's shader ("shader") and, from 4.5, its lights and its world's light ("object"): things the
    engine draws no pixel of."""
    from addon import compat

    scene = plane_and_cube_scene()  # the plane has no material, the cube "red"; a point light and a world
    things = bpy.data.collections.new("Things")
    bpy.ops.mesh.primitive_uv_sphere_add(radius=0.4, segments=8, ring_count=4, location=(0.0, 0.0, 50.0))
    ball = bpy.context.object
    for collection in ball.users_collection:
        collection.objects.unlink(ball)
    things.objects.link(ball)
    holder = bpy.data.objects.new("Holder", None)  # the ball instanced beside the cube
    holder.instance_type, holder.instance_collection = "COLLECTION", things
    holder.location = (1.8, 1.0, -49.6)
    scene.collection.objects.link(holder)
    scene.render.resolution_x, scene.render.resolution_y = 32, 24
    tick(scene, "use_pass_cryptomatte_object", "use_pass_cryptomatte_material")
    scene.view_layers[0].pass_cryptomatte_depth = levels
    found = {}
    for engine in ("CYCLES", "WEATHERVANE_TRACER"):
        scene.render.engine = engine
        scene.cycles.samples, scene.cycles.use_denoising, scene.cycles.device = 1, False, "CPU"
        bpy.ops.render.render()
        save_multilayer(scene, tmp_path / f"{engine}.exr")
        found[engine] = _cryptomatte_of(*read_exr(tmp_path / f"{engine}.exr", tmp_path))
    (cycles_channels, cycles_manifests, cycles_seen), (channels, manifests, seen) = found.values()
    layers = (levels + 1) // 2
    assert (
        channels
        == cycles_channels
        == {
            f"ViewLayer.Crypto{kind}{layer:02d}.{channel}"
            for kind in ("Object", "Material")
            for layer in range(layers)
            for channel in "rgba"
        }
    )
    lights = {obj.name for obj in scene.objects if obj.type == "LIGHT"}
    extra_objects = lights | {"object"} if compat.VERSION >= (4, 5, 0) else set()
    assert manifests["ViewLayer.CryptoObject"] == cycles_manifests["ViewLayer.CryptoObject"] - extra_objects
    assert manifests["ViewLayer.CryptoObject"] == {"Plane", "Cube", "Sphere"}
    assert manifests["ViewLayer.CryptoMaterial"] == cycles_manifests["ViewLayer.CryptoMaterial"] - {"shader"}
    assert seen == cycles_seen == {"Plane", "Cube", "Sphere", "red", "default_surface"}


def test_the_engines_own_pass_boxes_belong_to_each_view_layer() -> None:
    from addon.convert import pass_map

    scene = plane_and_cube_scene()
    first = scene.view_layers[0]
    second = scene.view_layers.new("Second")
    first.weathervane.use_pass_transmission = True
    second.weathervane.use_pass_ambient = True
    assert pass_map.wanted(scene, first) == ("transmission",)
    assert pass_map.wanted(scene, second) == ("ambient",)
