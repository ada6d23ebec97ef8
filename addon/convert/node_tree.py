"""A Blender shader node tree (a material's, a light's, a world's) -> the graph Blender evaluates, and its constants.

Cycles flattens a node tree before it compiles it (intern/cycles/blender/shader.cpp): group nodes are replaced by
their contents at any depth, reroutes and muted nodes pass their input through, and an input that nothing feeds
holds its own value. The conversions read the tree the same way through this module, without copying it:

- `Node` and `Socket` stand for a node and a socket at one place in the flattened graph: the bpy node or socket and
  the group nodes around it (`path`, outermost first). They answer what bpy's do (`node.inputs["Color"]`,
  `socket.default_value`, `node.image`, ...), except that a socket is linked only where something in the flattened
  graph feeds it, and an input's `default_value` is the value it holds there (an unconnected group input's: the
  group node's socket's).
- `source(socket)`: the node and output that feed an input, through groups, reroutes and muted nodes.
- `constant(socket)`: an input's value where it does not depend on the shading point: its own, or what Value, RGB,
  Math, Vector Math, Map Range, Clamp, Invert, Mix, Separate / Combine (RGB, XYZ, Color), Color Ramp, RGB Curves,
  Gamma, Bright/Contrast, Hue/Saturation/Value and RGB to BW make of constant inputs, with Blender's conversions
  between socket types (a colour read as a number is its luminance, a number read as a colour is grey). A product
  with a constant 0 is 0 whatever the other factor (Math Multiply, Multiply Add's product, Vector Math Multiply,
  Scale, Dot and Cross Product, a Mix in Multiply blend of a black A, or of a black B at factor 1): Cycles' arithmetic
  gives exactly 0 for any finite factor (its constant folding does the same, scene/constant_fold.cpp).
- Geometry > Backfacing is a constant too: 0, as front faces (what a camera sees of a closed mesh from outside), or
  1 inside `back_faces()`; a conversion that finds `reads_backfacing(tree)` reads the tree both ways and names what
  differs.
- `own_normal(socket)`: whether a shader's Normal input is the surface's own shading normal as Cycles computes it
  (unlinked; Geometry > Normal; a flat Normal Map: tangent-space colour (0.5, 0.5, 1) or Strength <= 0; a Bump of
  Strength <= 0 or a constant Height, its own Normal input passed on; and linear arithmetic on these that leaves a
  positive multiple of the normal, e.g. glTF's Separate XYZ, x NormalScale 1, Combine XYZ, Normalize).
"""

from __future__ import annotations

import contextlib
import contextvars
import math
from collections.abc import Iterator

import numpy as np

LUMINANCE = (0.2126, 0.7152, 0.0722)  # Cycles' colour -> number (the default OpenColorIO config's, 3.4 to 5.0)
MAX_DEPTH = 64  # links followed for one input: more is a cycle (Blender refuses them, a corrupt file may not)
PASS_THROUGH = ("NodeReroute",)
GROUP_NODES = ("ShaderNodeGroup", "NodeGroup")
# Geometry > Backfacing as the walker reads it: 0 (front faces) unless inside back_faces()
_BACK_FACES: contextvars.ContextVar[bool] = contextvars.ContextVar("back_faces", default=False)


class Socket:
    """A socket in the flattened graph: the bpy socket and the group nodes around it (outermost first)."""

    __slots__ = ("bpy", "path")

    def __init__(self, socket, path: tuple = ()) -> None:
        self.bpy, self.path = socket, path

    def __getattr__(self, name: str):
        return getattr(self.bpy, name)

    def __eq__(self, other: object) -> bool:
        return isinstance(other, Socket) and self.bpy == other.bpy and self.path == other.path

    def __hash__(self) -> int:
        return hash((self.bpy.as_pointer(), tuple(node.as_pointer() for node in self.path)))

    @property
    def node(self) -> Node:
        return Node(self.bpy.node, self.path)

    @property
    def is_linked(self) -> bool:
        """Whether a node feeds this input in the flattened graph (an output: whether it feeds anything)."""
        if self.bpy.is_output or not self.bpy.is_linked:
            return self.bpy.is_linked
        return source(self)[0] is not None

    @property
    def default_value(self):
        """An input's value where nothing feeds it: its own, or the group node's socket it reaches through a Group
        Input; an output's own."""
        if self.bpy.is_output:
            return self.bpy.default_value
        held = _resolve(self)
        return (held if held is not None and not held.bpy.is_output else self).bpy.default_value


class _Sockets:
    """A node's inputs or outputs as Sockets, looked up as bpy's are (by name, index or .get)."""

    __slots__ = ("_made", "_path", "_sockets")

    def __init__(self, sockets, path: tuple) -> None:
        self._sockets, self._path, self._made = sockets, path, {}

    def __getitem__(self, key) -> Socket:
        made = self._made.get(key)
        if made is None:
            made = self._made[key] = Socket(self._sockets[key], self._path)
        return made

    def get(self, key, default=None) -> Socket | None:
        socket = self._sockets.get(key)
        return default if socket is None else Socket(socket, self._path)

    def __iter__(self) -> Iterator[Socket]:
        return (Socket(socket, self._path) for socket in self._sockets)

    def __len__(self) -> int:
        return len(self._sockets)

    def __contains__(self, key) -> bool:
        return key in self._sockets


