"""JSON scene files -> Scene, with one clear message per problem (`objects[3].radius: must be > 0, got -1`)."""

from __future__ import annotations

import json
import math
from importlib import resources
from pathlib import Path
from typing import Any

from . import motion as mo
from . import scene as sc
from . import wind as wi

DEFAULT_SCENE_RESOURCE = "default_scene.json"


class SceneError(ValueError):
    """A scene that cannot be used; problems holds one 'field.path: what was expected, got X' line each."""

    def __init__(self, problems: list[str], source: str = "scene") -> None:
        self.problems = problems
        self.source = source
        super().__init__("\n".join(f"{source}: {problem}" for problem in problems))


def _show(value: Any) -> str:
    if isinstance(value, str):
        return json.dumps(value)
    if isinstance(value, bool) or value is None:
        return json.dumps(value)
    if isinstance(value, float) and value.is_integer() and abs(value) < 1e15:
        return str(int(value))
    if isinstance(value, int | float):
        return repr(value)
    return type(value).__name__ if isinstance(value, dict | list) else repr(value)


class _Reader:
    """Reads the fields of one JSON object, records problems by path and returns usable fallbacks."""

    def __init__(self, data: Any, path: str, problems: list[str]) -> None:
        self.path = path
        self.problems = problems
        self.data = data if isinstance(data, dict) else {}
        self.seen: set[str] = set()
        if not isinstance(data, dict):
            self.fail("", f"must be an object, got {_show_shape(data)}")

    def at(self, key: str) -> str:
        if not key:
            return self.path or "(top level)"
        return f"{self.path}.{key}" if self.path else key

    def fail(self, key: str, message: str) -> None:
        self.problems.append(f"{self.at(key)}: {message}")

    def raw(self, key: str, default: Any = ..., required: bool = False) -> Any:
        """The raw value; a missing field is reported when it has no default (returns ...)."""
        self.seen.add(key)
        if key in self.data:
            return self.data[key]
        if required or default is ...:
            self.fail(key, "is required")
            return ...
        return default

    def number(
        self,
        key: str,
        default: Any = ...,
        *,
        low: float | None = None,
        high: float | None = None,
        low_open: bool = False,
        integer: bool = False,
    ) -> Any:
        if key not in self.data:
            value = self.raw(key, default)
            return _fallback_number(low) if value is ... else value
        value = self.raw(key)
        if value is None and default is None:  # an optional number written as null
            return None
        return self.check_number(key, value, low=low, high=high, low_open=low_open, integer=integer)

    def check_number(
        self,
        key: str,
        value: Any,
        *,
        low: float | None = None,
        high: float | None = None,
        low_open: bool = False,
        integer: bool = False,
    ) -> Any:
        kind = "an integer" if integer else "a number"
        if isinstance(value, bool) or not isinstance(value, int | float):
            self.fail(key, f"must be {kind}, got {_show_shape(value)}")
            return _fallback_number(low)
        if not math.isfinite(value):
            self.fail(key, f"must be a finite number, got {_show(value)}")
            return _fallback_number(low)
        if integer and not float(value).is_integer():
            self.fail(key, f"must be an integer, got {_show(value)}")
            return int(value)
        if low is not None and (value <= low if low_open else value < low):
            self.fail(key, f"must be {'>' if low_open else '>='} {_show(low)}, got {_show(value)}")
        elif high is not None and value > high:
            self.fail(key, f"must be <= {_show(high)}, got {_show(value)}")
        return int(value) if integer else float(value)

    def vector(
        self,
        key: str,
        default: Any = ...,
        *,
        length: int = 3,
        low: float | None = None,
        high: float | None = None,
        low_open: bool = False,
        nonzero: bool = False,
    ) -> Any:
        if key not in self.data:
            value = self.raw(key, default)
            return (0.0,) * length if value is ... else value
        value = self.raw(key)
        if not isinstance(value, list) or len(value) != length:
            self.fail(key, f"must be a list of {length} numbers, got {_show_shape(value)}")
            return (0.0,) * length
        items = tuple(
            self.check_number(f"{key}[{i}]", item, low=low, high=high, low_open=low_open)
            for i, item in enumerate(value)
        )
        if nonzero and all(isinstance(item, float) and item == 0.0 for item in items):
            self.fail(key, "must not be the zero vector, got [0, 0, 0]")
        return items

    def color(self, key: str, default: Any = ...) -> Any:
        return self.vector(key, default, low=0.0, high=1.0)

    def choice(self, key: str, options: tuple[str, ...], default: Any = ...) -> Any:
        if key not in self.data:
            value = self.raw(key, default)
            return options[0] if value is ... else value
        value = self.raw(key)
        if value not in options:
            listed = ", ".join(json.dumps(option) for option in options)
            self.fail(key, f"must be one of {listed}, got {_show(value)}")
            return options[0]
        return value

    def string(self, key: str, default: Any = ...) -> Any:
        if key not in self.data:
            value = self.raw(key, default)
            return "" if value is ... else value
        value = self.raw(key)
        if not isinstance(value, str) or not value:
            self.fail(key, f"must be a non-empty string, got {_show(value)}")
            return ""
        return value

    def boolean(self, key: str, default: bool) -> bool:
        value = self.raw(key, default)
        if not isinstance(value, bool):
            self.fail(key, f"must be true or false, got {_show(value)}")
            return default
        return value

    def reader(self, key: str, required: bool = False) -> _Reader | None:
        value = self.raw(key, None, required=required)
        if value is None or value is ...:
            return None
        return _Reader(value, self.at(key), self.problems)

    def finish(self) -> None:
        for key in self.data:
            if key not in self.seen:
                self.fail(key, "is not a known field")


