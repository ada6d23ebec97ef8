"""Seeded generators of hostile scene documents: valid ones at the loader's limits, and malformed ones."""

from __future__ import annotations

import copy
import json
import random
from typing import Any

from tracer.scene import loader

EXTREME_LENGTHS = (loader.LENGTH_RANGE[0], 1e-3, 1.0, 1e3, 1e6, loader.LENGTH_RANGE[1])
EXTREME_COORDINATES = (0.0, 1e-9, 1.0, 1e6, loader.COORDINATE_LIMIT, -loader.COORDINATE_LIMIT)


def _pick(rng: random.Random, values: tuple) -> Any:
    return rng.choice(values) * rng.choice((1.0, 0.5, -1.0)) if rng.random() < 0.2 else rng.choice(values)


def _vector(rng: random.Random, values: tuple) -> list[float]:
    return [_pick(rng, values) for _ in range(3)]


def _length(rng: random.Random) -> float:
    return rng.choice(EXTREME_LENGTHS)


def extreme_scene(seed: int) -> dict[str, Any]:
    """A scene the loader accepts, with sizes, positions, intensities and angles at or near its limits."""
    rng = random.Random(seed)
    materials = {
        f"m{i}": {
            "color": [rng.choice((0.0, 1.0, rng.random())) for _ in range(3)],
            "specular": rng.choice((0.0, 1.0, 1e3, loader.SPECULAR_MAX)),
            "reflective": rng.choice((0.0, 0.5, 1.0)),
        }
        for i in range(3)
    }
    objects = []
    for i in range(rng.randint(1, 5)):
        kind = rng.choice(("sphere", "plane", "cylinder", "box", "pyramid", "mesh"))
        body: dict[str, Any] = {
            "type": kind,
            "name": f"o{i}",
            "material": f"m{rng.randrange(3)}",
            "location": _vector(rng, EXTREME_COORDINATES),
            "rotation": [rng.choice((0.0, 45.0, 90.0, 1e-7, loader.ANGLE_LIMIT)) for _ in range(3)],
        }
        if kind in ("sphere", "cylinder"):
            body["radius"] = _length(rng)
        if kind == "cylinder":
            body["height"] = _length(rng)
        if kind in ("box", "pyramid"):
            body["size"] = [_length(rng) for _ in range(3)]
        if kind == "plane" and rng.random() < 0.5:
            body["size"] = [_length(rng) for _ in range(2)]
        if kind == "mesh":
            scale = _length(rng)
            body["vertices"] = [[0, 0, 0], [scale, 0, 0], [0, scale, 0], [0, 0, scale]]
            body["triangles"] = [[0, 1, 2], [0, 1, 3], [0, 2, 3], [1, 2, 3]]
        objects.append(body)
    lights: list[dict[str, Any]] = [{"type": "ambient", "intensity": rng.choice((0.0, 0.2, loader.INTENSITY_MAX))}]
    for _ in range(rng.randint(0, 3)):
        if rng.random() < 0.5:
            lights.append(
                {"type": "point", "location": _vector(rng, EXTREME_COORDINATES), "intensity": rng.choice((0.5, 1e6))}
            )
        else:
            direction = [rng.choice((0.0, loader.DIRECTION_MIN_LENGTH, 1.0, -1.0, 1e9)) for _ in range(3)]
            if all(value == 0.0 for value in direction):
                direction[2] = 1.0
            lights.append({"type": "directional", "direction": direction, "intensity": rng.choice((0.5, 1e6))})
    camera: dict[str, Any] = {
        "location": _vector(rng, EXTREME_COORDINATES),
        "rotation": [rng.choice((0.0, 60.0, 90.0, 180.0, loader.ANGLE_LIMIT)) for _ in range(3)],
        "sensor_fit": rng.choice(("AUTO", "HORIZONTAL", "VERTICAL")),
    }
    if rng.random() < 0.5:
        camera["fov"] = rng.choice((loader.FOV_RANGE[0], 1.0, 90.0, loader.FOV_RANGE[1]))
    else:
        camera["lens"] = rng.choice((loader.LENS_RANGE[0], 50.0, loader.LENS_RANGE[1]))
    return {
        "materials": materials,
        "objects": objects,
        "lights": lights,
        "camera": camera,
        "background": {"type": rng.choice(("solid", "sky", "documented", "none"))},
        "render": {
            "width": rng.choice((1, 7, 16)),
            "height": rng.choice((1, 5, 12)),
            "depth": rng.choice((0, 3, 8)),
            "model": rng.choice(("phong", "blinn-phong")),
            "coef": rng.choice((0.01, 4.0, 100.0)),
            "dtype": rng.choice(("float32", "float64")),
            "numerics": rng.choice(("documented", "robust")),
            "gate_specular": rng.random() < 0.5,
            "workers": 1,
        },
    }


def _mutations(rng: random.Random) -> list[Any]:
    """Values that are wrong where a number, a list, an object or a string is expected."""
    return [
        None,
        True,
        "4",
        "",
        [],
        {},
        [1, 2],
        -1,
        0,
        1e308,
        -1e308,
        5e-324,
        10**400,
        "x" * 5000,
        [[[[]]]],
        {"nested": {"deeper": [1, {"x": None}]}},
        rng.random() * 1e12,
        -rng.random(),
    ]


def _paths(document: Any, prefix: tuple = ()) -> list[tuple]:
    found = [prefix] if prefix else []
    if isinstance(document, dict):
        for key, value in document.items():
            found += _paths(value, (*prefix, key))
    elif isinstance(document, list):
        for index, value in enumerate(document):
            found += _paths(value, (*prefix, index))
    return found


def hostile_text(seed: int, base: dict[str, Any]) -> str:
    """A scene file made from base by a few wrong values, deleted or added fields, or broken JSON text."""
    rng = random.Random(seed)
    document = copy.deepcopy(base)
    paths = _paths(document)
    for _ in range(rng.randint(1, 3)):
        path = rng.choice(paths)
        action = rng.random()
        try:
            holder = document
            for step in path[:-1]:  # an earlier change may have removed or replaced this path
                holder = holder[step]
            if action < 0.6:
                holder[path[-1]] = rng.choice(_mutations(rng))
            elif action < 0.8 and isinstance(holder, dict):
                del holder[path[-1]]
            elif isinstance(holder, dict):
                holder[f"unknown{rng.randrange(9)}"] = rng.choice(_mutations(rng))
        except (KeyError, IndexError, TypeError):
            pass
    text = json.dumps(document)
    roll = rng.random()
    if roll < 0.1:
        cut = rng.randrange(len(text))
        text = text[:cut]  # truncated
    elif roll < 0.15:
        text = text.replace(",", ", " + json.dumps("k") + ": 1, ", 1) if text.startswith("{") else text
    elif roll < 0.2:
        text = "[" * rng.choice((100, 2000, 100000)) + text
    elif roll < 0.25:
        text = text[:-1] + ', "materials": {}}'  # a duplicate key
    return text
