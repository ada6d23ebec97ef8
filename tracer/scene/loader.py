"""JSON scene files -> Scene, with one clear message per problem (`objects[3].radius: must be > 0, got -1`)."""

from __future__ import annotations

import json
import math
import stat
from dataclasses import replace
from importlib import resources
from pathlib import Path
from typing import Any

import numpy as np

from . import motion as mo
from . import scene as sc
from . import textures as tx
from . import wind as wi
from .passes import CRYPTOMATTE_LEVELS_MAX, PASSES
from .reuse import LoadedParts

DEFAULT_SCENE_RESOURCE = "default_scene.json"

# What the tracer renders to finite pixels in both precisions (docs/scene-format.md, "Limits"); beyond these the
# arithmetic overflows or divides by zero, so the loader refuses rather than render garbage or crash.
MAX_SCENE_BYTES = 256 << 20  # a scene file; read no further (a device or a huge file is refused before reading)
COORDINATE_LIMIT = 1e9  # metres: any position, |x| at most
LENGTH_RANGE = (1e-6, 1e9)  # metres: radii, heights, sizes
ANGLE_LIMIT = 1e6  # degrees: rotations and headings, |a| at most
DIRECTION_MIN_LENGTH = 1e-9  # a direction or axis shorter than this has no usable direction
INTENSITY_MAX = 1e6
TEXTURE_SCALE_MAX = 1e6  # a checker's scale, |s| at most (Blender's socket allows +-1000)
RAMP_STOPS_MAX = 32  # a colour ramp's stops, at most (Blender's colour band holds 32)
PASS_INDEX_MAX = 2**15 - 1  # Blender's pass_index range (a short)
IOR_MAX = 1000.0  # Blender's IOR sockets stop at 1000
MIST_FALLOFFS = ("QUADRATIC", "LINEAR", "INVERSE_QUADRATIC")  # Blender's World > Mist Pass > Falloff
SPECULAR_MAX = 1e6  # the specular exponent (and coef times it)
LENS_RANGE = (1e-3, 1e6)  # millimetres: lens and sensor sizes
FOV_RANGE = (1e-3, 179.0)  # degrees
SHIFT_LIMIT = 10.0  # Blender's lens shift range, in units of the fitted sensor side
PIXEL_ASPECT_RANGE = (1.0, 200.0)  # Blender's pixel_aspect_x and _y
POSES_MAX = 256  # motion blur's time slices (poses over the shutter), at most: each is a whole render
SHOWN_CHARACTERS = 60  # a value in a message is cut to about this many characters


class SceneError(ValueError):
    """A scene that cannot be used; problems holds one 'field.path: what was expected, got X' line each."""

    def __init__(self, problems: list[str], source: str = "scene") -> None:
        self.problems = problems
        self.source = source
        super().__init__("\n".join(f"{source}: {problem}" for problem in problems))


def _show(value: Any) -> str:
    shown = _show_whole(value)
    if len(shown) > SHOWN_CHARACTERS:
        return f"{shown[: SHOWN_CHARACTERS - 20]}...{shown[-10:]} ({len(shown)} characters)"
    return shown


def _show_whole(value: Any) -> str:
    if isinstance(value, int) and not isinstance(value, bool) and abs(value) >= 10**30:
        return f"an integer of {len(str(abs(value)))} digits"
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
        for key in getattr(data, "duplicates", ()):
            self.fail(key, "appears more than once in this object (JSON keeps only the last; remove the others)")

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
        least: float | None = None,
    ) -> Any:
        if key not in self.data:
            value = self.raw(key, default)
            return _fallback_number(low) if value is ... else value
        value = self.raw(key)
        if value is None and default is None:  # an optional number written as null
            return None
        return self.check_number(key, value, low=low, high=high, low_open=low_open, integer=integer, least=least)

    def check_number(
        self,
        key: str,
        value: Any,
        *,
        low: float | None = None,
        high: float | None = None,
        low_open: bool = False,
        integer: bool = False,
        least: float | None = None,
    ) -> Any:
        """least: a positive floor checked after low (a size must be > 0, and at least this to be rendered)."""
        kind = "an integer" if integer else "a number"
        if isinstance(value, bool) or not isinstance(value, int | float):
            self.fail(key, f"must be {kind}, got {_show_shape(value)}")
            return _fallback_number(low)
        if isinstance(value, int) and abs(value) > 2**1023:  # beyond any float: float(value) would overflow
            self.fail(key, f"must be a finite number, got {_show(value)}")
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
        elif least is not None and value < least:
            self.fail(key, f"must be at least {_show(least)} (the smallest the tracer renders), got {_show(value)}")
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
        least: float | None = None,
    ) -> Any:
        """nonzero: a direction, whose length must be at least DIRECTION_MIN_LENGTH."""
        if key not in self.data:
            value = self.raw(key, default)
            return (0.0,) * length if value is ... else value
        value = self.raw(key)
        if not isinstance(value, list) or len(value) != length:
            self.fail(key, f"must be a list of {length} numbers, got {_show_shape(value)}")
            return (0.0,) * length
        # the common case (finite floats within the limits) without a check_number per item: a material's colours,
        # thousands of objects' positions
        if all(type(item) is float and math.isfinite(item) for item in value):
            least_item, most_item = min(value), max(value)
            if (
                (low is None or (least_item > low if low_open else least_item >= low))
                and (high is None or most_item <= high)
                and (least is None or least_item >= least)
                and not nonzero
            ):
                return tuple(value)
        items = tuple(
            self.check_number(f"{key}[{i}]", item, low=low, high=high, low_open=low_open, least=least)
            for i, item in enumerate(value)
        )
        if nonzero and all(isinstance(item, float) and item == 0.0 for item in items):
            self.fail(key, "must not be the zero vector, got [0, 0, 0]")
        elif nonzero and all(isinstance(item, float) for item in items) and math.hypot(*items) < DIRECTION_MIN_LENGTH:
            self.fail(key, f"must have a length of at least {_show(DIRECTION_MIN_LENGTH)} to give a direction")
        return items

    def position(self, key: str, default: Any = ...) -> Any:
        return self.vector(key, default, low=-COORDINATE_LIMIT, high=COORDINATE_LIMIT)

    def angles(self, key: str, default: Any = ...) -> Any:
        return self.vector(key, default, low=-ANGLE_LIMIT, high=ANGLE_LIMIT)

    def length(self, key: str, default: Any = ...) -> Any:
        low, high = LENGTH_RANGE
        return self.number(key, default, low=0.0, low_open=True, high=high, least=low)

    def lengths(self, key: str, default: Any = ..., count: int = 3) -> Any:
        low, high = LENGTH_RANGE
        return self.vector(key, default, length=count, low=0.0, low_open=True, high=high, least=low)

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
    if isinstance(value, list | np.ndarray):
        return f"a list of {len(value)}"
    if isinstance(value, dict):
        return "an object"
    if value is None:
        return "null"
    return f"{_json_type(value)} {_show(value)}"


def _fallback_number(low: float | None) -> float:
    return 1.0 if low is None else max(1.0, low + 1.0)


# ---- sections ----------------------------------------------------------------------------------------------------


def _material(reader: _Reader, base: Path | None = None) -> sc.Material:
    texture = _texture(reader.reader("texture"), base)
    emission_texture = _texture(reader.reader("emission_texture"), base)
    material = sc.Material(
        color=reader.color("color"),
        specular=reader.number("specular", 0.0, low=0.0, high=SPECULAR_MAX),
        reflective=reader.number("reflective", 0.0, low=0.0, high=1.0),
        emission=reader.vector("emission", sc.BLACK, low=0.0, high=INTENSITY_MAX),
        two_sided=reader.boolean("two_sided", False),
        specular_color=reader.vector("specular_color", None, low=0.0, high=INTENSITY_MAX),
        pass_index=reader.number("pass_index", 0, low=0, high=PASS_INDEX_MAX, integer=True),
        texture=texture,
        emission_texture=emission_texture,
        transmission=reader.number("transmission", 0.0, low=0.0, high=1.0),
        ior=reader.number("ior", 1.45, low=0.0, low_open=True, high=IOR_MAX),
        alpha=reader.number("alpha", 1.0, low=0.0, high=1.0),
        glossy=reader.color("glossy", sc.BLACK),
        roughness=reader.number("roughness", 0.5, low=0.0, low_open=True, high=1.0),
        glossy_fresnel=reader.choice("glossy_fresnel", ("constant", "schlick"), "constant"),
        glossy_energy=reader.choice("glossy_energy", ("multiscatter", "single"), "multiscatter"),
        glossy_source=reader.choice("glossy_source", ("traced", "world"), "traced"),
        glossy_shadowing=reader.choice("glossy_shadowing", ("correlated", "separable"), "correlated"),
        transmission_roughness=reader.number("transmission_roughness", 0.0, low=0.0, high=1.0),
        transmission_distribution=reader.choice("transmission_distribution", ("ggx", "beckmann"), "ggx"),
    )
    reader.finish()
    return material