class Node:
    """A node in the flattened graph: the bpy node and the group nodes around it (outermost first)."""

    __slots__ = ("_sockets", "bpy", "path")

    def __init__(self, node, path: tuple = ()) -> None:
        self.bpy, self.path, self._sockets = node, path, None

    def __getattr__(self, name: str):
        return getattr(self.bpy, name)

    def __eq__(self, other: object) -> bool:
        return isinstance(other, Node) and self.bpy == other.bpy and self.path == other.path

    def __hash__(self) -> int:
        return hash((self.bpy.as_pointer(), tuple(node.as_pointer() for node in self.path)))

    @property
    def inputs(self) -> _Sockets:
        if self._sockets is None:  # made once: a conversion asks a Principled BSDF for its inputs dozens of times
            self._sockets = _Sockets(self.bpy.inputs, self.path)
        return self._sockets

    @property
    def outputs(self) -> _Sockets:
        return _Sockets(self.bpy.outputs, self.path)

    @property
    def path_name(self) -> str:
        """The node's name as the notes give it: inside groups, the groups' names before it (each group node's
        node tree, as its header shows it)."""
        groups = [group.node_tree.name if group.node_tree is not None else group.name for group in self.path]
        return " > ".join([*groups, self.bpy.name])


def wrap(socket_or_node):
    """A bpy socket or node of a tree's top level as a Socket or Node (one already wrapped: itself)."""
    if isinstance(socket_or_node, Socket | Node):
        return socket_or_node
    if hasattr(socket_or_node, "is_output"):
        return Socket(socket_or_node)
    return Node(socket_or_node)


def _group_output(tree):
    """The Group Output node a group's outputs come from: the active one, else the first."""
    outputs = [node for node in tree.nodes if node.bl_idname == "NodeGroupOutput"]
    return ([node for node in outputs if getattr(node, "is_active_output", False)] or outputs or [None])[0]


def _by_identifier(sockets, identifier: str):
    return next((socket for socket in sockets if socket.identifier == identifier), None)


def _step(socket: Socket) -> Socket | None:
    """One hop back from an input: the output that feeds it (a node's, in the flattened graph), the input that
    stands for it (through a reroute, a muted node, a group's boundary), or None where nothing feeds it."""
    bpy_socket, path = socket.bpy, socket.path
    if not bpy_socket.is_linked:  # first: bpy's `links` walks the whole tree's links in Python
        return None
    links = [link for link in bpy_socket.links if link.is_valid and not getattr(link, "is_muted", False)]
    if not links:
        return None
    link = links[0]
    node, output = link.from_node, link.from_socket
    if node.bl_idname in PASS_THROUGH:
        return Socket(node.inputs[0], path)
    if node.mute:  # a muted node passes its internal links' inputs through (nothing: the output's own value)
        passed = next((inner.from_socket for inner in node.internal_links if inner.to_socket == output), None)
        return Socket(passed, path) if passed is not None else Socket(output, path)
    if node.bl_idname in GROUP_NODES:
        tree = node.node_tree
        inner = _group_output(tree) if tree is not None else None
        inner_input = _by_identifier(inner.inputs, output.identifier) if inner is not None else None
        if inner_input is None:  # an empty group, or an output its tree no longer has: the output's own value
            return Socket(output, path)
        return Socket(inner_input, (*path, node))
    if node.bl_idname == "NodeGroupInput":
        if not path:  # a Group Input at a tree's top level (a group edited on its own): nothing outside it
            return Socket(output, path)
        group = path[-1]
        outer = _by_identifier(group.inputs, output.identifier)
        return Socket(outer, path[:-1]) if outer is not None else Socket(output, path)
    return Socket(output, path)


def _resolve(socket: Socket) -> Socket | None:
    """The output that feeds an input in the flattened graph, or the unlinked input whose value it holds (None
    where the links run in a circle)."""
    if not socket.bpy.is_linked:  # the common case: an input that holds its own value
        return socket
    current = socket
    for _ in range(MAX_DEPTH):
        if current.bpy.is_output:
            return current
        found = _step(current)
        if found is None:
            return current
        current = found
    return None


def source(socket) -> tuple[Node | None, Socket | None]:
    """The node and output that feed an input (a bpy socket or a Socket) in the flattened graph, or (None, None)."""
    if not (socket.bpy if isinstance(socket, Socket) else socket).is_linked:  # the common case, without wrapping
        return None, None
    found = _resolve(wrap(socket))
    if found is None or not found.bpy.is_output:
        return None, None
    node = found.bpy.node
    if node.bl_idname in PASS_THROUGH or node.mute or node.bl_idname in (*GROUP_NODES, "NodeGroupInput"):
        return None, None  # an output standing for its own value (a muted node without a path, an empty group)
    return Node(node, found.path), found