def _json_type(value: Any) -> str:
    names = {bool: "boolean", int: "number", float: "number", str: "string", list: "list", dict: "object"}
    return "null" if value is None else names.get(type(value), type(value).__name__)


def _show_shape(value: Any) -> str:
    """What a wrong value is, for messages: 'a list of 2', 'an object', 'null', 'string "x"', 'boolean true'."""
    if isinstance(value, list):
        return f"a list of {len(value)}"
    if isinstance(value, dict):
        return "an object"
    if value is None:
        return "null"
    return f"{_json_type(value)} {_show(value)}"


def _fallback_number(low: float | None) -> float:
    return 1.0 if low is None else max(1.0, low + 1.0)


# ---- sections ----------------------------------------------------------------------------------------------------


def _material(reader: _Reader) -> sc.Material:
    material = sc.Material(
        color=reader.color("color"),
        specular=reader.number("specular", 0.0, low=0.0),
        reflective=reader.number("reflective", 0.0, low=0.0, high=1.0),
    )
    reader.finish()
    return material


def _object(reader: _Reader, materials: dict[str, sc.Material], index: int) -> sc.SceneObject | None:
    kinds = ("sphere", "plane", "cylinder", "box", "pyramid", "mesh")
    kind = reader.choice("type", kinds, None)
    if kind is None and "type" not in reader.data:
        reader.fail("type", f"is required (one of {', '.join(kinds)})")
    name = reader.string("name", f"object{index}")
    material = reader.string("material")
    if material and materials and material not in materials:
        reader.fail(
            "material", f"must name one of the materials ({', '.join(sorted(materials))}), got {_show(material)}"
        )
    common = {
        "name": name,
        "material": material,
        "location": reader.vector("location", (0.0, 0.0, 0.0)),
        "rotation": reader.vector("rotation", (0.0, 0.0, 0.0)),
    }
    result: sc.SceneObject | None = None
    if kind == "sphere":
        result = sc.Sphere(radius=reader.number("radius", low=0.0, low_open=True), **common)
    elif kind == "plane":
        size = reader.vector("size", None, length=2, low=0.0, low_open=True)
        result = sc.Plane(size=size, **common)
    elif kind == "cylinder":
        result = sc.Cylinder(
            radius=reader.number("radius", low=0.0, low_open=True),
            height=reader.number("height", low=0.0, low_open=True),
            **common,
        )
    elif kind == "box":
        result = sc.Box(size=reader.vector("size", low=0.0, low_open=True), **common)
    elif kind == "pyramid":
        result = sc.Pyramid(size=reader.vector("size", low=0.0, low_open=True), **common)
    elif kind == "mesh":
        result = _mesh(reader, common)
    reader.finish()
    return result