def _texture(reader: _Reader | None, base: Path | None) -> sc.Texture | None:
    """A material's "texture" or "emission_texture": an image's pixels inline ("pixels") or by a file's path
    ("image", relative to the scene file's folder), its colour space, interpolation and extension."""
    if reader is None:
        return None
    mapping = {
        "uv_scale": reader.vector("uv_scale", (1.0, 1.0), length=2, low=-TEXTURE_SCALE_MAX, high=TEXTURE_SCALE_MAX),
        "uv_offset": reader.vector("uv_offset", (0.0, 0.0), length=2, low=-COORDINATE_LIMIT, high=COORDINATE_LIMIT),
        "uv_rotation": reader.number("uv_rotation", 0.0, low=-ANGLE_LIMIT, high=ANGLE_LIMIT),
    }
    uv_map = reader.raw("uv_map", "")  # which UV map the meshes' "uvs" hold: for readers, not the tracer
    if not isinstance(uv_map, str):
        reader.fail("uv_map", f"must be a UV map's name (a string), got {_show_shape(uv_map)}")
    if "checker" in reader.data or "gradient" in reader.data or "attribute" in reader.data:
        texture = _procedural_texture(reader)
        return None if texture is None else replace(texture, **mapping)
    colorspace = reader.choice("colorspace", tx.COLORSPACES, "sRGB")
    interpolation = reader.choice("interpolation", sc.INTERPOLATIONS, "linear")
    extension = reader.choice("extension", sc.EXTENSIONS, "repeat")
    image = reader.raw("image", None)
    pixels = reader.raw("pixels", None)
    reader.finish()
    values, source = None, ""
    if (image is None) == (pixels is None):
        reader.fail("", 'must give its pixels either inline ("pixels") or by a file\'s path ("image"), one of them')
        return None
    if image is not None:
        if not isinstance(image, str) or not image:
            reader.fail("image", f"must be a file's path (a non-empty string), got {_show_shape(image)}")
            return None
        path = Path(image) if base is None or Path(image).is_absolute() else Path(base) / image
        source = str(path)
        try:
            values = tx.read_image(path)
        except tx.TextureFileError as error:
            reader.fail("image", f"{_show(image)} {error}")
            return None
    else:
        values = _texture_pixels(reader, pixels)
        if values is None:
            return None
        kept = _checked_texels.get((id(values), colorspace))
        if kept is not None and kept[0] is values:  # the same pixels, already found a picture
            return sc.Texture(pixels=kept[1], interpolation=interpolation, extension=extension, **mapping)
    try:
        linear = tx.linear_pixels(values, colorspace)
    except tx.TextureFileError as error:
        reader.fail("image" if image is not None else "pixels", str(error))
        return None
    if linear.shape[0] * linear.shape[1] > tx.MAX_TEXTURE_PIXELS:
        reader.fail(
            "pixels", f"must have at most {tx.MAX_TEXTURE_PIXELS} pixels, got {linear.shape[0] * linear.shape[1]}"
        )
        return None
    problem = _unpicturable_texel(linear, values)
    if problem:
        reader.fail("image" if image is not None else "pixels", problem)
        return None
    linear.flags.writeable = False  # the texture keeps it, without a copy
    if image is None and values.nbytes >= KEPT_TEXELS_FROM and sc.immutable(values):
        while len(_checked_texels) >= TEXELS_KEPT:
            _checked_texels.pop(next(iter(_checked_texels)))
        _checked_texels[(id(values), colorspace)] = (values, linear)
    return sc.Texture(pixels=linear, interpolation=interpolation, extension=extension, source=source, **mapping)


# A document's inline texture given as a read-only array of at least KEPT_TEXELS_FROM bytes is converted and checked
# once: the Rendered view hands the same array over on every change, and a 4096 x 4096 picture's conversion took
# 0.25 s (up to 1 s beside the view's tracing). At most TEXELS_KEPT of them; each input kept alive with its result,
# so that its id stays its own, and nothing can change its bits (scene.immutable)
KEPT_TEXELS_FROM = 1 << 20
TEXELS_KEPT = 4
_checked_texels: dict[tuple[int, str], tuple[np.ndarray, np.ndarray]] = {}


def _procedural_texture(reader: _Reader) -> sc.Texture | None:
    """A texture given as {"checker": {...}} or {"gradient": {...}} (Blender's Checker and Gradient Texture nodes on
    the UV map; a gradient's colour ramp) or {"attribute": {...}} (a mesh's corner colours), alone in its object."""
    kind = next(key for key in ("checker", "gradient", "attribute") if key in reader.data)
    inner = reader.reader(kind)
    mapped = ("uv_scale", "uv_offset", "uv_rotation", "uv_map") if kind != "attribute" else ()  # colours: not by UV
    beside = [key for key in reader.data if key not in (kind, *mapped)]
    if beside:
        others = ", ".join(json.dumps(key) for key in beside)
        reader.fail("", f'must give "{kind}" alone: a procedural texture has no {others}')
    reader.seen.update(reader.data)
    if inner is None:
        reader.fail(kind, "must be an object, got null")
        return None
    if kind == "attribute":
        gain = inner.vector("gain", (1.0, 1.0, 1.0), length=3, low=-INTENSITY_MAX, high=INTENSITY_MAX)
        bias = inner.vector("bias", (0.0, 0.0, 0.0), length=3, low=-INTENSITY_MAX, high=INTENSITY_MAX)
        name = inner.raw("name", "")  # which colour attribute the meshes' "colors" hold: for readers, not the tracer
        if not isinstance(name, str):
            inner.fail("name", f"must be a colour attribute's name (a string), got {_show_shape(name)}")
        inner.finish()
        return sc.Texture(kind="attribute", gain=gain, bias=bias)
    if kind == "checker":
        colors = (inner.color("color1", (0.8, 0.8, 0.8)), inner.color("color2", (0.2, 0.2, 0.2)))
        scale = inner.number("scale", 5.0, low=-TEXTURE_SCALE_MAX, high=TEXTURE_SCALE_MAX)
        inner.finish()
        return sc.Texture(kind="checker", colors=colors, scale=scale)
    gradient = inner.choice("type", sc.GRADIENTS, "linear")
    ramp = inner.choice("interpolation", sc.RAMP_INTERPOLATIONS, "linear")
    stops = inner.raw("stops", [[0.0, [0.0, 0.0, 0.0]], [1.0, [1.0, 1.0, 1.0]]])
    inner.finish()
    expected = "must be a non-empty list of colour ramp stops [position, [r, g, b]], positions ascending in 0..1"
    if not isinstance(stops, list) or not stops or len(stops) > RAMP_STOPS_MAX:
        inner.fail("stops", f"{expected} (at most {RAMP_STOPS_MAX}), got {_show_shape(stops)}")
        return None
    positions, colors = [], []
    for index, stop in enumerate(stops):
        at = f"stops[{index}]"
        if not isinstance(stop, list) or len(stop) != 2:
            inner.fail(at, f"{expected}, got {_show_shape(stop)}")
            return None
        problems = len(inner.problems)
        position = inner.check_number(at, stop[0], low=0.0, high=1.0)
        if not isinstance(stop[1], list) or len(stop[1]) != 3:
            inner.fail(f"{at}[1]", f"must be a colour [r, g, b], got {_show_shape(stop[1])}")
            return None
        color = tuple(inner.check_number(f"{at}[1][{i}]", c, low=0.0, high=1.0) for i, c in enumerate(stop[1]))
        if len(inner.problems) > problems:
            return None
        if positions and position < positions[-1]:
            inner.fail(at, f"{expected}, got {_show(position)} after {_show(positions[-1])}")
            return None
        positions.append(position)
        colors.append(color)
    return sc.Texture(kind="gradient", gradient=gradient, ramp=ramp, positions=tuple(positions), colors=tuple(colors))


def _texture_pixels(reader: _Reader, raw: Any) -> np.ndarray | None:
    """Inline pixels: rows (top first) of pixels, each [r, g, b] (or [r, g, b, a], or one grey number); a NumPy
    array (H, W[, C]) in a document made in the same process."""
    expected = "must be a non-empty list of rows, each a list of pixels [r, g, b] (top row first)"
    if isinstance(raw, np.ndarray):
        if raw.dtype.kind not in "fiu" or raw.ndim not in (2, 3) or raw.size == 0:
            reader.fail("pixels", f"{expected}, got an array of shape {raw.shape} and dtype {raw.dtype}")
            return None
        return raw
    if not isinstance(raw, list) or not raw or not all(isinstance(row, list) and row for row in raw):
        reader.fail("pixels", f"{expected}, got {_show_shape(raw)}")
        return None
    try:
        objects = np.asarray(raw, dtype=object)
    except ValueError:
        objects = None
    if objects is None or objects.ndim not in (2, 3) or objects.shape[1] != len(raw[0]):
        widths = sorted({len(row) for row in raw})
        reader.fail("pixels", f"{expected}, all rows as long and all pixels of one size, got row lengths {widths}")
        return None
    if not set(map(type, objects.ravel().tolist())) <= {int, float}:
        bad = next(i for i, row in enumerate(raw) if not _numbers_only(row))
        reader.fail(f"pixels[{bad}]", f"must hold numbers only, got {_show(raw[bad])}")
        return None
    return objects.astype(np.float64)


