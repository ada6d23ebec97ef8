"""The add-on -> blend_templates/*.blend: the default vane, a gusty day's animation and a mirror studio.

    blender -b --factory-startup --python scripts/make_templates.py -- [--out blend_templates]
    python scripts/make_templates.py [--out blend_templates]          (the bpy wheel: files only 4.x/5.0 open)

Run it with the oldest supported Blender (Debian's 3.4.1) so that every supported Blender opens the files. Each
template is built by the add-on from a tracer scene, baked, set to render with the tracer engine, and saved.
"""

from __future__ import annotations

import argparse
import copy
import json
import sys
import tempfile
from pathlib import Path

ROOT = Path(__file__).resolve().parents[1]
sys.path.insert(0, str(ROOT))
sys.path.insert(0, str(ROOT / "scripts"))

import bpy  # noqa: E402

from tracer.scene.loader import default_scene_dict  # noqa: E402


def default_vane() -> dict:
    return default_scene_dict()


def gusty_day() -> dict:
    document = default_scene_dict()
    document["wind"] = {
        "keys": [
            {"time": 0, "direction": 240, "speed": 7},
            {"time": 2.0, "direction": 260, "speed": 11},
            {"time": 3.5, "direction": 330, "speed": 9},
            {"time": 5.0, "direction": 300, "speed": 12},
        ],
        "gusts": {"intensity": 0.3, "time_scale": 1.2, "seed": 11},
        "start": 0.0,
    }
    document["motion"]["damping"] = 0.3
    document["background"] = {"type": "sky", "horizon": [0.7, 0.74, 0.78], "zenith": [0.38, 0.45, 0.55]}
    return document


def mirror_studio() -> dict:
    document = copy.deepcopy(default_scene_dict())
    document["materials"].update(
        {
            "mirror": {"color": [0.9, 0.92, 0.95], "specular": 500, "reflective": 0.85},
            "floor": {"color": [0.2, 0.2, 0.22], "specular": 50, "reflective": 0.5},
        }
    )
    for name in ("brass", "copper"):
        document["materials"][name]["reflective"] = 0.6
    document["objects"][0].update({"material": "floor", "size": [12, 12]})
    document["objects"] += [
        {
            "name": "mirror_back",
            "type": "plane",
            "material": "mirror",
            "location": [0, 3.0, 2.5],
            "rotation": [90, 0, 0],
            "size": [8, 5],
        },
        {
            "name": "mirror_side",
            "type": "plane",
            "material": "mirror",
            "location": [-3.0, 0, 2.5],
            "rotation": [90, 0, 90],
            "size": [8, 5],
        },
    ]
    document["background"] = {"type": "solid", "color": [0.02, 0.02, 0.03]}
    document["render"]["depth"] = 5
    return document


TEMPLATES = {"default_vane": default_vane, "gusty_day": gusty_day, "mirror_studio": mirror_studio}


def make(name: str, document: dict, folder: Path, frames: int) -> Path:
    import addon

    bpy.ops.wm.read_factory_settings(use_empty=True)
    if not hasattr(bpy.types, "WEATHERVANE_OT_build"):
        addon.register()
    with tempfile.TemporaryDirectory() as scratch:
        scene_file = Path(scratch) / f"{name}.json"
        scene_file.write_text(json.dumps(document))
        if bpy.ops.weathervane.build(filepath=str(scene_file)) != {"FINISHED"}:
            sys.exit(f"error: {name}: the scene could not be built")
    scene = bpy.context.scene
    scene.frame_start, scene.frame_end = 1, frames
    bpy.ops.weathervane.bake()
    scene.frame_set(1)
    scene.render.engine = "WEATHERVANE_TRACER"
    scene.view_settings.view_transform = "Standard"
    target = folder / f"{name}.blend"
    with tempfile.TemporaryDirectory(dir=folder) as scratch:
        partial = Path(scratch) / target.name
        bpy.ops.wm.save_as_mainfile(filepath=str(partial), compress=True)
        partial.replace(target)
    return target


def main() -> None:
    from script_args import script_arguments

    argv = script_arguments()
    parser = argparse.ArgumentParser(prog="make_templates.py", description=__doc__.splitlines()[0])
    parser.add_argument("--out", type=Path, default=ROOT / "blend_templates")
    parser.add_argument("--frames", type=int, default=120)
    args = parser.parse_args(argv)
    args.out.mkdir(parents=True, exist_ok=True)
    for name, build in TEMPLATES.items():
        print(f"wrote {make(name, build(), args.out, args.frames)} (Blender {bpy.app.version_string})")


if __name__ == "__main__":
    main()
    sys.exit(0)  # see render_both.py: Blender 3.4's normal shutdown crashes after multiprocessing was imported
