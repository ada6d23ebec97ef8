"""Every text the add-on draws, against its room, with Blender's UI font (blf) in a real window (run inside Blender by
tests/addon/gui_session.py).

Each panel of the add-on (the sidebar's Weathervane tab and its Properties editor panels) is drawn into a Recorder,
a stand-in for UILayout that keeps the layout's tree (rows, columns, splits, property split, lists) with what each
button shows: a field's label and value, a vector's labels and values (a row of label, X, Y, Z in a panel's own
layout, a column under a label in a column, Blender's "Location X / Y / Z" label column with property split), the
current item of a menu (every item in turn: each can be chosen), every item of an expanded enum, a UI list's rows
(its draw_item for every item). Rows share their width as Blender's rows do for these buttons (icon-only columns
take one unit); the room of each text is its share less the button's padding and icon. The panels are drawn in
every state that changes what they show (wind and spin, each background, highlight model, light and material).

Tooltips: each operator's and property's description as Blender holds it is one line (a docstring's line breaks
and indentation show in the tooltip) and, for operators, not cut at Blender's 240-byte limit (RNA_DYN_DESCR_MAX).

Scene Conversion's notes (measure_notes): the panel drawn for the scene as it is, in the Properties editor's region (its
width as the window has it): every text fits its room, and every line of a note is a button whose tooltip (the
operator's description, as Blender asks for it) is the whole note, the lines together the whole note.
"""

from __future__ import annotations

import bpy

VALUE_ROOM = 60.0  # a number field's value: about 8 characters ("600 ms", "200°", "-12.3 m") at 11 points
PADDING = 12.0  # a button's text padding, pixels at scale 1
ICON = 20.0  # an icon or a menu's arrow
LIST_MARGIN = 30.0  # a UI list's box, scroll bar and row padding
MARGIN = 14.0  # a panel's margin on each side
SPLIT = 0.4  # property split's label column (Blender's UI_ITEM_PROP_SEP_DIVIDE)
SEPARATOR = 6.0  # a separator in a row, per unit of its factor (Blender: 0.3 of a UI unit)
DESCRIPTION_MAX = 239  # Blender 3.4's RNA_DYN_DESCR_MAX less its terminating byte: longer operator tips are cut


class Gap(float):
    """A separator's width in a row (pixels at scale 1): room that no text gets."""


class Node:
    """A layout in the tree: a row (children side by side) or a column; a leaf is (text, pixels beside it) or a Gap."""

    def __init__(self, horizontal: bool, factor: float | None = None) -> None:
        self.horizontal, self.factor = horizontal, factor
        self.children: list = []

    def icon_only(self) -> bool:
        leaves = [child for child in self.children if isinstance(child, tuple)]
        nodes = [child for child in self.children if isinstance(child, Node)]
        return bool(self.children) and all(text == "" for text, _ in leaves) and all(n.icon_only() for n in nodes)