def _numbers_only(value: Any) -> bool:
    if isinstance(value, list):
        return all(_numbers_only(item) for item in value)
    return isinstance(value, int | float) and not isinstance(value, bool)


def _corner_uvs(reader: _Reader, count: int) -> np.ndarray | None:
    """A mesh's "uvs": one [[u, v] x 3] per triangle (its corners'), checked as one array (large meshes)."""
    array = _corner_array(reader, "uvs", count, "UVs [u, v]")
    if array is not None:
        array.flags.writeable = False  # (T, 3, 2): the mesh keeps it, without a copy
    return array


def _corner_colors(reader: _Reader, count: int) -> np.ndarray | None:
    """A mesh's "colors": one [[r, g, b] x 3] per triangle (its corners' linear colours), checked as one array."""
    array = _corner_array(reader, "colors", count, "colours [r, g, b]")
    if array is not None:
        array.flags.writeable = False  # (T, 3, 3): the mesh keeps it, without a copy
    return array


def _corner_array(reader: _Reader, key: str, count: int, what: str) -> np.ndarray | None:
    """A mesh's per-corner key: count triangles' three corners, each what ("normals [x, y, z]", "UVs [u, v]")
    (T, 3, C) float64, checked as one array; None where absent or (after one message naming the first bad
    triangle) not valid."""
    raw = reader.raw(key, None)
    if raw is None:
        return None
    width = what.count(",") + 1
    brackets = ", ".join([what.split(" ", 1)[1]] * 3)
    if not isinstance(raw, list | np.ndarray) or len(raw) != count:
        reader.fail(
            key,
            f"must be a list of {count} triangles' corner {what.split(' ', 1)[0]} [{brackets}], got {_show_shape(raw)}",
        )
        return None
    array = _number_array(raw, (count, 3, width))
    if array is None:  # the slow way, to name the first bad triangle
        raw = raw.tolist() if isinstance(raw, np.ndarray) else raw
        bad = next((i for i, item in enumerate(raw) if _number_array([item], (1, 3, width)) is None), 0)
        reader.fail(
            f"{key}[{bad}]",
            f"must be 3 corner {what} of numbers up to {_show(COORDINATE_LIMIT)}, got {_show(raw[bad])}",
        )
        return None
    return array


def _object(
    reader: _Reader,
    materials: dict[str, sc.Material],
    index: int,
    meshes: dict[str, sc.TriangleMesh] | None = None,
    checked: dict[int, tuple[np.ndarray, np.ndarray]] | None = None,
) -> sc.SceneObject | None:
    """checked: meshes' arrays checked already, by id() of their bodies (_meshes_in_bulk)."""
    kinds = ("sphere", "plane", "cylinder", "box", "pyramid", "mesh", "instance", "instances")
    kind = reader.choice("type", kinds, None)
    if kind is None and "type" not in reader.data:
        reader.fail("type", f"is required (one of {', '.join(kinds)})")
    name = reader.string("name", f"object{index}")
    # a mesh with materials per triangle needs no material of its own (its first is the default)
    listed = reader.data.get("materials") if kind == "mesh" else None
    if "material" not in reader.data and isinstance(listed, list) and listed and isinstance(listed[0], str):
        material = listed[0]
    elif kind in ("instance", "instances"):
        material = reader.string("material", None)  # absent: the mesh's own materials
    else:
        material = reader.string("material")
    if isinstance(material, str) and material and materials and material not in materials:
        reader.fail(
            "material", f"must name one of the materials ({', '.join(sorted(materials))}), got {_show(material)}"
        )
    common = {
        "name": name,
        "material": material,
        "location": reader.position("location", (0.0, 0.0, 0.0)),
        "rotation": reader.angles("rotation", (0.0, 0.0, 0.0)),
        "visible_camera": reader.boolean("visible_camera", True),
        "visible_shadow": reader.boolean("visible_shadow", True),
        "visible_reflection": reader.boolean("visible_reflection", True),
        "holdout": reader.boolean("holdout", False),
        "pass_index": reader.number("pass_index", 0, low=0, high=PASS_INDEX_MAX, integer=True),
        "poses": _poses(reader),
    }
    result: sc.SceneObject | None = None
    if kind == "sphere":
        result = sc.Sphere(radius=reader.length("radius"), **common)
    elif kind == "plane":
        size = reader.lengths("size", None, count=2)
        result = sc.Plane(size=size, **common)
    elif kind == "cylinder":
        result = sc.Cylinder(
            radius=reader.length("radius"),
            height=reader.length("height"),
            **common,
        )
    elif kind == "box":
        result = sc.Box(size=reader.lengths("size"), **common)
    elif kind == "pyramid":
        result = sc.Pyramid(size=reader.lengths("size"), **common)
    elif kind == "mesh":
        result = _mesh(reader, common, materials, None if checked is None else checked.get(id(reader.data)))
    elif kind in ("instance", "instances"):
        result = _instances(reader, common, meshes or {}, many=kind == "instances")
    reader.finish()
    return result


def _poses(reader: _Reader) -> tuple[sc.Pose, ...]:
    """An object's or the camera's "poses": a list of 2 to POSES_MAX {"location", "rotation"} at evenly spaced times
    over the shutter (motion blur); () where absent."""
    raw = reader.raw("poses", None)
    if raw is None:
        return ()
    if not isinstance(raw, list) or not 2 <= len(raw) <= POSES_MAX:
        reader.fail(
            "poses",
            f'must be a list of 2 to {POSES_MAX} poses ({{"location": [x, y, z], "rotation": [x, y, z]}} at evenly '
            f"spaced times over the shutter), got {_show_shape(raw)}",
        )
        return ()
    poses = []
    for index, body in enumerate(raw):
        pose = _Reader(body, f"{reader.at('poses')}[{index}]", reader.problems)
        poses.append((pose.position("location"), pose.angles("rotation")))
        pose.finish()
    return tuple(poses)


def _same_pose_counts(objects: list[sc.SceneObject], camera: sc.Camera, problems: list[str]) -> None:
    """Every moving object and a moving camera have one pose per time slice: the same number of poses."""
    counts = [(f"objects[{i}].poses", len(obj.poses)) for i, obj in enumerate(objects) if obj.poses]
    if camera.poses:
        counts.append(("camera.poses", len(camera.poses)))
    if counts and any(count != counts[0][1] for _, count in counts):
        first, expected = counts[0]
        for where, count in counts[1:]:
            if count != expected:
                problems.append(
                    f"{where}: {count} poses where {first} has {expected}: each moving object and the camera need one "
                    "pose per time over the shutter, the same number"
                )


MATRIX_MIN_DETERMINANT = 1e-18  # relative to the largest entry cubed: below it, a matrix flattens its mesh


def _instances(
    reader: _Reader, common: dict[str, Any], meshes: dict[str, sc.TriangleMesh], many: bool
) -> sc.MeshInstances | None:
    """An "instance" (one placement: "matrix", or "location", "rotation", "scale") or "instances" (a list of
    "matrices") of a mesh in the scene's "meshes" table."""
    name = reader.string("mesh")
    mesh = meshes.get(name) if isinstance(name, str) else None
    if isinstance(name, str) and name and mesh is None:
        known = ", ".join(sorted(meshes)) if meshes else "the scene has no meshes table"
        reader.fail("mesh", f"must name a mesh of the scene's meshes ({known}), got {_show(name)}")
    if many:
        for key in ("location", "rotation"):
            if key in reader.data:
                reader.fail(key, 'is not a field of "instances" (each placement is one of its matrices)')
        raw = reader.raw("matrices")
        matrices = _matrices(reader, raw)
    elif "matrix" in reader.data:
        for key in ("location", "rotation", "scale"):
            if key in reader.data:
                reader.fail(key, 'cannot be given with "matrix" (the matrix holds the whole placement)')
        matrices = _matrices(reader, [reader.raw("matrix")], single=True)
    else:
        scale = reader.vector("scale", (1.0, 1.0, 1.0), low=-LENGTH_RANGE[1], high=LENGTH_RANGE[1])
        if any(abs(k) < LENGTH_RANGE[0] for k in scale):
            reader.fail("scale", f"must have every component at least {LENGTH_RANGE[0]} in size, got {_show(scale)}")
            scale = (1.0, 1.0, 1.0)
        matrices = sc.matrix_from_transform(common["location"], common["rotation"], scale)[None]
    if mesh is None or matrices is None:
        return None
    override = common["material"] is not None
    placed = {**common, "location": (0.0, 0.0, 0.0), "rotation": (0.0, 0.0, 0.0)}
    if not override:
        placed["material"] = mesh.material
    return sc.MeshInstances(mesh=mesh, mesh_name=name, matrices=matrices, override=override, **placed)


