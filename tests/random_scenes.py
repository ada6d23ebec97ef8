"""Seeded random scene documents that cover every primitive, rotation, light type, model, depth and background."""

from __future__ import annotations

import random
from typing import Any

KINDS = ("sphere", "cylinder", "box", "pyramid", "mesh", "plane")
BACKGROUNDS = ("solid", "sky", "documented", "none")


def _vector(rng: random.Random, low: float, high: float) -> list[float]:
    return [rng.uniform(low, high) for _ in range(3)]


def _object(rng: random.Random, kind: str, index: int) -> dict[str, Any]:
    body: dict[str, Any] = {
        "name": f"{kind}{index}",
        "type": kind,
        "material": f"m{rng.randrange(3)}",
        "location": [rng.uniform(-1.8, 1.8), rng.uniform(-1.0, 2.0), rng.uniform(-0.5, 1.5)],
        "rotation": _vector(rng, -180.0, 180.0),
    }
    if kind == "sphere":
        body["radius"] = rng.uniform(0.3, 1.0)
    elif kind == "cylinder":
        body.update(radius=rng.uniform(0.2, 0.7), height=rng.uniform(0.4, 2.0))
    elif kind in ("box", "pyramid"):
        body["size"] = _vector(rng, 0.3, 1.6)
    elif kind == "mesh":
        body["vertices"] = [_vector(rng, -0.8, 0.8) for _ in range(4)]
        body["triangles"] = [[0, 1, 2], [0, 2, 3], [1, 3, 2]]
    else:  # a floor or a wall, infinite or finite, tilted a little
        body["location"] = [0.0, 0.0, -1.0]
        body["rotation"] = [rng.uniform(-20, 20), rng.uniform(-20, 20), rng.uniform(0, 90)]
        if rng.random() < 0.5:
            body["size"] = [rng.uniform(3, 8), rng.uniform(3, 8)]
    return body