def nodes(tree, path: tuple = ()) -> Iterator[Node]:
    """Every node of a tree and of the groups in it, at any depth (each group's contents once per group node)."""
    for node in tree.nodes:
        if node.bl_idname in GROUP_NODES and node.node_tree is not None and len(path) < MAX_DEPTH:
            yield from nodes(node.node_tree, (*path, node))
        else:
            yield Node(node, path)


# --- constants ---------------------------------------------------------------------------------------------------


def luminance(color) -> float:
    return sum(w * float(c) for w, c in zip(LUMINANCE, color[:3], strict=True))


def as_number(value) -> float | None:
    """A constant as a number input reads it: a colour or vector by its luminance (Cycles' conversion)."""
    if value is None:
        return None
    if isinstance(value, tuple):
        return luminance(value) if len(value) >= 3 else float(value[0])
    return float(value)


def as_color(value) -> tuple[float, float, float] | None:
    """A constant as a colour or vector input reads it: a number repeated."""
    if value is None:
        return None
    if isinstance(value, tuple):
        return (*value, 0.0, 0.0, 0.0)[:3]
    return (float(value),) * 3


def _own(socket: Socket):
    """A resolved socket's own value (an unlinked input's, or an output's): a float, a (3,) tuple or None."""
    value = socket.bpy.default_value
    if isinstance(value, int | float):
        return float(value)
    try:
        return tuple(float(c) for c in value[:3])
    except TypeError:  # a shader socket: no value
        return None


def constant(socket, depth: int = 0):
    """An input's value where it is the same at every shading point: a float, a (3,) tuple (colour or vector), or
    None where it depends on the point (a texture, coordinates, attributes) or on what this module does not fold."""
    socket = wrap(socket)
    found = _resolve(socket)
    if found is None or depth > MAX_DEPTH:
        return None
    node = found.bpy.node
    if not found.bpy.is_output or node.bl_idname in (*PASS_THROUGH, *GROUP_NODES, "NodeGroupInput") or node.mute:
        value = _own(found)  # an unlinked input, or an output that stands for its own value
    else:
        value = _fold(Node(node, found.path), found, depth + 1)
    if value is None:
        return None
    kind = getattr(socket.bpy, "type", "VALUE")
    if kind in ("VALUE", "INT", "BOOLEAN"):
        return as_number(value)
    if kind in ("RGBA", "VECTOR"):
        return as_color(value)
    return value


def constant_number(socket) -> float | None:
    bpy_socket = socket.bpy if isinstance(socket, Socket) else socket
    if not bpy_socket.is_linked and bpy_socket.type == "VALUE":  # the common case, without the walk
        return float(bpy_socket.default_value)
    return as_number(constant(socket))


def constant_color(socket) -> tuple[float, float, float] | None:
    bpy_socket = socket.bpy if isinstance(socket, Socket) else socket
    if not bpy_socket.is_linked and bpy_socket.type in ("RGBA", "VECTOR"):  # the common case, without the walk
        value = bpy_socket.default_value
        return (float(value[0]), float(value[1]), float(value[2]))
    return as_color(constant(socket))


def _inputs(node: Node, depth: int, *names) -> list:
    return [constant(node.inputs[name], depth) for name in names]


@contextlib.contextmanager
def back_faces() -> Iterator[None]:
    """Inside: Geometry > Backfacing reads 1, the tree as Cycles evaluates it on a face seen from behind."""
    token = _BACK_FACES.set(True)
    try:
        yield
    finally:
        _BACK_FACES.reset(token)


def facing_back() -> bool:
    """Whether the walker now reads the tree for back faces (inside back_faces())."""
    return _BACK_FACES.get()


def reads_backfacing(tree) -> bool:
    """Whether a Geometry node's Backfacing output feeds anything in the tree or its groups (then the tree may shade
    back faces otherwise than front faces)."""
    for node in nodes(tree) if tree is not None else ():
        if node.bl_idname == "ShaderNodeNewGeometry":
            output = node.bpy.outputs.get("Backfacing")
            if output is not None and output.is_linked:
                return True
    return False


def _fold(node: Node, output: Socket, depth: int):
    """A node's output from constant inputs, or None."""
    kind = node.bl_idname
    if kind in ("ShaderNodeValue", "ShaderNodeRGB"):
        return _own(output)
    if kind == "ShaderNodeNewGeometry":
        return (1.0 if _BACK_FACES.get() else 0.0) if output.identifier == "Backfacing" else None
    folder = _FOLDERS.get(kind)
    return None if folder is None else folder(node, output, depth)


def _by_id(node: Node) -> dict:
    return {socket.identifier: socket for socket in node.inputs if socket.enabled}


def _fold_math(node: Node, output: Socket, depth: int) -> float | None:
    values = [constant(socket, depth) for socket in node.inputs if socket.enabled]
    if any(value is None for value in values):
        result = _absorbed(node.operation, [as_number(value) for value in values])
    else:
        numbers = [as_number(value) for value in values] + [0.0, 0.0, 0.0]
        result = math_operation(node.operation, *numbers[:3])
    if result is None:
        return None
    return min(1.0, max(0.0, result)) if node.use_clamp else result