def _matrices(reader: _Reader, raw: Any, single: bool = False) -> np.ndarray | None:
    """Placements as (K, 3, 4) float64: each a row-major [[a, b, c, x], [d, e, f, y], [g, h, i, z]] (a last row
    [0, 0, 0, 1] may follow) or the same 12 (or 16) numbers flat; every entry finite and within COORDINATE_LIMIT,
    every 3x3 part invertible."""
    key = "matrix" if single else "matrices"
    if raw is ...:
        return None
    expected = "a 3x4 or 4x4 matrix (rows [a, b, c, x], ...; or its 12 or 16 numbers flat)"
    if not isinstance(raw, list) or (not single and not raw):
        reader.fail(key, f"must be a non-empty list of placements, each {expected}, got {_show_shape(raw)}")
        return None
    array = _placements(raw)
    if array is None:  # forms mixed in one list, or a bad entry: one at a time, to name the first bad one
        entries = [_placements([item]) for item in raw]
        bad = next((i for i, entry in enumerate(entries) if entry is None), None)
        if bad is not None:
            where = key if single else f"{key}[{bad}]"
            reader.fail(where, f"must be {expected} of numbers up to {_show(COORDINATE_LIMIT)}, got {_show(raw[bad])}")
            return None
        wrong = next((i for i, e in enumerate(entries) if e.shape[1] == 4 and np.any(e[0, 3] != (0, 0, 0, 1))), None)
        if wrong is not None:
            reader.fail(
                key if single else f"{key}[{wrong}]", "must have a last row of [0, 0, 0, 1] (an affine placement)"
            )
            return None
        array = np.concatenate([e[:, :3] for e in entries])
    if array.shape[1] == 4:
        wrong = np.any(array[:, 3] != (0.0, 0.0, 0.0, 1.0), axis=1).nonzero()[0]
        if wrong.size:
            where = key if single else f"{key}[{int(wrong[0])}]"
            reader.fail(where, "must have a last row of [0, 0, 0, 1] (an affine placement)")
            return None
        array = np.ascontiguousarray(array[:, :3])
    linear = array[:, :, :3]
    largest = np.abs(linear).max(axis=(1, 2))
    flat = np.abs(np.linalg.det(linear)) <= MATRIX_MIN_DETERMINANT * largest**3
    if flat.any():
        where = key if single else f"{key}[{int(flat.nonzero()[0][0])}]"
        reader.fail(where, "must be invertible (its 3x3 part flattens the mesh: a scale of 0 on some axis)")
        return None
    array.flags.writeable = False
    return array


def _placements(raw: list) -> np.ndarray | None:
    """A list of matrices all in one of the four forms -> (K, 3 or 4, 4) float64, or None."""
    for rows in (3, 4):
        for shape in ((len(raw), rows, 4), (len(raw), rows * 4)):
            array = _number_array(raw, shape)
            if array is not None:
                return array.reshape(len(raw), rows, 4)
    return None


def _mesh_table(reader: _Reader | None, materials: dict[str, sc.Material]) -> dict[str, sc.TriangleMesh]:
    """The scene's "meshes": name -> a mesh's vertices, triangles, normals and materials, once for all the
    "instance" and "instances" objects that place it."""
    meshes: dict[str, sc.TriangleMesh] = {}
    if reader is None:
        return meshes
    for name in list(reader.data):
        body = _Reader(reader.raw(name), f"{reader.path}.{name}", reader.problems)
        listed = body.data.get("materials")
        if "material" not in body.data and isinstance(listed, list) and listed and isinstance(listed[0], str):
            material = listed[0]
        else:
            material = body.string("material")
        if material and materials and material not in materials:
            body.fail(
                "material", f"must name one of the materials ({', '.join(sorted(materials))}), got {_show(material)}"
            )
        mesh = _mesh(body, {"name": name, "material": material}, materials)
        body.finish()
        meshes[name] = mesh
    return meshes


def _mesh(
    reader: _Reader,
    common: dict[str, Any],
    materials: dict[str, sc.Material],
    checked: tuple[np.ndarray, np.ndarray] | None = None,
) -> sc.TriangleMesh:
    """checked: this body's vertices and triangles as arrays, checked already (_meshes_in_bulk)."""
    raw_vertices = reader.raw("vertices")
    raw_triangles = reader.raw("triangles")
    fast = checked if checked is not None else _mesh_arrays(raw_vertices, raw_triangles)
    if fast is None:  # a document made in this process may hold arrays (a render's export): its problems named below
        raw_vertices = raw_vertices.tolist() if isinstance(raw_vertices, np.ndarray) else raw_vertices
        raw_triangles = raw_triangles.tolist() if isinstance(raw_triangles, np.ndarray) else raw_triangles
    if fast is not None:  # every vertex and triangle valid: checked as arrays, the same numbers as the loop below
        vertices_array, triangles_array = fast
        count = len(triangles_array)
        normals = _corner_normals(reader, count)
        names, indices = _mesh_materials(reader, count, materials)
        return sc.TriangleMesh(
            vertices=vertices_array,
            triangles=triangles_array,
            normals=normals,
            uvs=_corner_uvs(reader, count),
            colors=_corner_colors(reader, count),
            materials=names,
            material_indices=indices,
            **common,
        )
    vertices: list[sc.Vec3] = []
    triangles: list[tuple[int, int, int]] = []
    if raw_vertices is not ...:
        if not isinstance(raw_vertices, list) or not raw_vertices:
            reader.fail("vertices", f"must be a non-empty list of [x, y, z], got {_show_shape(raw_vertices)}")
        else:
            holder = _Reader({f"vertices[{i}]": v for i, v in enumerate(raw_vertices)}, reader.path, reader.problems)
            vertices = [holder.position(f"vertices[{i}]") for i in range(len(raw_vertices))]
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
                        f"must be 3 vertex indices in 0..{len(vertices) - 1}, "
                        f"got [{', '.join(_show(k) for k in triangle)}]"
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
    count = len(raw_triangles) if isinstance(raw_triangles, list) else 0
    normals = _corner_normals(reader, count)
    names, indices = _mesh_materials(reader, count, materials)
    return sc.TriangleMesh(
        vertices=tuple(vertices),
        triangles=tuple(triangles),
        normals=normals,
        uvs=_corner_uvs(reader, count),
        colors=_corner_colors(reader, count),
        materials=names,
        material_indices=indices,
        **common,
    )


def _mesh_arrays(raw_vertices: Any, raw_triangles: Any) -> tuple[np.ndarray, np.ndarray] | None:
    """A mesh's vertices (V, 3) float64 and triangles (T, 3) int64 where every entry is valid (numbers within the
    coordinate limit; integer indices of vertices; triangles that span an area), checked with array operations (a
    million-triangle mesh in a fraction of the per-entry loop's time); None where any is not, for the loop to
    name it. Either may be a NumPy array (a document made in the same process): floats, and integers, shaped as the
    lists would be."""
    if not isinstance(raw_vertices, list | np.ndarray) or not len(raw_vertices):
        return None
    if not isinstance(raw_triangles, list | np.ndarray) or not len(raw_triangles):
        return None
    vertices = _number_array(raw_vertices, (len(raw_vertices), 3))
    if vertices is None:
        return None
    triangles = _index_array(raw_triangles)
    if triangles is None:
        return None
    if not (np.all(triangles >= 0) and np.all(triangles < len(vertices))) or not _span_areas(vertices, triangles):
        return None
    vertices.flags.writeable = triangles.flags.writeable = False  # the mesh keeps these arrays, without a copy
    return vertices, triangles


def _index_array(raw: Any) -> np.ndarray | None:
    """Triangles' vertex indices (T, 3) int64 from lists of JSON integers or an integer array of that shape (the
    bounds are the caller's to check); None where they are not that."""
    if isinstance(raw, np.ndarray):
        if raw.dtype.kind not in "iu" or raw.shape != (len(raw), 3):
            return None
        return raw.astype(np.int64, copy=False).view()
    try:
        objects = np.asarray(raw, dtype=object)
    except ValueError:
        return None
    if objects.shape != (len(raw), 3) or not set(map(type, objects.ravel().tolist())) <= {int}:
        return None
    try:
        return objects.astype(np.int64)
    except OverflowError:
        return None