def _mesh(reader: _Reader, common: dict[str, Any]) -> sc.TriangleMesh:
    raw_vertices = reader.raw("vertices")
    raw_triangles = reader.raw("triangles")
    vertices: list[sc.Vec3] = []
    triangles: list[tuple[int, int, int]] = []
    if raw_vertices is not ...:
        if not isinstance(raw_vertices, list) or not raw_vertices:
            reader.fail("vertices", f"must be a non-empty list of [x, y, z], got {_show_shape(raw_vertices)}")
        else:
            holder = _Reader({f"vertices[{i}]": v for i, v in enumerate(raw_vertices)}, reader.path, reader.problems)
            vertices = [holder.vector(f"vertices[{i}]") for i in range(len(raw_vertices))]
    if raw_triangles is not ...:
        if not isinstance(raw_triangles, list) or not raw_triangles:
            reader.fail("triangles", f"must be a non-empty list of [i, j, k], got {_show_shape(raw_triangles)}")
        else:
            for i, triangle in enumerate(raw_triangles):
                key = f"triangles[{i}]"
                valid = isinstance(triangle, list) and len(triangle) == 3
                if valid and all(
                    isinstance(k, int) and not isinstance(k, bool) and 0 <= k < len(vertices) for k in triangle
                ):
                    triangles.append((triangle[0], triangle[1], triangle[2]))
                else:
                    reader.fail(
                        key,
                        f"must be 3 vertex indices in 0..{len(vertices) - 1}, got {_show(triangle)}"
                        if valid
                        else f"must be a list of 3 vertex indices, got {_show_shape(triangle)}",
                    )
    for i, (a, b, c) in enumerate(triangles):
        edge1 = [vertices[b][k] - vertices[a][k] for k in range(3)]
        edge2 = [vertices[c][k] - vertices[a][k] for k in range(3)]
        normal = (
            edge1[1] * edge2[2] - edge1[2] * edge2[1],
            edge1[2] * edge2[0] - edge1[0] * edge2[2],
            edge1[0] * edge2[1] - edge1[1] * edge2[0],
        )
        if normal == (0.0, 0.0, 0.0):
            reader.fail(f"triangles[{i}]", f"must span an area (its vertices {a}, {b}, {c} are on one line)")
    return sc.TriangleMesh(vertices=tuple(vertices), triangles=tuple(triangles), **common)


def _light(reader: _Reader) -> sc.Light | None:
    kind = reader.choice("type", ("ambient", "point", "directional"), None)
    if kind is None and "type" not in reader.data:
        reader.fail("type", "is required (one of ambient, point, directional)")
    intensity = reader.number("intensity", low=0.0)
    result: sc.Light | None = None
    if kind == "ambient":
        result = sc.AmbientLight(intensity=intensity)
    elif kind == "point":
        result = sc.PointLight(location=reader.vector("location"), intensity=intensity)
    elif kind == "directional":
        result = sc.DirectionalLight(direction=reader.vector("direction", nonzero=True), intensity=intensity)
    reader.finish()
    return result