def _absorbed(operation: str, numbers: list) -> float | None:
    """A Math node's output where an input varies (None) but a constant 0 factor decides it: a x 0 = 0, and
    Multiply Add's a x 0 + c = c (Cycles' arithmetic for any finite a); None otherwise."""
    if operation == "MULTIPLY" and 0.0 in numbers[:2]:
        return 0.0
    if operation == "MULTIPLY_ADD" and len(numbers) == 3 and 0.0 in numbers[:2] and numbers[2] is not None:
        return numbers[2]
    return None


def math_operation(operation: str, a: float, b: float, c: float) -> float | None:
    """Cycles' svm_math (kernel/svm/math_util.h) for one operation, None for one not folded."""
    simple = {
        "ADD": lambda: a + b,
        "SUBTRACT": lambda: a - b,
        "MULTIPLY": lambda: a * b,
        "DIVIDE": lambda: a / b if b != 0.0 else 0.0,
        "MULTIPLY_ADD": lambda: a * b + c,
        "POWER": lambda: _safe_power(a, b),
        "LOGARITHM": lambda: math.log(a) / math.log(b) if a > 0.0 and b > 0.0 and b != 1.0 else 0.0,
        "SQRT": lambda: math.sqrt(a) if a > 0.0 else 0.0,
        "INVERSE_SQRT": lambda: 1.0 / math.sqrt(a) if a > 0.0 else 0.0,
        "ABSOLUTE": lambda: abs(a),
        "EXPONENT": lambda: math.exp(a) if a < 700.0 else math.inf,
        "MINIMUM": lambda: min(a, b),
        "MAXIMUM": lambda: max(a, b),
        "LESS_THAN": lambda: float(a < b),
        "GREATER_THAN": lambda: float(a > b),
        "SIGN": lambda: math.copysign(1.0, a) if a != 0.0 else 0.0,
        "COMPARE": lambda: float(abs(a - b) <= max(c, 1e-5)),
        "SMOOTH_MIN": lambda: _smooth_min(a, b, c),
        "SMOOTH_MAX": lambda: -_smooth_min(-a, -b, c),
        "ROUND": lambda: math.floor(a + 0.5),
        "FLOOR": lambda: math.floor(a),
        "CEIL": lambda: math.ceil(a),
        "TRUNC": lambda: float(math.trunc(a)),
        "FRACT": lambda: a - math.floor(a),
        "MODULO": lambda: math.fmod(a, b) if b != 0.0 else 0.0,
        "FLOORED_MODULO": lambda: a - math.floor(a / b) * b if b != 0.0 else 0.0,
        "WRAP": lambda: _wrap(a, b, c),
        "SNAP": lambda: math.floor(a / b) * b if b != 0.0 else 0.0,
        "PINGPONG": lambda: _pingpong(a, b),
        "SINE": lambda: math.sin(a),
        "COSINE": lambda: math.cos(a),
        "TANGENT": lambda: math.tan(a),
        "SINH": lambda: math.sinh(a),
        "COSH": lambda: math.cosh(a),
        "TANH": lambda: math.tanh(a),
        "ARCSINE": lambda: math.asin(min(1.0, max(-1.0, a))),
        "ARCCOSINE": lambda: math.acos(min(1.0, max(-1.0, a))),
        "ARCTANGENT": lambda: math.atan(a),
        "ARCTAN2": lambda: math.atan2(a, b),
        "RADIANS": lambda: math.radians(a),
        "DEGREES": lambda: math.degrees(a),
    }
    function = simple.get(operation)
    if function is None:
        return None
    try:
        return float(function())
    except (OverflowError, ValueError):
        return None


def _safe_power(a: float, b: float) -> float:
    if a < 0.0 and b != math.floor(b):  # Cycles' safe_powf: a negative base with a fractional exponent gives 0
        return 0.0
    try:
        return a**b
    except ZeroDivisionError:
        return 0.0


def _smooth_min(a: float, b: float, c: float) -> float:
    if c == 0.0:
        return min(a, b)
    h = max(c - abs(a - b), 0.0) / c
    return min(a, b) - h * h * h * c / 6.0


def _wrap(value: float, high: float, low: float) -> float:
    span = high - low
    return value - span * math.floor((value - low) / span) if span != 0.0 else low


def _pingpong(a: float, b: float) -> float:
    if b == 0.0:
        return 0.0
    x = (a - b) / (b * 2.0)
    return abs((x - math.floor(x)) * b * 2.0 - b)