def random_scene_document(seed: int, width: int = 16, height: int = 12) -> dict[str, Any]:
    rng = random.Random(seed)
    kinds = [KINDS[seed % 5]] + [rng.choice(KINDS[:5]) for _ in range(rng.randrange(1, 4))]
    objects = [_object(rng, kind, i) for i, kind in enumerate(kinds)]
    if seed % 3 != 2:
        objects.append(_object(rng, "plane", len(objects)))
    lights: list[dict[str, Any]] = [{"type": "ambient", "intensity": rng.uniform(0.0, 0.3)}]
    for _ in range(rng.randrange(1, 3)):
        lights.append({"type": "point", "location": _vector(rng, -4, 5), "intensity": rng.uniform(0.2, 0.7)})
    if seed % 2 == 0:
        lights.append({"type": "directional", "direction": _vector(rng, -1, 1), "intensity": rng.uniform(0.1, 0.5)})
    materials = {
        f"m{k}": {
            "color": [rng.random() for _ in range(3)],
            "specular": rng.choice([0, 5, 50, 500]),
            "reflective": rng.choice([0.0, 0.2, 0.5, 0.9]),
        }
        for k in range(3)
    }
    return {
        "materials": materials,
        "objects": objects,
        "lights": lights,
        "camera": {
            "location": [rng.uniform(-1, 1), -7.0, rng.uniform(0.5, 2.5)],
            "rotation": [80, 0, 0],
            "lens": rng.choice([25, 35, 50]),
            "sensor_fit": rng.choice(["AUTO", "HORIZONTAL", "VERTICAL"]),
        },
        "background": {"type": BACKGROUNDS[seed % 4], "color": [0.1, 0.2, 0.3]},
        "render": {
            "width": width,
            "height": height,
            "depth": seed % 6,
            "model": ("phong", "blinn-phong")[(seed // 2) % 2],
            "coef": rng.choice([2, 3, 4]),
            "samples": 4 if seed % 7 == 0 else 1,
            "gate_specular": seed % 5 == 4,
            "seed": seed,
        },
    }


def extended_scene_document(seed: int, width: int = 16, height: int = 12) -> dict[str, Any]:
    """random_scene_document(seed) with the optional Blender fields (docs/scene-format.md) drawn at random: material
    emission, two_sided and specular_color; light colours, inverse-square falloff and spot lights of both models;
    objects' ray visibility and holdouts; mesh corner normals and per-triangle materials; a transparent film; a
    render border, cropped or not."""
    document = random_scene_document(seed, width, height)
    rng = random.Random(10_000 + seed)
    for material in document["materials"].values():
        if rng.random() < 0.4:
            material["emission"] = [rng.uniform(0.0, 0.3) for _ in range(3)]
        if rng.random() < 0.5:
            material["two_sided"] = True
        if rng.random() < 0.4:
            material["specular_color"] = [rng.uniform(0.5, 1.2) for _ in range(3)]
    for light in document["lights"]:
        if rng.random() < 0.6:
            light["color"] = [rng.uniform(0.2, 1.5) for _ in range(3)]
        if light["type"] == "point" and rng.random() < 0.5:
            light["falloff"] = "inverse_square"
            light["intensity"] *= 10.0
    for _ in range(rng.randrange(0, 3)):
        location = _vector(rng, -3, 4)
        target = [rng.uniform(-1, 1), rng.uniform(-0.5, 1.5), rng.uniform(-0.5, 1.0)]
        document["lights"].append(
            {
                "type": "spot",
                "location": location,
                "direction": [t - p for t, p in zip(target, location, strict=True)],
                "intensity": rng.uniform(0.3, 1.0),
                "color": [rng.uniform(0.3, 1.2) for _ in range(3)],
                "falloff": rng.choice(["none", "inverse_square"]),
                "spot_size": rng.uniform(20.0, 120.0),
                "spot_blend": rng.choice([0.0, 0.15, 0.6, 1.0]),
                "spot_model": rng.choice(["cycles4", "cycles3"]),
            }
        )
    stretch = random.Random(20_000 + seed)  # apart from rng: the documents above stay as they were
    for light in document["lights"]:
        if light["type"] == "spot" and stretch.random() < 0.5:  # Blender 4+'s spot scaled unevenly
            light["cone_scale"] = [stretch.uniform(0.3, 2.5), stretch.uniform(0.3, 2.5)]
            light["x_axis"] = _vector(stretch, -1.0, 1.0)
        if light["type"] != "ambient" and stretch.random() < 0.25:  # the light's ray visibility, one term off
            light[stretch.choice(["visible_diffuse", "visible_glossy", "visible_transmission"])] = False
    names = sorted(document["materials"])
    for body in document["objects"]:
        for flag in ("visible_camera", "visible_shadow", "visible_reflection"):
            if rng.random() < 0.15:
                body[flag] = False
        if rng.random() < 0.1:
            body["holdout"] = True
        if body["type"] == "mesh":
            if rng.random() < 0.7:
                body["normals"] = [[_vector(rng, -1, 1) for _ in range(3)] for _ in body["triangles"]]
            if rng.random() < 0.6:
                body["materials"] = rng.sample(names, 2)
                body["material_indices"] = [rng.randrange(2) for _ in body["triangles"]]
    if rng.random() < 0.4:
        document["render"]["film_transparent"] = True
    if rng.random() < 0.3:
        x, y = rng.uniform(0.0, 0.5), rng.uniform(0.0, 0.5)
        document["render"]["border"] = [x, y, x + rng.uniform(0.1, 0.5), y + rng.uniform(0.1, 0.5)]
        document["render"]["crop"] = rng.random() < 0.5
    return document


def see_through_scene_document(seed: int, width: int = 16, height: int = 12) -> dict[str, Any]:
    """extended_scene_document(seed) (random_scene_document(seed) for even seeds) with glass and transparency drawn
    at random on its materials (docs/scene-format.md): transmission 0, 1 or between, ior below 1, 1, water's,
    glass's or diamond's, alpha 1, 0 or between; at least one material see-through. A stream of its own, so the
    other fields are those of the scene it extends."""
    document = (extended_scene_document if seed % 2 else random_scene_document)(seed, width, height)
    rng = random.Random(30_000 + seed)
    materials = list(document["materials"].values())
    for index, material in enumerate(materials):
        if rng.random() < 0.6 or index == 0:
            material["transmission"] = rng.choice([1.0, rng.uniform(0.1, 0.9)])
            material["ior"] = rng.choice([0.7, 1.0, 1.33, 1.45, 2.4])
        if rng.random() < 0.45:
            material["alpha"] = rng.choice([0.0, rng.uniform(0.1, 0.9)])
    return document