def _camera(reader: _Reader | None) -> sc.Camera:
    if reader is None:
        return sc.Camera()
    base = sc.Camera()
    sensor_width = reader.number("sensor_width", base.sensor_width, low=0.0, low_open=True)
    sensor_height = reader.number("sensor_height", base.sensor_height, low=0.0, low_open=True)
    sensor_fit = reader.choice("sensor_fit", sc.SENSOR_FITS, base.sensor_fit)
    lens = reader.number("lens", base.lens, low=0.0, low_open=True)
    fov = reader.number("fov", None, low=0.0, low_open=True, high=179.0)
    if "lens" in reader.data and "fov" in reader.data:
        reader.fail("fov", "give either lens or fov, not both")
    elif fov is not None and isinstance(fov, float) and 0.0 < fov <= 179.0:
        # Blender's camera.angle: the fitted sensor side (height for VERTICAL, width otherwise) spans fov.
        sensor = sensor_height if sensor_fit == "VERTICAL" else sensor_width
        lens = sensor / 2.0 / math.tan(math.radians(fov) / 2.0)
    camera = sc.Camera(
        location=reader.vector("location", base.location),
        rotation=reader.vector("rotation", base.rotation),
        lens=lens,
        sensor_width=sensor_width,
        sensor_height=sensor_height,
        sensor_fit=sensor_fit,
    )
    reader.finish()
    return camera


def _background(reader: _Reader | None) -> sc.Background:
    if reader is None:
        return sc.Background()
    base = sc.Background()
    background = sc.Background(
        type=reader.choice("type", sc.BACKGROUNDS, base.type),
        color=reader.color("color", base.color),
        horizon=reader.color("horizon", base.horizon),
        zenith=reader.color("zenith", base.zenith),
    )
    reader.finish()
    return background


def _render(reader: _Reader | None) -> sc.RenderSettings:
    if reader is None:
        return sc.RenderSettings()
    base = sc.RenderSettings()
    settings = sc.RenderSettings(
        width=reader.number("width", base.width, low=1, high=16384, integer=True),
        height=reader.number("height", base.height, low=1, high=16384, integer=True),
        depth=reader.number("depth", base.depth, low=0, high=64, integer=True),
        model=reader.choice("model", sc.MODELS, base.model),
        coef=reader.number("coef", base.coef, low=0.0, low_open=True),
        samples=reader.number("samples", base.samples, low=1, high=1024, integer=True),
        workers=reader.number("workers", base.workers, low=0, high=256, integer=True),
        dtype=reader.choice("dtype", sc.DTYPES, base.dtype),
        seed=reader.number("seed", base.seed, low=0, high=2**32 - 1, integer=True),
        gate_specular=reader.boolean("gate_specular", base.gate_specular),
        numerics=reader.choice("numerics", sc.NUMERICS, base.numerics),
    )
    samples_problem = check_samples(settings.samples)
    if samples_problem and "samples" in reader.data and isinstance(reader.data["samples"], int):
        reader.fail("samples", samples_problem)
    reader.finish()
    return settings


def check_samples(samples: int) -> str | None:
    """None when samples per pixel is usable, else what is wrong (it must be a perfect square: 1, 4, 9, 16...)."""
    if samples >= 1 and math.isqrt(samples) ** 2 == samples:
        return None
    return f"must be a perfect square (1, 4, 9, 16, ...) for the stratified grid, got {samples}"


def _vane(reader: _Reader | None, object_names: set[str]) -> sc.Vane | None:
    if reader is None:
        return None
    parts = reader.raw("parts")
    names: list[str] = []
    if parts is not ...:
        if not isinstance(parts, list) or not parts:
            reader.fail("parts", f"must be a non-empty list of object names, got {_show_shape(parts)}")
        else:
            for i, part in enumerate(parts):
                if not isinstance(part, str) or part not in object_names:
                    reader.fail(f"parts[{i}]", f"must name an object of the scene, got {_show(part)}")
                else:
                    names.append(part)
    vane = sc.Vane(
        parts=tuple(names),
        pivot=reader.vector("pivot", (0.0, 0.0, 0.0)),
        axis=reader.vector("axis", (0.0, 0.0, 1.0), nonzero=True),
        heading=reader.number("heading", 0.0),
        name=reader.string("name", "vane"),
    )
    reader.finish()
    return vane