def _span_areas(vertices: np.ndarray, triangles: np.ndarray) -> bool:
    """Whether every triangle (T, 3) of vertices (V, 3) spans an area: the per-entry loop's cross product, in the
    same float64 operations."""
    v0, v1, v2 = (vertices[triangles[:, k]] for k in range(3))
    e1, e2 = v1 - v0, v2 - v0
    normal = np.stack(
        (
            e1[:, 1] * e2[:, 2] - e1[:, 2] * e2[:, 1],
            e1[:, 2] * e2[:, 0] - e1[:, 0] * e2[:, 2],
            e1[:, 0] * e2[:, 1] - e1[:, 1] * e2[:, 0],
        ),
        axis=1,
    )
    return not np.any(np.all(normal == 0.0, axis=1))


def _meshes_in_bulk(bodies: list) -> dict[int, tuple[np.ndarray, np.ndarray]]:
    """The "mesh" objects whose vertices and triangles are lists (an export's small meshes: thousands of separate
    objects), checked as one array each (_mesh_arrays' checks, the same arrays it would make): id(body) -> (vertices
    (V, 3), triangles (T, 3)), read-only views of the joined arrays. {} where any of them fails a check: each is
    then checked on its own, which names the problem. Checked one by one, 3,000 cubes cost 0.17 s of NumPy calls."""
    chosen = [
        body
        for body in bodies
        if isinstance(body, dict)
        and body.get("type") == "mesh"
        and isinstance(body.get("vertices"), list)
        and isinstance(body.get("triangles"), list)
        and body["vertices"]
        and body["triangles"]
    ]
    if len(chosen) < 2:
        return {}
    vertex_counts = np.array([len(body["vertices"]) for body in chosen], dtype=np.int64)
    triangle_counts = np.array([len(body["triangles"]) for body in chosen], dtype=np.int64)
    vertex_rows = [row for body in chosen for row in body["vertices"]]
    vertices = _number_array(vertex_rows, (len(vertex_rows), 3))
    triangles = None if vertices is None else _index_array([row for body in chosen for row in body["triangles"]])
    if triangles is None:
        return {}
    owners = np.repeat(np.arange(len(chosen)), triangle_counts)
    if not (np.all(triangles >= 0) and np.all(triangles < vertex_counts.take(owners)[:, None])):
        return {}
    vertex_ends, triangle_ends = np.cumsum(vertex_counts), np.cumsum(triangle_counts)
    if not _span_areas(vertices, triangles + (vertex_ends - vertex_counts).take(owners)[:, None]):
        return {}
    vertices.flags.writeable = triangles.flags.writeable = False  # the meshes keep views of these, without a copy
    checked, vertex_start, triangle_start = {}, 0, 0
    for body, vertex_end, triangle_end in zip(chosen, vertex_ends.tolist(), triangle_ends.tolist(), strict=True):
        checked[id(body)] = (vertices[vertex_start:vertex_end], triangles[triangle_start:triangle_end])
        vertex_start, triangle_start = vertex_end, triangle_end
    return checked


def _corner_normals(reader: _Reader, count: int) -> np.ndarray | None:
    """A mesh's "normals": one [[x, y, z] x 3] per triangle, checked as one array (large meshes)."""
    array = _corner_array(reader, "normals", count, "normals [x, y, z]")
    if array is None:
        return None
    short = np.sqrt((array * array).sum(axis=2)) < DIRECTION_MIN_LENGTH
    if short.any():
        bad, corner = (int(x) for x in np.argwhere(short)[0])
        reader.fail(f"normals[{bad}][{corner}]", "must not be the zero vector (a normal needs a direction)")
        return None
    array.flags.writeable = False  # (T, 3, 3): the mesh keeps it, without a copy
    return array


def _number_array(raw: list, shape: tuple[int, ...]) -> np.ndarray | None:
    """Nested lists of JSON numbers (no booleans) of this shape, each of magnitude at most COORDINATE_LIMIT, as a
    float64 array (checked with array operations: a large mesh's normals); None where they are not. raw may be a
    float NumPy array of that shape instead (a document made in the same process): a read-only view of it then."""
    if isinstance(raw, np.ndarray):
        if raw.dtype.kind != "f" or raw.shape != shape:
            return None
        array = raw.astype(np.float64, copy=False).view()
        return array if np.all(np.abs(array) <= COORDINATE_LIMIT) else None  # NaN fails too
    try:
        objects = np.asarray(raw, dtype=object)
    except ValueError:
        return None
    if objects.shape != shape or not set(map(type, objects.ravel().tolist())) <= {int, float}:
        return None
    try:
        array = objects.astype(np.float64)
    except OverflowError:
        return None
    if not np.all(np.abs(array) <= COORDINATE_LIMIT):
        return None
    return array


def _mesh_materials(
    reader: _Reader, count: int, materials: dict[str, sc.Material]
) -> tuple[tuple[str, ...] | None, np.ndarray | None]:
    """A mesh's "materials" (names) and "material_indices" (one index into them per triangle), given together."""
    raw_names = reader.raw("materials", None)
    raw_indices = reader.raw("material_indices", None)
    if raw_names is None and raw_indices is None:
        return None, None
    if raw_names is None or raw_indices is None:
        missing = "materials" if raw_names is None else "material_indices"
        reader.fail(missing, "is required with " + ("material_indices" if raw_names is None else "materials"))
        return None, None
    names: list[str] = []
    if not isinstance(raw_names, list) or not raw_names:
        reader.fail("materials", f"must be a non-empty list of material names, got {_show_shape(raw_names)}")
        return None, None
    for i, name in enumerate(raw_names):
        if not isinstance(name, str) or (materials and name not in materials):
            known = ", ".join(sorted(materials))
            reader.fail(f"materials[{i}]", f"must name one of the materials ({known}), got {_show(name)}")
        names.append(name if isinstance(name, str) else "")
    if not isinstance(raw_indices, list) or len(raw_indices) != count:
        reader.fail(
            "material_indices", f"must be a list of {count} integers (one per triangle), got {_show_shape(raw_indices)}"
        )
        return None, None
    valid = [isinstance(k, int) and not isinstance(k, bool) and 0 <= k < len(names) for k in raw_indices]
    if not all(valid):
        bad = valid.index(False)
        reader.fail(
            f"material_indices[{bad}]", f"must be an integer in 0..{len(names) - 1}, got {_show(raw_indices[bad])}"
        )
        return None, None
    indices = np.asarray(raw_indices, dtype=np.int64)  # (T,)
    indices.flags.writeable = False
    return tuple(names), indices


LIGHT_TYPES = ("ambient", "point", "directional", "spot", "area", "world")


def _light(reader: _Reader) -> sc.Light | None:
    kind = reader.choice("type", LIGHT_TYPES, None)
    if kind is None and "type" not in reader.data:
        reader.fail("type", f"is required (one of {', '.join(LIGHT_TYPES)})")
    intensity = reader.number("intensity", low=0.0, high=INTENSITY_MAX)
    color = reader.vector("color", sc.WHITE, low=0.0, high=INTENSITY_MAX)
    result: sc.Light | None = None
    direction = {"nonzero": True, "low": -COORDINATE_LIMIT, "high": COORDINATE_LIMIT}
    if kind == "ambient":
        result = sc.AmbientLight(intensity=intensity, color=color)
    elif kind == "world":
        samples = reader.number("samples", sc.WorldLight.samples, low=1, high=1024, integer=True)
        radiance = reader.choice("radiance", ("background", "color"), "background")
        result = sc.WorldLight(intensity=intensity, color=color, samples=samples, radiance=radiance)
    elif kind == "point":
        result = sc.PointLight(
            location=reader.position("location"),
            intensity=intensity,
            color=color,
            falloff=reader.choice("falloff", sc.FALLOFFS, "none"),
            radius=reader.number("radius", 0.0, low=0.0, high=LENGTH_RANGE[1]),
        )
    elif kind == "directional":
        result = sc.DirectionalLight(
            direction=reader.vector("direction", **direction),
            intensity=intensity,
            color=color,
            angle=reader.number("angle", 0.0, low=0.0, high=180.0),
            seen_in_mirrors=reader.boolean("seen_in_mirrors", False),
            disc_model=reader.choice("disc_model", sc.DISC_MODELS, "cycles4"),
        )
    elif kind == "area":
        result = _area_light(reader, intensity, color, direction)
    elif kind == "spot":
        base = sc.SpotLight()
        result = sc.SpotLight(
            location=reader.position("location"),
            direction=reader.vector("direction", **direction),
            intensity=intensity,
            color=color,
            falloff=reader.choice("falloff", sc.FALLOFFS, "none"),
            spot_size=reader.number("spot_size", base.spot_size, low=0.0, low_open=True, high=180.0),
            spot_blend=reader.number("spot_blend", base.spot_blend, low=0.0, high=1.0),
            spot_model=reader.choice("spot_model", sc.SPOT_MODELS, base.spot_model),
            radius=reader.number("radius", 0.0, low=0.0, high=LENGTH_RANGE[1]),
            **_spot_cone(reader, direction),
        )
    if isinstance(result, sc.PointLight | sc.SpotLight | sc.DirectionalLight | sc.AreaLight):
        flags = ("visible_diffuse", "visible_glossy", "visible_transmission")
        seen = {flag: reader.boolean(flag, True) for flag in flags}
        if not all(seen.values()):  # the documented light reaches every term
            result = replace(result, **seen)
    reader.finish()
    return result


