"""Every message whole where the user looks, as Blender's own reports are shown.

- A report longer than the status bar holds (report_whole): the whole text, then a short line. Blender's status bar
  shows the last report of an operator or a render and the Info editor keeps them all, so the bar shows the short
  line and Info the whole text; a failed F12's popup shows both. Without a window, the whole text alone.
- F12 that renders nothing (a refusal before the scene is read, a bad scene, lost workers): the whole text is drawn
  over the render window's empty image, wrapped to the window, under the window's own line (show_in_render_window: a
  draw handler of the Image editor while it shows the Render Result slot that the failed render went into; the next
  render, or another file, takes it away).
- The Rendered view: the engine's text in the view (update_stats, which the view draws line by line) wrapped into
  lines that fit the view (view_text).
- Panels: fitted() wraps a text into lines that fit a width as Blender's interface font measures them (blf), a word
  too long for a line (a file's path) broken after a '/', '_', '.' or '-'.
"""

from __future__ import annotations

import functools
import re

import bpy

AVERAGE = 6.3  # pixels a character at 11 points and scale 1: the width where blf measures nothing
# the most characters a report shows whole in the status bar: about 760 pixels, less than a 1600-pixel-wide window's
# bar has beside its mouse hints (left) and statistics (right); the real-window test measures the short line there
STATUS_CHARACTERS = 120
MORE = " (whole message: Info editor)"
BREAKS = "/\\_.-,"  # where a word too long for a line may be broken: after one of these
VIEW_TEXT_BYTES = 500  # Blender keeps 511 bytes of an engine's text (RenderEngine.text); more is cut silently
VIEW_MORE = "... (F12 reports the whole message to the Info editor)"
VIEW_TEXT: dict = {}  # the last text of the Rendered view: "status" as the engine had it, "shown" as wrapped; for tests
_MEMORY = re.compile(r"^(?P<head>.*?not started: ).*?needs about (?P<needed>[^;(]+?) of memory(?: \([^)]*\))? and "
                     r"(?P<free>[^;]+?) is available")  # fmt: skip


# ---- measuring and wrapping ------------------------------------------------------------------------------------------


def interface_scale() -> float:
    """The interface's scale (Preferences > Interface > Resolution Scale); 1 without a window."""
    try:
        return bpy.context.preferences.system.ui_scale or 1.0  # 0 in background mode
    except AttributeError:
        return 1.0


def _points() -> float:
    try:
        return float(bpy.context.preferences.ui_styles[0].widget.points)
    except (AttributeError, IndexError):
        return 11.0


def text_width(text: str) -> float:
    """text's width in pixels in the interface's font and size, as Blender draws a label (blf); estimated from its
    length where blf measures nothing. Main thread only (blf is not thread-safe)."""
    if not text:
        return 0.0
    scale = interface_scale()
    return _measured(text, _points(), scale) or AVERAGE * len(text) * scale


@functools.lru_cache(maxsize=4096)
def _measured(text: str, points: float, scale: float) -> float:
    import blf

    blf.size(0, points * scale)  # the size in pixels (from 3.4; its DPI argument is deprecated)
    return float(blf.dimensions(0, text)[0])


def fitted(text: str, room: float) -> list[str]:
    """text in lines, each at most room pixels wide in the interface's font: words kept whole where they fit a line,
    a longer word broken after a '/', '_', '.', '-' or ',' (else between characters). Never loses a character: the
    lines joined (by spaces where a line ended between words) are text with its runs of spaces made one."""
    return list(_fitted(text, max(1.0, room), _points(), interface_scale()))


@functools.lru_cache(maxsize=1024)
def _fitted(text: str, room: float, _points: float, _scale: float) -> tuple[str, ...]:
    lines: list[str] = []
    line = ""
    for word in text.split():
        candidate = f"{line} {word}" if line else word
        if text_width(candidate) <= room:
            line = candidate
            continue
        if line and text_width(word) > room:  # broken anyway: its start fills this line where it ends at a break
            head = _head(word, room - text_width(line + " "), at_break=True)
            if head:
                line, word = f"{line} {head}", word[len(head) :]
        if line:
            lines.append(line)
        while text_width(word) > room:
            head = _head(word, room)
            lines.append(head)
            word = word[len(head) :]
        line = word
    return (*lines, line) if line or not lines else tuple(lines)