def _wind(reader: _Reader | None) -> wi.Wind:
    if reader is None:
        return wi.Wind()
    keys: list[wi.WindKey] = []
    raw_keys = reader.raw("keys", None)
    constant = "direction" in reader.data or "speed" in reader.data
    if raw_keys is not None and constant:
        reader.fail("keys", "give either keys or a constant direction and speed, not both")
    elif raw_keys is not None:
        if not isinstance(raw_keys, list) or not raw_keys:
            reader.fail("keys", f"must be a non-empty list of {{time, direction, speed}}, got {_show_shape(raw_keys)}")
        else:
            for i, body in enumerate(raw_keys):
                key_reader = _Reader(body, reader.at(f"keys[{i}]"), reader.problems)
                key = wi.WindKey(
                    time=key_reader.number("time", low=0.0),
                    direction=key_reader.number("direction", low=0.0, high=360.0),
                    speed=key_reader.number("speed", low=0.0, high=60.0),
                )
                key_reader.finish()
                if keys and key.time <= keys[-1].time and "time" in key_reader.data:
                    key_reader.fail(
                        "time", f"must be after the previous key's time ({_show(keys[-1].time)}), got {_show(key.time)}"
                    )
                keys.append(key)
    else:
        base = wi.Wind().keys[0]
        keys.append(
            wi.WindKey(
                0.0,
                reader.number("direction", base.direction, low=0.0, high=360.0),
                reader.number("speed", base.speed, low=0.0, high=60.0),
            )
        )
    gusts = None
    gust_reader = reader.reader("gusts")
    if gust_reader is not None:
        gusts = wi.Gusts(
            intensity=gust_reader.number("intensity", 0.2, low=0.0, high=1.0),
            time_scale=gust_reader.number("time_scale", 2.0, low=0.0, low_open=True),
            seed=gust_reader.number("seed", 0, low=0, high=2**32 - 1, integer=True),
        )
        gust_reader.finish()
    start = reader.number("start", 0.0, low=0.0)
    stop = reader.number("stop", None, low=0.0)
    if stop is not None and isinstance(start, float) and isinstance(stop, float) and stop <= start:
        reader.fail("stop", f"must be after start ({_show(start)}), got {_show(stop)}")
    wind = wi.Wind(keys=tuple(keys) or wi.Wind().keys, gusts=gusts, start=start, stop=stop)
    reader.finish()
    return wind


def _spin(reader: _Reader | None) -> mo.Spin:
    if reader is None:
        return mo.Spin()
    base = mo.Spin()
    start = reader.number("start", base.start, low=0.0)
    stop = reader.number("stop", None, low=0.0)
    if stop is not None and isinstance(start, float) and isinstance(stop, float) and stop < start:
        reader.fail("stop", f"must not be before start ({_show(start)}), got {_show(stop)}")
    spin = mo.Spin(
        direction=reader.choice("direction", ("clockwise", "counterclockwise"), base.direction),
        speed=reader.number("speed", base.speed, low=0.0, high=3600.0),
        smoothness=reader.number("smoothness", base.smoothness, low=0.0),
        start=start,
        stop=stop,
    )
    reader.finish()
    return spin


def _motion(reader: _Reader | None, wind_reader: _Reader | None) -> mo.Motion | None:
    if reader is None and wind_reader is None:
        return None
    wind = _wind(wind_reader)
    if reader is None:
        return mo.Motion(wind=wind)
    base = mo.Motion()
    motion = mo.Motion(
        mode=reader.choice("mode", ("wind", "spin"), base.mode),
        damping=reader.number("damping", base.damping, low=0.0, low_open=True, high=5.0),
        wavelength=reader.number("wavelength", base.wavelength, low=0.0, low_open=True),
        threshold=reader.number("threshold", base.threshold, low=0.0),
        friction_time=reader.number("friction_time", base.friction_time, low=0.0, low_open=True),
        initial_heading=reader.number("initial_heading", None),
        fps=reader.number("fps", base.fps, low=0.0, low_open=True, high=1000.0),
        wind=wind,
        spin=_spin(reader.reader("spin")),
    )
    reader.finish()
    return motion