def _spot_cone(reader: _Reader, direction: dict) -> dict:
    """A spot's "cone_scale" (two factors > 0) and "x_axis" (required with cone_scale; not along "direction")."""
    found = {}
    if "cone_scale" in reader.data:
        low, high = LENGTH_RANGE
        found["cone_scale"] = reader.vector("cone_scale", length=2, low=0.0, low_open=True, high=high, least=low)
        if "x_axis" not in reader.data:
            reader.fail("x_axis", "is required with cone_scale (the light's local X, the first factor's axis)")
    if "x_axis" not in reader.data:
        return found
    x_axis = found["x_axis"] = reader.vector("x_axis", **direction)
    shine = reader.data.get("direction")
    if all(isinstance(c, float) for c in (*x_axis, *(shine or ()))) and shine and len(shine) == 3:
        a, b = np.asarray(shine, dtype=float), np.asarray(x_axis, dtype=float)
        if np.linalg.norm(np.cross(a, b)) <= 1e-6 * np.linalg.norm(a) * np.linalg.norm(b):
            reader.fail("x_axis", "must not lie along direction")
    return found


def _area_light(reader: _Reader, intensity: float, color: sc.Color, direction: dict) -> sc.AreaLight:
    """An "area" light: location, direction (the way it shines), x_axis (its local X; not along direction),
    shape and size (one length, or [x, y] for a rectangle or an ellipse)."""
    base = sc.AreaLight()
    shine = reader.vector("direction", **direction)
    x_axis = reader.vector("x_axis", base.x_axis, **direction)
    shape = reader.choice("shape", sc.AREA_SHAPES, base.shape)
    raw = reader.data.get("size")
    if isinstance(raw, list):
        size = reader.lengths("size", count=2)
        if shape in ("square", "disk") and size[0] != size[1]:
            reader.fail("size", f"must be one length for a {shape} ([x, y] is for a rectangle or an ellipse)")
    else:
        side = reader.length("size")
        size = (side, side)
    numbers = all(isinstance(c, float) for c in (*shine, *x_axis))
    if numbers and min(math.hypot(*shine), math.hypot(*x_axis)) >= DIRECTION_MIN_LENGTH:
        a, b = np.asarray(shine) / math.hypot(*shine), np.asarray(x_axis) / math.hypot(*x_axis)
        if np.linalg.norm(np.cross(a, b)) < 1e-6:
            shown = ", ".join(_show(c) for c in x_axis)
            reader.fail("x_axis", f"must not lie along direction ({', '.join(_show(c) for c in shine)}), got [{shown}]")
    return sc.AreaLight(
        location=reader.position("location"),
        direction=shine,
        x_axis=x_axis,
        shape=shape,
        size=size,
        intensity=intensity,
        color=color,
        seen_in_mirrors=reader.boolean("seen_in_mirrors", False),
    )


def _camera(reader: _Reader | None) -> sc.Camera:
    if reader is None:
        return sc.Camera()
    base = sc.Camera()
    millimetres = {"low": 0.0, "low_open": True, "least": LENS_RANGE[0], "high": LENS_RANGE[1]}
    sensor_width = reader.number("sensor_width", base.sensor_width, **millimetres)
    sensor_height = reader.number("sensor_height", base.sensor_height, **millimetres)
    sensor_fit = reader.choice("sensor_fit", sc.SENSOR_FITS, base.sensor_fit)
    lens = reader.number("lens", base.lens, **millimetres)
    fov = reader.number("fov", None, low=0.0, low_open=True, least=FOV_RANGE[0], high=FOV_RANGE[1])
    if "lens" in reader.data and "fov" in reader.data:
        reader.fail("fov", "give either lens or fov, not both")
    elif fov is not None and isinstance(fov, float) and FOV_RANGE[0] <= fov <= FOV_RANGE[1]:
        # Blender's camera.angle: the fitted sensor side (height for VERTICAL, width otherwise) spans fov.
        sensor = sensor_height if sensor_fit == "VERTICAL" else sensor_width
        lens = sensor / 2.0 / math.tan(math.radians(fov) / 2.0)
    kind = reader.choice("type", sc.CAMERA_TYPES, base.type)
    degrees = {"low": -360.0, "high": 360.0}
    panorama = {
        "panorama_type": reader.choice("panorama_type", sc.PANORAMA_TYPES, base.panorama_type),
        "fisheye_fov": reader.number("fisheye_fov", base.fisheye_fov, low=0.0, low_open=True, high=360.0),
        "fisheye_lens": reader.number("fisheye_lens", base.fisheye_lens, **millimetres),
        "latitude_min": reader.number("latitude_min", base.latitude_min, low=-90.0, high=90.0),
        "latitude_max": reader.number("latitude_max", base.latitude_max, low=-90.0, high=90.0),
        "longitude_min": reader.number("longitude_min", base.longitude_min, **degrees),
        "longitude_max": reader.number("longitude_max", base.longitude_max, **degrees),
    }
    shift = {"low": -SHIFT_LIMIT, "high": SHIFT_LIMIT}
    clip_start = reader.number("clip_start", base.clip_start, low=0.0, high=LENGTH_RANGE[1])
    clip_end = reader.number("clip_end", None, low=0.0, low_open=True, high=LENGTH_RANGE[1])
    if isinstance(clip_end, float) and isinstance(clip_start, float) and clip_end <= clip_start:
        reader.fail("clip_end", f"must be greater than clip_start ({_show(clip_start)}), got {_show(clip_end)}")
    camera = sc.Camera(
        location=reader.position("location", base.location),
        rotation=reader.angles("rotation", base.rotation),
        lens=lens,
        sensor_width=sensor_width,
        sensor_height=sensor_height,
        sensor_fit=sensor_fit,
        type=kind,
        ortho_scale=reader.length("ortho_scale", base.ortho_scale),
        shift_x=reader.number("shift_x", base.shift_x, **shift),
        shift_y=reader.number("shift_y", base.shift_y, **shift),
        clip_start=clip_start,
        clip_end=clip_end,
        **panorama,
        aperture=reader.number("aperture", base.aperture, low=0.0, high=LENGTH_RANGE[1]),
        focus_distance=reader.number(
            "focus_distance", base.focus_distance, low=0.0, low_open=True, least=LENGTH_RANGE[0], high=LENGTH_RANGE[1]
        ),
        poses=_poses(reader),
    )
    reader.finish()
    return camera


BACKGROUND_SIDE_MAX = 32768  # texels along either side of a background image


def _background(reader: _Reader | None, folder: str | Path | None = None) -> sc.Background:
    if reader is None:
        return sc.Background()
    base = sc.Background()
    kind = reader.choice("type", sc.BACKGROUNDS, base.type)
    image = None
    if kind == "image":
        image = _background_image(reader, folder)
    else:
        for key in ("image", "pixels", "colorspace", "rotation", "strength", "interpolation"):
            if key in reader.data:
                reader.raw(key)
                reader.fail(key, f'is a field of the "image" background only, got type {_show(kind)}')
    background = sc.Background(
        type=kind,
        color=reader.color("color", base.color),
        horizon=reader.color("horizon", base.horizon),
        zenith=reader.color("zenith", base.zenith),
        image=image,
        rotation=reader.number("rotation", base.rotation, low=-ANGLE_LIMIT, high=ANGLE_LIMIT),
        strength=reader.number("strength", base.strength, low=0.0, high=INTENSITY_MAX),
        interpolation=reader.choice("interpolation", sc.BACKGROUND_INTERPOLATIONS, base.interpolation),
    )
    reader.finish()
    return background


def _unpicturable_texel(texels: np.ndarray, raw: np.ndarray) -> str:
    """What makes a picture's linear texels (H, W, 3) no picture: the first texel that is not finite or lies beyond
    +-INTENSITY_MAX ("" where none does). Slightly negative values are kept as they are: float images hold them (every
    HDRI shipped with Blender has a few, from its encoder's filtering) and Blender and Cycles use them unchanged."""
    bad = ~np.isfinite(texels) | (np.abs(texels) > INTENSITY_MAX)
    if not bad.any():
        return ""
    row, column, _ = np.argwhere(bad)[0].tolist()
    channel = int(np.argmax(bad[row, column]))
    given = np.asarray(raw)
    exact = given.ndim == 3 and given.dtype.kind == "f" and given.shape[:2] == texels.shape[:2]
    value = float(given[row, column, channel]) if exact else float(texels[row, column, channel])
    return (
        f"texel (row {row}, column {column}) must be a finite number within +-{_show(INTENSITY_MAX)}, got "
        f"{_show(value)}"
    )