def _fold_vector_math(node: Node, output: Socket, depth: int):
    by_id = _by_id(node)
    values = {key: constant(socket, depth) for key, socket in by_id.items()}
    if any(value is None for value in values.values()):
        return _vector_absorbed(node.operation, values)
    a, b, c = (as_color(values.get(key, (0.0, 0.0, 0.0))) for key in ("Vector", "Vector_001", "Vector_002"))
    scale = as_number(values.get("Scale", 1.0))
    operation = node.operation
    per = {
        "ADD": lambda x, y, _z: x + y,
        "SUBTRACT": lambda x, y, _z: x - y,
        "MULTIPLY": lambda x, y, _z: x * y,
        "DIVIDE": lambda x, y, _z: x / y if y != 0.0 else 0.0,
        "MULTIPLY_ADD": lambda x, y, z: x * y + z,
        "ABSOLUTE": lambda x, _y, _z: abs(x),
        "MINIMUM": lambda x, y, _z: min(x, y),
        "MAXIMUM": lambda x, y, _z: max(x, y),
        "FLOOR": lambda x, _y, _z: math.floor(x),
        "CEIL": lambda x, _y, _z: math.ceil(x),
        "FRACTION": lambda x, _y, _z: x - math.floor(x),
    }
    if operation in per:
        return tuple(float(per[operation](x, y, z)) for x, y, z in zip(a, b, c, strict=True))
    dot = sum(x * y for x, y in zip(a, b, strict=True))
    length = math.sqrt(sum(x * x for x in a))
    if operation == "SCALE":
        return tuple(x * scale for x in a)
    if operation == "DOT_PRODUCT":
        return dot
    if operation == "LENGTH":
        return length
    if operation == "DISTANCE":
        return math.dist(a, b)
    if operation == "NORMALIZE":
        return tuple(x / length for x in a) if length > 0.0 else (0.0, 0.0, 0.0)
    if operation == "CROSS_PRODUCT":
        return (a[1] * b[2] - a[2] * b[1], a[2] * b[0] - a[0] * b[2], a[0] * b[1] - a[1] * b[0])
    return None


def _vector_absorbed(operation: str, values: dict):
    """A Vector Math node's output where an input varies but a constant zero factor decides it (Multiply or Dot or
    Cross Product by the zero vector, Scale of it or by 0): zero, as Cycles computes it for finite inputs."""
    zero = [key for key, value in values.items() if value is not None and not any(as_color(value))]
    if operation in ("MULTIPLY", "CROSS_PRODUCT") and {"Vector", "Vector_001"} & set(zero):
        return (0.0, 0.0, 0.0)
    if operation == "DOT_PRODUCT" and {"Vector", "Vector_001"} & set(zero):
        return 0.0
    if operation == "SCALE" and {"Vector", "Scale"} & set(zero):
        return (0.0, 0.0, 0.0)
    return None


def _fold_rgb_to_bw(node: Node, output: Socket, depth: int) -> float | None:
    """RGB to BW: the colour's luminance (Cycles' linear_rgb_to_gray, the scene-linear space's Y weights)."""
    return as_number(as_color(constant(node.inputs["Color"], depth)))


def _fold_clamp(node: Node, output: Socket, depth: int) -> float | None:
    value, low, high = (as_number(v) for v in _inputs(node, depth, "Value", "Min", "Max"))
    if None in (value, low, high):
        return None
    if getattr(node, "clamp_type", "MINMAX") == "RANGE" and low > high:
        low, high = high, low
    return min(max(value, low), high)


def _fold_map_range(node: Node, output: Socket, depth: int) -> float | None:
    if getattr(node, "data_type", "FLOAT") != "FLOAT":
        return None
    names = ("Value", "From Min", "From Max", "To Min", "To Max", "Steps")
    by_name = {socket.name: socket for socket in _by_id(node).values()}
    values = {name: as_number(constant(by_name[name], depth)) for name in names if name in by_name}
    if any(value is None for value in values.values()):
        return None
    x, a, b, c, d = (values[name] for name in names[:5])
    if a == b:
        return 0.0
    t = (x - a) / (b - a)
    kind = node.interpolation_type
    if kind == "STEPPED":
        steps = values.get("Steps", 4.0)
        t = math.floor(t * (steps + 1.0)) / steps if steps > 0.0 else 0.0
    elif kind == "SMOOTHSTEP":
        t = 0.0 if t <= 0.0 else 1.0 if t >= 1.0 else t * t * (3.0 - 2.0 * t)
    elif kind == "SMOOTHERSTEP":
        t = 0.0 if t <= 0.0 else 1.0 if t >= 1.0 else t * t * t * (t * (t * 6.0 - 15.0) + 10.0)
    result = c + t * (d - c)
    if node.clamp and kind in ("LINEAR", "STEPPED"):
        result = min(max(result, min(c, d)), max(c, d))
    return result


def _fold_invert(node: Node, output: Socket, depth: int):
    fac, color = _inputs(node, depth, "Fac", "Color")
    if fac is None or color is None:
        return None
    fac, color = as_number(fac), as_color(color)
    return tuple((1.0 - fac) * c + fac * (1.0 - c) for c in color)