class Recorder:
    """A stand-in for a panel's UILayout that builds a Node tree of what is drawn."""

    def __init__(self, node: Node, root: bool = False, split: bool = False) -> None:
        object.__setattr__(self, "node", node)
        object.__setattr__(self, "root", root)
        object.__setattr__(self, "use_property_split", split)

    def __setattr__(self, name: str, value) -> None:
        object.__setattr__(self, name, value)

    def _child(self, horizontal: bool, factor: float | None = None, root: bool = False) -> Recorder:
        node = Node(horizontal, factor)
        self.node.children.append(node)
        return Recorder(node, root=root, split=self.use_property_split)

    def row(self, *args, **kwargs) -> Recorder:
        return self._child(True)

    def split(self, factor: float = 0.0, **kwargs) -> Recorder:
        return self._child(True, factor or None)

    def column(self, *args, **kwargs) -> Recorder:
        return self._child(False)

    def box(self, *args, **kwargs) -> Recorder:
        return self._child(False, root=True)

    def grid_flow(self, *args, **kwargs) -> Recorder:
        return self._child(False)

    def column_flow(self, *args, **kwargs) -> Recorder:
        return self._child(False)

    def __getattr__(self, name: str):
        return lambda *args, **kwargs: None  # menus, decorators: no text of their own

    def separator(self, factor: float = 1.0, **kwargs) -> None:
        if self.node.horizontal:  # in a column it takes height, not width
            self.node.children.append(Gap(SEPARATOR * factor))

    def _add(self, text: str, beside: float) -> None:
        self.node.children.append((text, beside))

    def _field(self, label: str, value_text: str | None, beside: float) -> None:
        """A field with its label: inside it (label and value share it) or, with property split, in the label
        column."""
        if self.use_property_split:
            row = Node(True, SPLIT)
            row.children = [(label, 0.0), (value_text or "", beside if value_text is not None else VALUE_ROOM)]
            self.node.children.append(row)
        elif value_text is None:
            self._add(label, VALUE_ROOM if label else VALUE_ROOM - PADDING)
        else:
            self._add(f"{label} {value_text}" if label else value_text, beside)

    def prop(self, data, name: str, text: str | None = None, expand: bool = False, icon_only: bool = False, **kw):
        rna = data.bl_rna.properties[name]
        label = "" if icon_only else (text if text is not None else rna.name)
        if rna.type == "ENUM":
            items = list(rna.enum_items)
            if expand:
                row = self._child(True)
                for item in items:
                    row._add(item.name, 0.0)  # one button each
            else:  # a menu button: every item can be the one shown
                for item in items:
                    if self.use_property_split:
                        self._field(label, item.name, ICON)
                    elif label:  # the label in a third of the row (Blender's ui_item_with_label)
                        row = Node(True, 1.0 / 3.0)
                        row.children = [(label, 0.0), (item.name, ICON)]
                        self.node.children.append(row)
                    else:
                        self._add(item.name, ICON)
            return
        length = getattr(rna, "array_length", 0)
        if rna.type in ("FLOAT", "INT") and length and rna.subtype not in ("COLOR", "COLOR_GAMMA"):
            axes = "XYZW"[:length]
            if self.use_property_split:
                for index, axis in enumerate(axes):
                    row = Node(True, SPLIT)
                    row.children = [
                        ((f"{label} {axis}" if index == 0 else axis) if label else "", 0.0),
                        ("", VALUE_ROOM),
                    ]
                    self.node.children.append(row)
            elif self.root or self.node.horizontal:  # a row: the label beside the values
                row = self._child(True)
                if label:
                    row._add(label, 0.0)
                for _axis in axes:
                    row._add("", VALUE_ROOM - PADDING)
            else:  # a column: the label above, then "X" and its value in each field
                if label:
                    self._add(label, 0.0)
                for axis in axes:
                    self._add(axis, VALUE_ROOM)
            return
        if rna.type in ("FLOAT", "INT") and not length:
            self._field(label, None, VALUE_ROOM)
        elif rna.type == "BOOLEAN":
            self._add(label, ICON)  # the checkbox
        elif rna.type == "STRING":
            self._field(label, "", 0.0) if label else self._add("", 0.0)
        elif label:  # a colour: its label beside the swatch
            if self.use_property_split:
                self._field(label, "", 0.0)
            else:
                row = self._child(True)
                row._add(label + ":", 0.0)
                row._add("", 0.0)
        else:
            self._add("", 0.0)

    def label(self, text: str = "", icon: str = "NONE", **kwargs) -> None:
        self._add(text, ICON if icon != "NONE" else 0.0)

    def operator(self, idname: str, text: str | None = None, icon: str = "NONE", **kwargs):
        module, name = idname.split(".")
        label = text if text is not None else getattr(getattr(bpy.ops, module), name).get_rna_type().name
        self._add(label, ICON if icon != "NONE" else 0.0)
        properties = _Properties()
        BUTTONS.append((idname, label, properties))
        return properties

    def operator_menu_enum(self, operator: str, property: str, text: str = "", icon: str = "NONE", **kwargs):
        self._add(text, ICON if icon != "NONE" else 0.0)

    def menu(self, menu: str, text: str = "", icon: str = "NONE", **kwargs) -> None:
        self._add(text, ICON + (ICON if icon != "NONE" else 0.0))

    def template_list(self, listtype: str, list_id, data, propname: str, active_data, active_propname, **kwargs):
        """The list's rows, each drawn by the list's draw_item into a row LIST_MARGIN narrower than the list."""
        cls = getattr(bpy.types, listtype)
        holder = type("List", (), {"draw_item": cls.draw_item})()
        box = Node(False)
        box.list = True
        self.node.children.append(box)
        for index, item in enumerate(getattr(data, propname)):
            row = Recorder(box)._child(True)
            holder.draw_item(bpy.context, row, data, item, 0, active_data, active_propname, index)


