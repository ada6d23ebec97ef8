"""Every message whole where the user looks (addon/engine/messages.py): texts wrapped into lines that fit a width as
Blender's font measures them, without losing a character; a report too long for the status bar followed by a short
line; the Rendered view's text wrapped to the view; Scene Conversion's note buttons, whose tooltip is the whole note.
The real window (tests/test_blender_gui.py) measures the same in Blender 3.4.1's window."""

from __future__ import annotations

import re
from types import SimpleNamespace

import bpy
import pytest

from addon.engine import messages
from tracer.scene.scene import RenderSettings
from tracer.workers.resources import refusal

NOTE = (
    'image "kloofendal_48d_partly_cloudy_puresky_4k.hdr" on the world not found '
    "(textures/hdri/kloofendal_48d_partly_cloudy_puresky_4k.hdr): magenta, as Cycles shows it"
)
REFUSAL = (
    "Weathervane Tracer: not started: a 1920x1080 float64 render with 2 workers of 196,608 triangles needs about "
    "616.6 MB of memory and 300.0 MB is available; the largest: Cube (196,608 triangles); try fewer triangles (a lower "
    "Subdivision level) or instances, Precision 32-bit, fewer Processes, a lower Resolution %"
)


def squeezed(text: str) -> str:
    return re.sub(r"\s+", "", text)


@pytest.mark.parametrize("room", [40.0, 120.0, 219.0, 400.0, 2000.0])
def test_a_text_fits_its_room_in_lines_that_keep_every_character(room: float) -> None:
    lines = messages.fitted(NOTE, room)
    assert all(messages.text_width(line) <= room for line in lines), lines
    assert squeezed("".join(lines)) == squeezed(NOTE)
    words = NOTE.split()
    short_words = [word for word in words if messages.text_width(word) <= room]
    # a word that fits a line is never broken: it ends a line or lies whole inside one
    assert all(any(word in line.split() for line in lines) for word in short_words), lines
    if room == 219.0:  # the Properties editor's default room: the path broken after a '/' or a '_', not mid-word
        assert all(line[-1] in messages.BREAKS or not line.split()[-1].startswith('"kloof') for line in lines)
        assert any(line.endswith(("/", "_")) for line in lines), lines
    assert messages.fitted("", room) == [""]


def test_a_report_too_long_for_the_status_bar_gets_a_short_line_after_it(monkeypatch: pytest.MonkeyPatch) -> None:
    assert messages.headline("Weathervane Tracer: done") is None
    short = messages.headline(REFUSAL)
    assert short == (
        "Weathervane Tracer: not started: not enough memory: needs about 616.6 MB, 300.0 MB free"
        " (whole message: Info editor)"
    )
    assert len(short) <= messages.STATUS_CHARACTERS
    margin = "Weathervane Tracer: not started: " + refusal(
        RenderSettings(width=30000, height=30000), 2, 21_800_000_000, 23_200_000_000, 8, 0, (("Ground", 2),), True
    )
    margin_short = messages.headline(margin)
    assert "not started: not enough memory: needs about 24.0 GB, 23.2 GB free" in margin_short, margin_short
    cut = messages.headline("does not render: " + ", ".join(f"object number {n}" for n in range(40)))
    assert len(cut) <= messages.STATUS_CHARACTERS and cut.endswith("... (whole message: Info editor)"), cut
    reports: list = []
    reporter = SimpleNamespace(report=lambda kinds, text: reports.append((kinds, text)))
    # without a window (blender -b, the bpy module) the terminal shows the whole text: one report
    assert messages.report_whole(reporter, {"ERROR"}, REFUSAL) == REFUSAL and reports == [({"ERROR"}, REFUSAL)]
    reports.clear()
    monkeypatch.setattr(messages, "bpy", SimpleNamespace(app=SimpleNamespace(background=False)))
    assert messages.report_whole(reporter, {"ERROR"}, REFUSAL) == short
    assert reports == [({"ERROR"}, REFUSAL), ({"ERROR"}, short)]  # the status bar shows the last report


def test_the_rendered_views_text_is_wrapped_to_the_view() -> None:
    region = SimpleNamespace(type="WINDOW", x=0, y=0, width=1586, height=926)
    area = SimpleNamespace(regions=[region, SimpleNamespace(type="TOOLS", x=0, width=60)])
    text = messages.view_text(REFUSAL, region, area)
    lines = text.split("\n")
    room = messages.view_room(region, area)
    assert len(lines) >= 2 and all(messages.text_width(line) <= room for line in lines), lines
    assert squeezed(text) == squeezed(REFUSAL)
    done = "Weathervane Tracer: done in 0.50 s"
    assert messages.view_text(done, region, area) == done
    huge = messages.view_text(REFUSAL * 3, region, area)  # Blender keeps 511 bytes of an engine's text
    assert len(huge.encode()) <= messages.VIEW_TEXT_BYTES and huge.endswith(messages.VIEW_MORE)


def test_a_notes_button_shows_the_whole_note_and_copies_it() -> None:
    operator = bpy.types.WEATHERVANE_OT_conversion_note
    assert operator.description(bpy.context, SimpleNamespace(note=NOTE)) == NOTE
    with pytest.raises(RuntimeError, match="No note to copy"):  # bad input: a clear line, no traceback
        bpy.ops.weathervane.conversion_note(note="  ")
    assert bpy.ops.weathervane.conversion_note(note=NOTE) == {"FINISHED"}


def test_f12_of_a_resolution_beyond_the_format_names_blenders_field_whole() -> None:
    """The refusal names what the user sets (Output Properties' Resolution and its %), not the scene format's
    render.width, with the engine's name first; nothing is rendered."""
    bpy.ops.wm.read_factory_settings(use_empty=False)
    render = bpy.context.scene.render
    render.engine = "WEATHERVANE_TRACER"
    render.resolution_x, render.resolution_y, render.resolution_percentage = 20000, 1080, 100
    with pytest.raises(RuntimeError) as raised:
        bpy.ops.render.render()
    message = str(raised.value).strip().removeprefix("Error: ")
    assert message == "Weathervane Tracer: Resolution X x % (Output Properties): must be <= 16384, got 20000"
    assert messages.render_window_text() == message
