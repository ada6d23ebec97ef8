"""Node groups as the tests build them: a new group with its sockets, made through the interface (Blender 4.0+) or
the group's own inputs and outputs (3.4)."""

from __future__ import annotations

import bpy


def new_group(name: str, kind: str, inputs: list[tuple[str, str]], outputs: list[tuple[str, str]]):
    """A new node group of kind ("GeometryNodeTree", "ShaderNodeTree") with (name, socket type) inputs and outputs
    -> the group, its Group Input node and its Group Output node."""
    group = bpy.data.node_groups.new(name, kind)
    for sockets, side in ((inputs, "INPUT"), (outputs, "OUTPUT")):
        for socket_name, socket_type in sockets:
            if hasattr(group, "interface"):
                group.interface.new_socket(socket_name, in_out=side, socket_type=socket_type)
            else:
                (group.inputs if side == "INPUT" else group.outputs).new(socket_type, socket_name)
    return group, group.nodes.new("NodeGroupInput"), group.nodes.new("NodeGroupOutput")