# ---- entry points ------------------------------------------------------------------------------------------------


def scene_from_dict(data: Any, source: str = "scene") -> sc.Scene:
    """Validate a parsed JSON document and build the Scene; raises SceneError listing every problem."""
    problems: list[str] = []
    top = _Reader(data, "", problems)
    if problems:
        raise SceneError(problems, source)
    top.raw("$schema", None)
    top.raw("comment", None)

    materials: dict[str, sc.Material] = {}
    raw_materials = top.raw("materials")
    if raw_materials is not ...:
        if not isinstance(raw_materials, dict) or not raw_materials:
            top.fail("materials", f"must be a non-empty object of name: material, got {_show_shape(raw_materials)}")
        else:
            for name, body in raw_materials.items():
                materials[name] = _material(_Reader(body, f"materials.{name}", problems))

    objects: list[sc.SceneObject] = []
    raw_objects = top.raw("objects")
    if raw_objects is not ...:
        if not isinstance(raw_objects, list) or not raw_objects:
            top.fail("objects", f"must be a non-empty list of objects, got {_show_shape(raw_objects)}")
        else:
            for i, body in enumerate(raw_objects):
                made = _object(_Reader(body, f"objects[{i}]", problems), materials, i)
                if made is not None:
                    objects.append(made)
    names = [obj.name for obj in objects]
    for i, name in enumerate(names):
        if name in names[:i]:
            problems.append(f"objects[{i}].name: must be unique, got {_show(name)} twice")

    lights: list[sc.Light] = []
    raw_lights = top.raw("lights", [])
    if not isinstance(raw_lights, list):
        top.fail("lights", f"must be a list of lights, got {_show_shape(raw_lights)}")
    else:
        for i, body in enumerate(raw_lights):
            made_light = _light(_Reader(body, f"lights[{i}]", problems))
            if made_light is not None:
                lights.append(made_light)

    camera = _camera(top.reader("camera"))
    background = _background(top.reader("background"))
    render = _render(top.reader("render"))
    vane = _vane(top.reader("vane"), set(names))
    motion = _motion(top.reader("motion"), top.reader("wind"))
    top.finish()
    if problems:
        raise SceneError(problems, source)
    return sc.Scene(
        materials=materials,
        objects=tuple(objects),
        lights=tuple(lights),
        camera=camera,
        background=background,
        render=render,
        vane=vane,
        motion=motion,
    )


def load_scene(path: str | Path) -> sc.Scene:
    """Read and validate a JSON scene file; raises SceneError (unreadable file, bad JSON, bad fields)."""
    source = str(path)
    try:
        text = Path(path).read_text(encoding="utf-8")
    except OSError as error:
        raise SceneError([f"cannot read the file ({error.strerror or error})"], source) from None
    except UnicodeDecodeError:
        raise SceneError(["is not UTF-8 text"], source) from None
    try:
        data = json.loads(text, parse_constant=_reject_constant)
    except json.JSONDecodeError as error:
        raise SceneError([f"line {error.lineno} column {error.colno}: invalid JSON: {error.msg}"], source) from None
    except ValueError as error:
        raise SceneError([str(error)], source) from None
    return scene_from_dict(data, source)


def _reject_constant(name: str) -> float:
    raise ValueError(f"invalid JSON: {name} is not a number JSON allows")


def default_scene_dict() -> dict[str, Any]:
    """The embedded default weathervane as a JSON document."""
    text = resources.files(__package__).joinpath(DEFAULT_SCENE_RESOURCE).read_text(encoding="utf-8")
    return json.loads(text)


def default_scene() -> sc.Scene:
    """The embedded default weathervane, used when no scene file is given."""
    return scene_from_dict(default_scene_dict(), "default scene")