def _background_image(reader: _Reader, folder: str | Path | None) -> np.ndarray:
    """The "image" background's equirectangular picture: "image", a PNG or .npy file's path (relative to the scene
    file's folder), or "pixels", the texels themselves (rows of [r, g, b], top row first; from the add-on in the
    same process an (H, W, 3) array), in "colorspace" (sRGB decoded, linear kept) -> (H, W, 3) float32 linear.
    A 1 x 1 black picture stands in where it is unusable (the problem is reported)."""
    fallback = np.zeros((1, 1, 3), dtype=np.float32)
    colorspace = reader.choice("colorspace", tx.COLORSPACES, "sRGB")
    given = [key for key in ("image", "pixels") if key in reader.data]
    if len(given) != 1:
        message = 'give the picture either by a file\'s path ("image") or inline ("pixels")'
        reader.fail(given[1] if given else "image", message + (", not both" if given else ": one of them is required"))
        for key in given:
            reader.raw(key)
        return fallback
    key = given[0]
    raw = reader.raw(key)
    if key == "image":
        if not isinstance(raw, str) or not raw:
            reader.fail(key, f"must be a PNG or .npy file's path (a non-empty string), got {_show_shape(raw)}")
            return fallback
        path = Path(raw) if folder is None or Path(raw).is_absolute() else Path(folder) / raw
        try:
            raw = tx.read_image(path)
        except tx.TextureFileError as error:
            reader.fail(key, f"{_show(str(path))} {error}")
            return fallback
    elif not isinstance(raw, np.ndarray):
        try:
            raw = np.asarray(raw, dtype=np.float64)
        except (ValueError, TypeError):
            reader.fail(key, "must be rows of texels, each [r, g, b] numbers, every row as long (top row first)")
            return fallback
    try:
        if raw.ndim != 3 or raw.shape[2] not in (3, 4):
            raise tx.TextureFileError(f"must be (height, width, 3 or 4) numbers, got shape {list(raw.shape)}")
        texels = tx.linear_pixels(raw, colorspace)
    except tx.TextureFileError as error:
        reader.fail(key, str(error))
        return fallback
    height, width = texels.shape[:2]
    if max(height, width) > BACKGROUND_SIDE_MAX or height * width > tx.MAX_TEXTURE_PIXELS:
        reader.fail(
            key,
            f"must be at most {BACKGROUND_SIDE_MAX} texels a side and {tx.MAX_TEXTURE_PIXELS} in all, got "
            f"{width} x {height}",
        )
        return fallback
    problem = _unpicturable_texel(texels, raw)
    if problem:
        reader.fail(key, problem)
        return fallback
    texels.flags.writeable = False  # the background keeps it without a copy
    return texels


def _render(reader: _Reader | None, names: dict[str, set[str]] | None = None) -> sc.RenderSettings:
    """names: the scene's object and material names ("object", "material"), which cryptomatte_names may rename."""
    if reader is None:
        return sc.RenderSettings()
    base = sc.RenderSettings()
    settings = sc.RenderSettings(
        width=reader.number("width", base.width, low=1, high=16384, integer=True),
        height=reader.number("height", base.height, low=1, high=16384, integer=True),
        depth=reader.number("depth", base.depth, low=0, high=64, integer=True),
        model=reader.choice("model", sc.MODELS, base.model),
        coef=reader.number("coef", base.coef, low=0.0, low_open=True, high=SPECULAR_MAX),
        samples=reader.number("samples", base.samples, low=1, high=1024, integer=True),
        workers=reader.number("workers", base.workers, low=0, high=256, integer=True),
        dtype=reader.choice("dtype", sc.DTYPES, base.dtype),
        seed=reader.number("seed", base.seed, low=0, high=2**32 - 1, integer=True),
        gate_specular=reader.boolean("gate_specular", base.gate_specular),
        numerics=reader.choice("numerics", sc.NUMERICS, base.numerics),
        pixel_aspect=reader.vector(
            "pixel_aspect", base.pixel_aspect, length=2, low=PIXEL_ASPECT_RANGE[0], high=PIXEL_ASPECT_RANGE[1]
        ),
        film_transparent=reader.boolean("film_transparent", base.film_transparent),
        border=reader.vector("border", None, length=4, low=0.0, high=1.0),
        crop=reader.boolean("crop", base.crop),
        passes=_passes(reader),
        cryptomatte_levels=reader.number(
            "cryptomatte_levels", base.cryptomatte_levels, low=1, high=CRYPTOMATTE_LEVELS_MAX, integer=True
        ),
        cryptomatte_names=_cryptomatte_names(reader, names),
        mist_start=reader.number("mist_start", base.mist_start, low=-COORDINATE_LIMIT, high=COORDINATE_LIMIT),
        mist_depth=reader.number("mist_depth", base.mist_depth, low=0.0, high=COORDINATE_LIMIT),
        mist_falloff=reader.choice("mist_falloff", MIST_FALLOFFS, base.mist_falloff),
        shadow_samples=reader.number("shadow_samples", base.shadow_samples, low=1, high=1024, integer=True),
        glossy_samples=reader.number("glossy_samples", base.glossy_samples, low=1, high=1024, integer=True),
        diffuse_bounces=reader.number("diffuse_bounces", base.diffuse_bounces, low=0, high=64, integer=True),
        adaptive_threshold=reader.number("adaptive_threshold", base.adaptive_threshold, low=0.0, high=1.0),
    )
    border = settings.border
    if border is not None and all(isinstance(x, float) for x in border):
        for axis, low, high in (("x", border[0], border[2]), ("y", border[1], border[3])):
            if not low < high:
                reader.fail("border", f"min_{axis} must be less than max_{axis}, got {_show(low)} and {_show(high)}")
    raw_samples = reader.data.get("samples")
    if isinstance(raw_samples, int) and not isinstance(raw_samples, bool) and 1 <= raw_samples <= 1024:
        samples_problem = check_samples(raw_samples)
        if samples_problem:
            reader.fail("samples", samples_problem)
    raw_shadow = reader.data.get("shadow_samples")
    if isinstance(raw_shadow, int) and not isinstance(raw_shadow, bool) and 1 <= raw_shadow <= 1024:
        shadow_problem = check_samples(raw_shadow)
        if shadow_problem:
            reader.fail("shadow_samples", shadow_problem.replace("stratified grid", "stratified grid over a light"))
    reader.finish()
    return settings


def _passes(reader: _Reader) -> tuple[str, ...]:
    """render.passes: a list of pass names (tracer/scene/passes.py), kept in the registry's order."""
    raw = reader.raw("passes", [])
    if not isinstance(raw, list) or not all(isinstance(name, str) for name in raw):
        reader.fail("passes", f"must be a list of pass names, got {_show_shape(raw)}")
        return ()
    unknown = [name for name in raw if name not in PASSES]
    if unknown:
        reader.fail("passes", f"unknown pass {_show(unknown[0])} (one of {', '.join(PASSES)})")
        return ()
    return tuple(name for name in PASSES if name in raw)


def _cryptomatte_names(reader: _Reader, names: dict[str, set[str]] | None) -> tuple[tuple[str, str, str], ...]:
    """render.cryptomatte_names: {"objects": {scene name: name}, "materials": {...}}, the names Cryptomatte's IDs
    and manifest give the scene's objects and materials where they are not their own (a Blender export's: the
    Blender names, as Cycles writes them) -> sorted (kind, scene name, name) triples."""
    table = reader.reader("cryptomatte_names")
    if table is None:
        return ()
    found = []
    for key, kind in (("objects", "object"), ("materials", "material")):
        raw = table.raw(key, {})
        if not isinstance(raw, dict) or not all(isinstance(value, str) and value for value in raw.values()):
            table.fail(key, f"must map names to non-empty names, got {_show_shape(raw)}")
            continue
        unknown = [name for name in raw if names is not None and name not in names[kind]]
        if unknown:
            table.fail(key, f"names no {kind} of the scene: {_show(unknown[0])}")
            continue
        found += [(kind, name, value) for name, value in raw.items()]
    table.finish()
    return tuple(sorted(found))


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
        pivot=reader.position("pivot", (0.0, 0.0, 0.0)),
        axis=reader.vector("axis", (0.0, 0.0, 1.0), nonzero=True, low=-COORDINATE_LIMIT, high=COORDINATE_LIMIT),
        heading=reader.number("heading", 0.0, low=-ANGLE_LIMIT, high=ANGLE_LIMIT),
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
                    time=key_reader.number("time", low=0.0, high=1e7),
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
            time_scale=gust_reader.number("time_scale", 2.0, low=0.0, low_open=True, least=1e-3, high=1e6),
            seed=gust_reader.number("seed", 0, low=0, high=2**32 - 1, integer=True),
        )
        gust_reader.finish()
    start = reader.number("start", 0.0, low=0.0, high=1e7)
    stop = reader.number("stop", None, low=0.0, high=1e7)
    if stop is not None and isinstance(start, float) and isinstance(stop, float) and stop <= start:
        reader.fail("stop", f"must be after start ({_show(start)}), got {_show(stop)}")
    wind = wi.Wind(keys=tuple(keys) or wi.Wind().keys, gusts=gusts, start=start, stop=stop)
    reader.finish()
    return wind