def _fold_mix(node: Node, output: Socket, depth: int):
    """The Mix node (3.4+: float, vector, colour) and MixRGB."""
    if node.bl_idname == "ShaderNodeMixRGB":
        factor, first, second = node.inputs["Fac"], node.inputs["Color1"], node.inputs["Color2"]
        data_type, blend, clamp_factor = "RGBA", node.blend_type, True
        clamp_result = node.use_clamp
    else:
        by_id = {socket.identifier: socket for socket in node.inputs}
        data_type = node.data_type
        suffix = {"FLOAT": "Float", "VECTOR": "Vector", "RGBA": "Color"}.get(data_type)
        if suffix is None:
            return None
        vector_factor = data_type == "VECTOR" and getattr(node, "factor_mode", "UNIFORM") == "NON_UNIFORM"
        factor = by_id["Factor_Vector" if vector_factor else "Factor_Float"]
        first, second = by_id[f"A_{suffix}"], by_id[f"B_{suffix}"]
        blend, clamp_factor = node.blend_type if data_type == "RGBA" else "MIX", node.clamp_factor
        clamp_result = data_type == "RGBA" and node.clamp_result
    values = [constant(socket, depth) for socket in (factor, first, second)]
    if any(value is None for value in values):
        return _mix_absorbed(data_type, blend, clamp_factor, *values)
    t, a, b = values
    if data_type == "FLOAT":
        t, a, b = as_number(t), as_number(a), as_number(b)
        t = min(1.0, max(0.0, t)) if clamp_factor else t
        return (1.0 - t) * a + t * b
    a, b = as_color(a), as_color(b)
    ts = as_color(t) if isinstance(t, tuple) else (as_number(t),) * 3
    ts = tuple(min(1.0, max(0.0, x)) for x in ts) if clamp_factor else ts
    if data_type == "VECTOR":
        return tuple((1.0 - x) * p + x * q for x, p, q in zip(ts, a, b, strict=True))
    mixed = blend_colors(blend, ts[0], a, b)
    if mixed is None:
        return None
    return tuple(min(1.0, max(0.0, c)) for c in mixed) if clamp_result else mixed


def _mix_absorbed(data_type: str, blend: str, clamp_factor: bool, t, a, b) -> tuple | None:
    """A colour Mix in Multiply blend, a x (1 - t + t b), where an input varies but a black factor decides it: a
    black A whatever t and B, a black B at factor 1: black (Cycles' svm_mix for finite inputs); None otherwise."""
    if data_type != "RGBA" or blend != "MULTIPLY":
        return None
    t = as_number(t) if t is not None and not isinstance(t, tuple) else None
    if t is not None and clamp_factor:
        t = min(1.0, max(0.0, t))
    if (a is not None and not any(as_color(a))) or (b is not None and not any(as_color(b)) and t == 1.0):
        return (0.0, 0.0, 0.0)
    return None


def blend_colors(blend: str, t: float, a, b) -> tuple | None:
    """Cycles' svm_mix for the blend types that are per channel (kernel/svm/color_util.h), None for the others."""
    s = 1.0 - t
    per = {
        "MIX": lambda x, y: s * x + t * y,
        "ADD": lambda x, y: x + t * y,
        "MULTIPLY": lambda x, y: x * (s + t * y),
        "SUBTRACT": lambda x, y: x - t * y,
        "SCREEN": lambda x, y: 1.0 - (s + t * (1.0 - y)) * (1.0 - x),
        "DIVIDE": lambda x, y: s * x + t * x / y if y != 0.0 else x,
        "DIFFERENCE": lambda x, y: s * x + t * abs(x - y),
        "EXCLUSION": lambda x, y: max(s * x + t * (x + y - 2.0 * x * y), 0.0),
        "DARKEN": lambda x, y: s * x + t * min(x, y),
        "OVERLAY": lambda x, y: x * (s + 2.0 * t * y) if x < 0.5 else 1.0 - (s + 2.0 * t * (1.0 - y)) * (1.0 - x),
        "LINEAR_LIGHT": lambda x, y: x + t * (2.0 * y - 1.0),
    }
    function = per.get(blend)
    if function is None:
        return None
    return tuple(float(function(x, y)) for x, y in zip(a, b, strict=True))


def _fold_separate(node: Node, output: Socket, depth: int):
    mode = getattr(node, "mode", "RGB")
    if mode != "RGB" and node.bl_idname == "ShaderNodeSeparateColor":
        return None
    value = as_color(constant(node.inputs[0], depth))
    if value is None:
        return None
    index = [socket.identifier for socket in node.outputs].index(output.identifier)
    return value[index] if index < 3 else None


def _fold_combine(node: Node, output: Socket, depth: int):
    mode = getattr(node, "mode", "RGB")
    if mode != "RGB" and node.bl_idname == "ShaderNodeCombineColor":
        return None
    values = [as_number(constant(socket, depth)) for socket in list(node.inputs)[:3]]
    return None if any(value is None for value in values) else tuple(values)


def _fold_ramp(node: Node, output: Socket, depth: int):
    fac = as_number(constant(node.inputs["Fac"], depth))
    if fac is None:
        return None
    color = node.color_ramp.evaluate(min(1.0, max(0.0, fac)))
    return tuple(float(c) for c in color[:3]) if output.name == "Color" else float(color[3])