class _Properties:
    """What layout.operator returns: its properties can be set (and are kept, for the button's tooltip)."""


BUTTONS: list = []  # (operator, text, properties) of every operator button drawn into a Recorder, in order


def needs(node: Node, width: float, scale: float, found: dict, where: str) -> None:
    """Each leaf's share of its room (> 1: cut), the largest per text, into found[text] = (share, where)."""
    import blf

    if getattr(node, "list", False):
        width -= LIST_MARGIN * scale
    if not node.children:
        return
    if node.horizontal:
        fixed = ICON * scale + PADDING * scale
        gaps = [c for c in node.children if isinstance(c, Gap)]
        free = [
            c
            for c in node.children
            if not isinstance(c, Gap) and not (c.icon_only() if isinstance(c, Node) else c == ("", ICON))
        ]
        rest = width - sum(gaps) * scale - fixed * (len(node.children) - len(free) - len(gaps))
        shares = []
        for child in node.children:
            if isinstance(child, Gap):
                shares.append(child * scale)
            elif not any(child is c for c in free):
                shares.append(fixed)
            elif node.factor is not None:
                first = child is node.children[0]
                shares.append(rest * node.factor if first else rest * (1.0 - node.factor) / max(1, len(free) - 1))
            else:
                shares.append(rest / len(free))
    else:
        shares = [width] * len(node.children)
    for child, share in zip(node.children, shares, strict=True):
        if isinstance(child, Node):
            needs(child, share, scale, found, where)
            continue
        if isinstance(child, Gap):
            continue
        text, beside = child
        if not text:
            continue
        room = share - PADDING * scale
        need = (blf.dimensions(0, text)[0] + beside * scale) / room
        if need > found.get(text, (0.0, ""))[0]:
            found[text] = (need, where)


def _states(scene):
    """Setters, each putting the settings in a state that changes what a panel shows, and back."""
    settings = scene.weathervane

    def setting(name, value):
        def apply():
            old = getattr(settings, name)
            setattr(settings, name, value)
            return lambda: setattr(settings, name, old)

        return apply

    states = [lambda: lambda: None]
    for name in ("mode", "background", "model"):
        for item in settings.bl_rna.properties[name].enum_items:
            states.append(setting(name, item.identifier))
    states += [setting("light_index", index) for index in range(len(settings.lights))]
    states += [setting("material_index", index) for index in range(len(settings.materials))]
    return states