def _head(word: str, room: float, at_break: bool = False) -> str:
    """The longest start of word that fits room, ending after a break character where one fits; else, unless
    at_break, any start (at least one character)."""
    fits = 0
    while fits < len(word) and text_width(word[: fits + 1]) <= room:
        fits += 1
    for end in range(fits, 0, -1):
        if word[end - 1] in BREAKS:
            return word[:end]
    return "" if at_break else word[: max(1, fits)]


# ---- reports: the status bar and the Info editor ---------------------------------------------------------------------


def headline(text: str, characters: int = STATUS_CHARACTERS) -> str | None:
    """The short line the status bar shows for text, or None where text itself fits: a memory refusal as its figures
    ("...: not enough memory: needs about 612.3 MB, 300.0 MB free"), else the clauses (between '; ') that fit, the
    first cut at a word where even it is longer; then where the rest is. Counted in characters: it may be made on
    the render's thread, where blf cannot measure."""
    if len(text) <= characters:
        return None
    room = characters - len(MORE)
    memory = _MEMORY.search(text)
    if memory is not None:
        short = f"{memory['head']}not enough memory: needs about {memory['needed']}, {memory['free']} free"
        if len(short) <= room:
            return short + MORE
    clauses = text.split("; ")
    short = clauses[0]
    for clause in clauses[1:]:
        if len(short) + 2 + len(clause) > room:
            break
        short = f"{short}; {clause}"
    if len(short) > room:
        short = short[: room - 3].rsplit(" ", 1)[0].rstrip(",;:") + "..."
    return short + MORE


def report_whole(reporter, kinds: set[str], text: str) -> str:
    """reporter.report(kinds, text) (an operator's or a render engine's), and where text is longer than the status bar
    holds, a short line after it: the bar shows the last report, the Info editor both. Returns the bar's line.
    Without a window (blender -b, the bpy module) the whole text alone: the terminal shows it whole."""
    reporter.report(kinds, text)
    short = None if bpy.app.background else headline(text)
    if short is not None:
        reporter.report(kinds, short)
    return short or text


# ---- the Rendered view -----------------------------------------------------------------------------------------------


def view_room(region, area) -> float:
    """Pixels a line of the engine's text in a 3D View's region has: the region less the toolbar and the sidebar
    drawn over it, the text's indent, and the navigation gizmos' column on the right."""
    scale = interface_scale()
    width = float(region.width)
    for other in getattr(area, "regions", ()):
        overlaps = region.x <= other.x < region.x + region.width and other.width > 1
        if other.type in ("TOOLS", "UI") and overlaps:
            width -= other.width
    return width - 30.0 * scale - 100.0 * scale


def view_text(text: str, region, area) -> str:
    """text as the Rendered view shows it: each line of it wrapped to the view's room (a status that fits stays as
    it is), at most VIEW_TEXT_BYTES bytes (then the lines that fit and VIEW_MORE)."""
    room = view_room(region, area)
    lines = [part for line in text.split("\n") for part in (fitted(line, room) if text_width(line) > room else [line])]
    joined = "\n".join(lines)
    if len(joined.encode()) <= VIEW_TEXT_BYTES:
        return joined
    kept: list[str] = []
    for line in lines:
        if len("\n".join([*kept, line, VIEW_MORE]).encode()) > VIEW_TEXT_BYTES:
            break
        kept.append(line)
    return "\n".join([*kept, VIEW_MORE])


# ---- the render window -----------------------------------------------------------------------------------------------