def _fold_curves(node: Node, output: Socket, depth: int):
    fac, color = as_number(constant(node.inputs["Fac"], depth)), as_color(constant(node.inputs["Color"], depth))
    if fac is None or color is None:
        return None
    mapping = node.mapping
    mapping.initialize()
    curves = mapping.curves
    mapped = [mapping.evaluate(curves[i], mapping.evaluate(curves[3], c)) for i, c in enumerate(color)]
    return tuple((1.0 - fac) * c + fac * m for c, m in zip(color, mapped, strict=True))


def _fold_gamma(node: Node, output: Socket, depth: int):
    color, gamma = as_color(constant(node.inputs["Color"], depth)), as_number(constant(node.inputs["Gamma"], depth))
    if color is None or gamma is None:
        return None
    return tuple(c**gamma if c > 0.0 else c for c in color)


def _fold_bright_contrast(node: Node, output: Socket, depth: int):
    color = as_color(constant(node.inputs["Color"], depth))
    bright, contrast = (as_number(constant(node.inputs[name], depth)) for name in ("Bright", "Contrast"))
    if color is None or bright is None or contrast is None:
        return None
    a = 1.0 + contrast
    b = bright - contrast * 0.5
    return tuple(max(a * c + b, 0.0) for c in color)


def _fold_hsv(node: Node, output: Socket, depth: int):
    color = as_color(constant(node.inputs["Color"], depth))
    settings = [as_number(constant(node.inputs[name], depth)) for name in ("Hue", "Saturation", "Value", "Fac")]
    if color is None or any(value is None for value in settings):
        return None
    return tuple(float(c) for c in hue_saturation(np.asarray(color), *settings))


def hue_saturation(pixels: np.ndarray, hue: float, saturation: float, value: float, fac: float) -> np.ndarray:
    """Cycles' svm_node_hsv on linear colours (..., 3): to HSV, hue + shift + 0.5 wrapped, saturation scaled and
    clamped to [0, 1], value scaled, back to RGB, mixed with the input by fac, clamped at 0."""
    rgb = np.asarray(pixels, dtype=np.float64)
    high, low = rgb.max(axis=-1), rgb.min(axis=-1)
    delta = high - low
    s = np.where(high != 0.0, delta / np.where(high != 0.0, high, 1.0), 0.0)
    c = (high[..., None] - rgb) / np.where(delta != 0.0, delta, 1.0)[..., None]
    h = np.where(
        rgb[..., 0] == high, c[..., 2] - c[..., 1], np.where(rgb[..., 1] == high, 2.0 + c[..., 0] - c[..., 2],
                                                              4.0 + c[..., 1] - c[..., 0])
    )  # fmt: skip
    h = h / 6.0
    h = np.where(h < 0.0, h + 1.0, h)
    h = np.where(s != 0.0, h, 0.0)
    h = np.mod(h + hue + 0.5, 1.0)  # Cycles' fractf (x - floor(x))
    s = np.clip(s * saturation, 0.0, 1.0)
    v = high * value
    h6 = np.where(h == 1.0, 0.0, h) * 6.0
    sector = np.floor(h6)
    f = h6 - sector
    p, q, t = v * (1.0 - s), v * (1.0 - s * f), v * (1.0 - s * (1.0 - f))
    choices = [(v, t, p), (q, v, p), (p, v, t), (p, q, v), (t, p, v), (v, p, q)]
    out = np.zeros_like(rgb)
    for k, (r, g, b) in enumerate(choices):
        where = (sector == k) if k < 5 else (sector >= 5)
        out = np.where(where[..., None], np.stack([r, g, b], axis=-1), out)
    out = np.where((s != 0.0)[..., None], out, v[..., None] * np.ones(3))
    return np.maximum(fac * out + (1.0 - fac) * rgb, 0.0)


_FOLDERS = {
    "ShaderNodeMath": _fold_math,
    "ShaderNodeVectorMath": _fold_vector_math,
    "ShaderNodeClamp": _fold_clamp,
    "ShaderNodeMapRange": _fold_map_range,
    "ShaderNodeInvert": _fold_invert,
    "ShaderNodeMix": _fold_mix,
    "ShaderNodeMixRGB": _fold_mix,
    "ShaderNodeSeparateRGB": _fold_separate,
    "ShaderNodeSeparateXYZ": _fold_separate,
    "ShaderNodeSeparateColor": _fold_separate,
    "ShaderNodeCombineRGB": _fold_combine,
    "ShaderNodeCombineXYZ": _fold_combine,
    "ShaderNodeCombineColor": _fold_combine,
    "ShaderNodeValToRGB": _fold_ramp,
    "ShaderNodeRGBCurve": _fold_curves,
    "ShaderNodeGamma": _fold_gamma,
    "ShaderNodeBrightContrast": _fold_bright_contrast,
    "ShaderNodeHueSaturation": _fold_hsv,
    "ShaderNodeRGBToBW": _fold_rgb_to_bw,
}


# --- the shading normal --------------------------------------------------------------------------------------------

FLAT_NORMAL_COLOR = (0.5, 0.5, 1.0)  # a tangent-space normal map's colour for the unperturbed normal