def measure(context, sidebar_width: int, properties_width: int | None) -> tuple[dict, list]:
    """found[text] = (share of its room, panel) for every text of every panel in every state, at the given widths;
    and the tooltips that are not one whole line."""
    import blf

    scale = context.preferences.system.ui_scale or 1.0  # 0 in background mode
    if bpy.app.version >= (4, 0, 0):
        blf.size(0, 11 * scale)
    else:
        blf.size(0, 11, int(72 * scale))
    panels = [
        cls
        for cls in bpy.types.Panel.__subclasses__()
        if cls.is_registered
        and (cls.__name__.startswith("WEATHERVANE_") or getattr(cls, "bl_category", "") == "Weathervane")
    ]
    found: dict = {}
    for state in _states(context.scene):
        undo = state()
        try:
            for cls in panels:
                sidebar = cls.bl_space_type == "VIEW_3D"
                width = sidebar_width if sidebar else properties_width
                if width is None:
                    continue
                if hasattr(cls, "poll") and not cls.poll(context):
                    continue
                node = Node(False)
                holder = type("Panel", (), {})()
                holder.layout = Recorder(node, root=True)
                if hasattr(cls, "split_layout"):
                    holder.split_layout = lambda holder=holder, cls=cls: cls.split_layout(holder)
                cls.draw(holder, context)
                needs(node, width - 2 * MARGIN * scale, scale, found, cls.__name__)
                found.setdefault(cls.bl_label, ((blf.dimensions(0, cls.bl_label)[0]) / (width - 60 * scale), "header"))
        finally:
            undo()
    return found, tooltips()


def tooltips() -> list:
    """Descriptions that do not show as one whole line: a line break or indentation, or an operator's cut."""
    import inspect

    bad = []
    settings = bpy.context.scene.weathervane
    groups = [settings] + ([settings.lights[0]] if len(settings.lights) else [])
    groups += [settings.materials[0]] if len(settings.materials) else []
    for group in groups:
        for prop in group.bl_rna.properties:
            texts = [prop.description] + [item.description for item in getattr(prop, "enum_items", [])]
            bad += [f"{group.bl_rna.identifier}.{prop.identifier}: {t!r}" for t in texts if "\n" in t or "  " in t]
    for name in dir(bpy.ops.weathervane):
        rna = getattr(bpy.ops.weathervane, name).get_rna_type()
        cls = getattr(bpy.types, rna.identifier, None)
        written = (getattr(cls, "bl_description", "") or inspect.getdoc(cls) or "") if cls else rna.description
        if "\n" in rna.description or "  " in rna.description or len(written) > DESCRIPTION_MAX:
            bad.append(f"weathervane.{name}: {rna.description!r}")
    return bad


def measure_notes(context, window, area, region) -> tuple[dict, list, list]:
    """Render Properties > Scene Conversion drawn in the Properties editor's region (area, region: the editor's):
    found[text] = (share of its room, panel) for its texts; the notes with each one's lines as its buttons show them;
    and the problems: a button whose tooltip is no note, a note whose buttons' lines do not make the whole note."""
    import re
    import sys

    import blf

    cls = bpy.types.WEATHERVANE_RENDER_PT_conversion
    note_operator = bpy.types.WEATHERVANE_OT_conversion_note
    report = sys.modules["weathervane.convert.conversion_report"]
    scale = context.preferences.system.ui_scale or 1.0
    node = Node(False)
    holder = type("Panel", (), {})()
    holder.layout = Recorder(node, root=True)
    BUTTONS.clear()
    with context.temp_override(window=window, area=area, region=region):
        cls.draw(holder, bpy.context)  # wrapped for the region's width, as Blender draws it there
        rows = report.scene_conversion(bpy.context.scene)
        # each button's tooltip as Blender asks the operator for it
        buttons = [
            (text, note_operator.description(bpy.context, properties))
            for idname, text, properties in BUTTONS
            if idname == note_operator.bl_idname
        ]
    blf.size(0, 11 * scale)
    found: dict = {}
    needs(node, region.width - 2 * MARGIN * scale, scale, found, cls.__name__)
    squeeze = lambda text: re.sub(r"\s+", "", text)  # noqa: E731 - lines end at a space or after a '/', '_', ...
    every = [note for _, _, row in rows for note in row]  # a note twice (two materials): its lines twice
    notes = [(note, [text for text, tip in buttons if tip == note]) for note in dict.fromkeys(every)]
    problems = [f"the tooltip of {text!r} is no note: {tip!r}" for text, tip in buttons if tip not in every]
    for note, lines in notes:
        if squeeze("".join(lines)) != squeeze(note) * every.count(note):
            problems.append(f"{lines!r} are not the note {note!r}")
    return found, notes, problems