def _spin(reader: _Reader | None) -> mo.Spin:
    if reader is None:
        return mo.Spin()
    base = mo.Spin()
    start = reader.number("start", base.start, low=0.0, high=1e7)
    stop = reader.number("stop", None, low=0.0, high=1e7)
    if stop is not None and isinstance(start, float) and isinstance(stop, float) and stop < start:
        reader.fail("stop", f"must not be before start ({_show(start)}), got {_show(stop)}")
    spin = mo.Spin(
        direction=reader.choice("direction", ("clockwise", "counterclockwise"), base.direction),
        speed=reader.number("speed", base.speed, low=0.0, high=3600.0),
        smoothness=reader.number("smoothness", base.smoothness, low=0.0, high=1e6),
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
        wavelength=reader.number("wavelength", base.wavelength, low=0.0, low_open=True, least=1e-3, high=1e6),
        threshold=reader.number("threshold", base.threshold, low=0.0, high=60.0),
        friction_time=reader.number("friction_time", base.friction_time, low=0.0, low_open=True, least=1e-3, high=1e6),
        initial_heading=reader.number("initial_heading", None, low=-ANGLE_LIMIT, high=ANGLE_LIMIT),
        fps=reader.number("fps", base.fps, low=0.0, low_open=True, high=1000.0),
        wind=wind,
        spin=_spin(reader.reader("spin")),
    )
    reader.finish()
    return motion


# ---- entry points ------------------------------------------------------------------------------------------------


def scene_from_dict(
    data: Any, source: str = "scene", base: str | Path | None = None, kept: LoadedParts | None = None
) -> sc.Scene:
    """Validate a parsed JSON document and build the Scene; raises SceneError listing every problem. base: the
    folder that textures' relative image paths start from (the scene file's; None: the current directory). kept:
    the last load's parts (reuse.LoadedParts), used again where the document's are the same, and replaced by this
    load's when it succeeds."""
    problems: list[str] = []
    top = _Reader(data, "", problems)
    if not isinstance(data, dict):
        raise SceneError(problems, source)
    if kept is not None:
        kept.reused = 0
        whole = kept.whole(data)
        if whole is not None:
            return whole
    top.raw("$schema", None)
    top.raw("comment", None)

    materials: dict[str, sc.Material] = {}
    built_materials: dict[str, tuple[Any, sc.Material]] = {}  # name -> (its part of the document, what it built)
    built_objects: list[tuple[Any, sc.SceneObject | None]] = []
    raw_materials = top.raw("materials")
    if raw_materials is not ...:
        if not isinstance(raw_materials, dict) or not raw_materials:
            top.fail("materials", f"must be a non-empty object of name: material, got {_show_shape(raw_materials)}")
        else:
            for name, body in raw_materials.items():
                material = None if kept is None else kept.material(name, body)
                if material is None:
                    material = _material(_Reader(body, f"materials.{name}", problems), base)
                materials[name] = material
                built_materials[name] = (body, material)

    raw_meshes = top.data.get("meshes")
    meshes = _mesh_table(top.reader("meshes"), materials)
    objects: list[sc.SceneObject] = []
    object_context = (sorted(materials), raw_meshes)
    raw_objects = top.raw("objects")
    if raw_objects is not ...:
        if not isinstance(raw_objects, list):  # an empty list is a scene of background only
            top.fail("objects", f"must be a list of objects, got {_show_shape(raw_objects)}")
        else:
            prior: list[sc.SceneObject | None] = [None] * len(raw_objects)
            if kept is not None and kept.objects_usable(*object_context):
                prior = [kept.object(i, body) for i, body in enumerate(raw_objects)]
            checked = _meshes_in_bulk([body for body, made in zip(raw_objects, prior, strict=True) if made is None])
            for i, body in enumerate(raw_objects):
                made = prior[i]
                if made is None:
                    made = _object(_Reader(body, f"objects[{i}]", problems), materials, i, meshes, checked)
                built_objects.append((body, made))
                if made is not None:
                    objects.append(made)
    names = [obj.name for obj in objects]
    seen_names: set[str] = set()
    for i, name in enumerate(names):
        if name in seen_names:
            problems.append(f"objects[{i}].name: must be unique, got {_show(name)} twice")
        seen_names.add(name)

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
    background = _background(top.reader("background"), base)
    render = _render(top.reader("render"), {"object": set(names), "material": set(materials)})
    vane = _vane(top.reader("vane"), set(names))
    motion = _motion(top.reader("motion"), top.reader("wind"))
    _same_pose_counts(objects, camera, problems)
    top.finish()
    if problems:
        raise SceneError(problems, source)
    scene = sc.Scene(
        materials=materials,
        objects=tuple(objects),
        lights=tuple(lights),
        camera=camera,
        background=background,
        render=render,
        vane=vane,
        motion=motion,
    )
    if kept is not None:
        kept.remember(data, scene, built_materials, built_objects, object_context)
    return scene


def load_scene(path: str | Path) -> sc.Scene:
    """Read and validate a JSON scene file; raises SceneError (unreadable file, bad JSON, bad fields)."""
    source = str(path)
    return scene_from_dict(parse_json(_read_scene_bytes(Path(path), source), source), source, Path(path).parent)


def _read_scene_bytes(path: Path, source: str) -> bytes:
    """The file's bytes, refusing before reading what is not a regular file (a FIFO would wait forever, a device
    never ends) or is larger than MAX_SCENE_BYTES."""
    try:
        status = path.stat()
        if stat.S_ISDIR(status.st_mode):
            raise SceneError(["is a folder, not a scene file"], source)
        if not stat.S_ISREG(status.st_mode):
            raise SceneError(["must be a regular file (this is a device, a pipe or a socket)"], source)
        if status.st_size > MAX_SCENE_BYTES:
            raise SceneError(
                [f"is {status.st_size} bytes; scene files of at most {MAX_SCENE_BYTES} bytes are read"], source
            )
        with path.open("rb") as stream:
            data = stream.read(MAX_SCENE_BYTES + 1)
    except OSError as error:
        raise SceneError([f"cannot read the file ({error.strerror or error})"], source) from None
    if len(data) > MAX_SCENE_BYTES:  # it grew while being read
        raise SceneError([f"is larger than {MAX_SCENE_BYTES} bytes, the most a scene file may be"], source)
    return data


class _JSONObject(dict):
    """A JSON object that remembers the keys it saw more than once (json keeps the last silently)."""

    duplicates: tuple[str, ...] = ()


def _object_pairs(pairs: list[tuple[str, Any]]) -> _JSONObject:
    made = _JSONObject(pairs)
    if len(made) != len(pairs):
        counted: dict[str, int] = {}
        for key, _ in pairs:
            counted[key] = counted.get(key, 0) + 1
        made.duplicates = tuple(key for key, count in counted.items() if count > 1)
    return made


def parse_json(data: bytes | str, source: str = "scene") -> Any:
    """JSON text -> Python values, with duplicate keys remembered; raises SceneError for what is not JSON."""
    try:
        text = data.decode("utf-8") if isinstance(data, bytes) else data
    except UnicodeDecodeError:
        raise SceneError(["is not UTF-8 text"], source) from None
    try:
        return json.loads(text, parse_constant=_reject_constant, object_pairs_hook=_object_pairs)
    except json.JSONDecodeError as error:
        raise SceneError([f"line {error.lineno} column {error.colno}: invalid JSON: {error.msg}"], source) from None
    except RecursionError:
        raise SceneError(["nests objects and lists too deeply to read (a scene needs 5 levels)"], source) from None
    except ValueError as error:  # a constant (NaN, Infinity), an integer of over 4300 digits
        raise SceneError([f"invalid JSON: {error}"], source) from None


def _reject_constant(name: str) -> float:
    raise ValueError(f"{name} is not a number JSON allows")


def default_scene_dict() -> dict[str, Any]:
    """The embedded default weathervane as a JSON document."""
    text = resources.files(__package__).joinpath(DEFAULT_SCENE_RESOURCE).read_text(encoding="utf-8")
    return json.loads(text)


def default_scene() -> sc.Scene:
    """The embedded default weathervane, used when no scene file is given."""
    return scene_from_dict(default_scene_dict(), "default scene")