def own_normal(socket) -> bool:
    """Whether a shader's Normal input (a bpy socket or a Socket) is the surface's own shading normal N as Cycles
    computes it: unlinked, or a positive multiple of N (a BSDF normalises its Normal) by _normal_form."""
    socket = wrap(socket)
    if not socket.is_linked:
        return True
    form = _normal_form(socket, 0)
    if form is None or form.shape != (3, 4) or np.any(np.abs(form[:, 3]) > 1e-6):
        return False
    scale = form[0, 0]
    return scale > 0.0 and bool(np.allclose(form[:, :3], scale * np.eye(3), rtol=1e-6, atol=1e-6 * scale))


def _normal_form(socket: Socket, depth: int) -> np.ndarray | None:
    """An input's value as a linear function of the shading normal N, the matrix F of v = F (N, 1): (3, 4) for a
    vector, (1, 4) for a number; None where it is not one the walker knows (a texture, a real normal map)."""
    if depth > MAX_DEPTH:
        return None
    vector = getattr(socket.bpy, "type", "VALUE") in ("VECTOR", "RGBA")
    value = constant(socket, depth + 1)
    if value is not None:
        column = np.asarray(as_color(value) if vector else (as_number(value),), dtype=np.float64)
        return np.concatenate([np.zeros((column.size, 3)), column[:, None]], axis=1)
    node, output = source(socket)
    if node is None:
        return None
    form = _node_normal_form(node, output, depth + 1)
    if form is None:
        return None
    if vector and form.shape[0] == 1:  # a number read as a vector: repeated
        return np.repeat(form, 3, axis=0)
    return form if (form.shape[0] == 3) == vector else None


def _identity() -> np.ndarray:
    return np.concatenate([np.eye(3), np.zeros((3, 1))], axis=1)


def _node_normal_form(node: Node, output: Socket, depth: int) -> np.ndarray | None:
    kind = node.bl_idname
    if kind == "ShaderNodeNewGeometry":
        return _identity() if output.identifier == "Normal" else None
    if kind == "ShaderNodeNormalMap":  # Cycles' svm_node_normal_map: N where the map says no change
        strength = constant_number(node.inputs["Strength"])
        color = constant_color(node.inputs["Color"])
        flat = color is not None and np.allclose(color, FLAT_NORMAL_COLOR, atol=1e-6) and node.space == "TANGENT"
        return _identity() if flat or (strength is not None and strength <= 0.0) else None
    if kind == "ShaderNodeBump":  # svm_node_set_bump: its Normal input where the height cannot tilt it
        strength = constant_number(node.inputs["Strength"])
        still = constant(node.inputs["Height"], depth) is not None
        if not still and (strength is None or strength > 0.0):
            return None
        normal = node.inputs["Normal"]  # unlinked: N (Cycles links a Normal input that nothing feeds to N)
        return _normal_form(normal, depth) if normal.is_linked else _identity()
    if kind == "ShaderNodeSeparateXYZ":
        form = _normal_form(node.inputs[0], depth)
        index = [socket.identifier for socket in node.outputs].index(output.identifier)
        return None if form is None or index > 2 else form[index : index + 1]
    if kind == "ShaderNodeCombineXYZ":
        rows = [_normal_form(socket, depth) for socket in list(node.inputs)[:3]]
        return None if any(row is None for row in rows) else np.concatenate(rows, axis=0)
    if kind == "ShaderNodeMath" and not node.use_clamp:
        return _linear(node.operation, [_normal_form(s, depth) for s in node.inputs if s.enabled], False)
    if kind == "ShaderNodeVectorMath":
        by_id = _by_id(node)
        forms = [_normal_form(by_id[key], depth) for key in ("Vector", "Vector_001", "Scale") if key in by_id]
        return _linear(node.operation, forms, True)
    return None


def _linear(operation: str, forms: list, vector: bool) -> np.ndarray | None:
    """A Math or Vector Math node's output form where it is linear in N: sums, differences, products and quotients
    by constants, and Normalize of a multiple of N (N is a unit vector)."""
    if any(form is None for form in forms):
        return None

    def constant_part(form):  # the form's value where it does not depend on N, else None
        return form[:, 3] if not np.any(form[:, :3]) else None

    if operation in ("ADD", "SUBTRACT") and len(forms) >= 2:
        return forms[0] + forms[1] if operation == "ADD" else forms[0] - forms[1]
    if operation in ("MULTIPLY", "SCALE", "DIVIDE") and len(forms) >= 2:
        first, second = forms[0], forms[1]
        if operation == "DIVIDE":
            divisor = constant_part(second)
            return None if divisor is None or np.any(divisor == 0.0) else first / divisor[:, None]
        if constant_part(second) is not None:
            return first * constant_part(second)[:, None]
        if constant_part(first) is not None and operation == "MULTIPLY":
            return second * constant_part(first)[:, None]
        return None
    if operation == "NORMALIZE" and vector and forms:
        form = forms[0]
        scale = form[0, 0]
        if scale != 0.0 and not np.any(form[:, 3]) and np.allclose(form[:, :3], scale * np.eye(3)):
            return _identity() * math.copysign(1.0, scale)
    return None