MARGIN = 10.0  # pixels left of the text, at scale 1
GIZMOS = 40.0  # the render window's zoom and pan gizmos on the right
TOP = 30.0  # below the window's own line (frame, time, memory)
LINE = 18.0  # between lines
BOX = (0.0, 0.0, 0.0, 0.6)  # behind the text, as Blender's own info line
_render_window: list[tuple[str, int | None]] = [("", None)]  # the whole text, and the slot it is about once drawn
_handler: list = []
DRAWN: dict = {}  # what the last draw showed: its region (window pixels), lines and their boxes; for the tests


def show_in_render_window(text: str) -> None:
    """The whole text of a render that made no image, for the render window (may run on the render's thread)."""
    _render_window[0] = (text, None)


@bpy.app.handlers.persistent
def clear_render_window(*_args) -> None:
    _render_window[0] = ("", None)
    DRAWN.clear()


def render_window_text() -> str:
    return _render_window[0][0]


def render_window_lines(text: str, region_width: float) -> list[str]:
    """text in the lines that fit a render window's image region region_width pixels wide."""
    scale = interface_scale()
    return fitted(text, region_width - (MARGIN + GIZMOS) * scale)


def _draw_render_window() -> None:
    """Over an Image editor showing the Render Result slot of a render that made no image: its whole text, wrapped to
    the region, in a box under the window's own line. Never raises into Blender's draw."""
    text, slot = _render_window[0]
    if not text:
        return
    try:
        context = bpy.context
        image = getattr(context.space_data, "image", None)
        region = context.region
        if image is None or image.type != "RENDER_RESULT" or region is None:
            return
        shown = image.render_slots.active_index
        if slot is None:  # the first draw after the render is of the slot it went into
            _render_window[0] = (text, shown)
        elif slot != shown:
            return
        _draw_lines(region, render_window_lines(text, region.width))
    except Exception:  # a draw handler must never raise into Blender's drawing; the console has the traceback
        import traceback

        traceback.print_exc()


def _draw_lines(region, lines: list[str]) -> None:
    import blf

    scale = interface_scale()
    left, line_height = MARGIN * scale, LINE * scale
    top = region.height - TOP * scale
    width = max(text_width(line) for line in lines) + 2 * MARGIN * scale
    bottom = top - line_height * len(lines) - 0.5 * line_height
    _draw_box(left - MARGIN * scale / 2, bottom, width, top - bottom)
    blf.size(0, _points() * scale)
    blf.color(0, 1.0, 1.0, 1.0, 1.0)
    boxes = []
    for index, line in enumerate(lines):
        baseline = top - line_height * (index + 1)
        blf.position(0, left, baseline, 0.0)
        blf.draw(0, line)
        boxes.append((left, baseline - 0.3 * line_height, text_width(line), line_height))
    DRAWN.update(region=(region.x, region.y, region.width, region.height), lines=list(lines), boxes=boxes)


def _draw_box(x: float, y: float, width: float, height: float) -> None:
    import gpu
    from gpu_extras.batch import batch_for_shader

    shader = gpu.shader.from_builtin("UNIFORM_COLOR")
    corners = ((x, y), (x + width, y), (x + width, y + height), (x, y + height))
    batch = batch_for_shader(shader, "TRIS", {"pos": corners}, indices=((0, 1, 2), (0, 2, 3)))
    gpu.state.blend_set("ALPHA")
    shader.bind()
    shader.uniform_float("color", BOX)
    batch.draw(shader)
    gpu.state.blend_set("NONE")


def register() -> None:
    if not _handler:
        _handler.append(bpy.types.SpaceImageEditor.draw_handler_add(_draw_render_window, (), "WINDOW", "POST_PIXEL"))
    if clear_render_window not in bpy.app.handlers.load_post:
        bpy.app.handlers.load_post.append(clear_render_window)  # another file: the last file's render is not shown


def unregister() -> None:
    if _handler:
        bpy.types.SpaceImageEditor.draw_handler_remove(_handler.pop(), "WINDOW")
    if clear_render_window in bpy.app.handlers.load_post:
        bpy.app.handlers.load_post.remove(clear_render_window)
    clear_render_window()
    _measured.cache_clear()
    _fitted.cache_clear()
