"""The progress bar: drawn on a terminal, silent otherwise, and fed by the renderer band by band."""

from __future__ import annotations

import io

from tracer.progress import ProgressBar
from tracer.scene.loader import default_scene
from tracer.workers.parallel import bands, render


class Terminal(io.StringIO):
    def isatty(self) -> bool:
        return True


def test_bar_draws_on_a_terminal_and_clears_itself() -> None:
    stream = Terminal()
    bar = ProgressBar("render", stream=stream)
    bar(1, 4)
    bar(4, 4)
    assert "1/4" in stream.getvalue() and "4/4" in stream.getvalue()
    assert "[" + "#" * 30 + "]" in stream.getvalue()
    bar.close()
    assert stream.getvalue().endswith("\r\033[K")


def test_bar_is_silent_when_not_a_terminal() -> None:
    stream = io.StringIO()
    bar = ProgressBar("render", stream=stream)
    bar(1, 2)
    bar.close()
    assert stream.getvalue() == ""


def test_renderer_reports_every_band() -> None:
    scene = default_scene().with_render(width=64, height=200)
    seen: list[tuple[int, int]] = []
    render(scene, workers=2, progress=lambda done, total: seen.append((done, total)))
    total = len(bands(scene.render))
    assert seen == [(k, total) for k in range(1, total + 1)]
