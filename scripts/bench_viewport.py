"""How long the 3D View's Rendered shading takes to answer an edit: from the change to the first (1/8) image and to
the full image, at a typical viewport size, in the bpy wheel (no window: the view's matrices are Blender's own
projection of the scene camera at that size, the path view_update / view_draw take).

    python scripts/bench_viewport.py [--width 1280 --height 720 --repeats 5 --workers 2]

Each repeat edits the tail fin's colour (a small edit: its pixels traced again at full size over the kept ray trees),
the ground's (most pixels: coarse to fine) (the depsgraph changes: view_update exports the scene again) and orbits the
view (view_draw sees new matrices); the time counts the export, the hand-over and the tracing, not Blender's redraw
(drawn within addon/engine/viewport.py's REDRAW_SECONDS after a level is ready). Medians of the repeats. Then
playback: the vane's turn keyed over 10 frames, each frame handed over as an animation playing (1/4 of the view) and
waited for: frames a second.

In a real Blender window (Debian's 3.4.1 under Xvfb, the default layout of a full-HD window, its 1586x926 3D View in
Rendered shading), the same edits and an orbit as the user makes them, each timed from the change (a property set,
or a key sent with event_simulate) to each stage: view_update's export, the hand-over, view_draw's draw of the
change's first image and of its finished one, and the end of the view's draw (a POST_PIXEL handler: Blender then
composites the window and swaps); clicks that select start no trace; playback of 10 frames for 5 s; and what one
draw of the view costs Blender (Rendered shading with the overlays on and off, Solid) and the engine's share of it:

    xvfb-run -a -s "-screen 0 1920x1080x24" blender --factory-startup --enable-event-simulate \
        --python scripts/bench_viewport.py -- --repeats 3
"""

from __future__ import annotations

import argparse
import statistics
import sys
import time
from pathlib import Path
from types import SimpleNamespace

ROOT = Path(__file__).resolve().parents[1]
sys.path.insert(0, str(ROOT))

import bpy  # noqa: E402
from mathutils import Matrix  # noqa: E402


def arguments() -> argparse.Namespace:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    argv = sys.argv[sys.argv.index("--") + 1 :] if "--" in sys.argv else [] if "blender" in sys.argv[0] else None
    parser.add_argument("--width", type=int, default=1280)
    parser.add_argument("--height", type=int, default=720)
    parser.add_argument("--repeats", type=int, default=5)
    parser.add_argument("--workers", type=int, default=2)
    return parser.parse_args(argv)


def timed_levels(session, view, started: float) -> dict[int, float]:
    """Seconds from started to each level of the newest scene, polled every millisecond."""
    seen: dict[int, float] = {}
    generation = session.progressive._generation
    while session.progressive.busy or 1 not in seen:
        level = session.progressive.latest()
        if level is not None and level.generation == generation and level.divisor not in seen:
            seen[level.divisor] = time.perf_counter() - started
        time.sleep(0.001)
    return seen


def keyed_turn(frames: int = 10) -> None:
    """The vane's turn keyed over frames 1..frames (a new heading each frame)."""
    from addon.vane import build

    scene, turn = bpy.context.scene, bpy.data.objects[build.TURN]
    scene.frame_start, scene.frame_end = 1, frames
    turn.animation_data_clear()
    for frame in range(1, frames + 1):
        turn.rotation_euler.z = 0.3 * frame
        turn.keyframe_insert("rotation_euler", index=2, frame=frame)


def playback(session, region, view) -> float:
    """Frames a second of the 10 keyed frames played once: each frame exported, handed over as playing, traced."""
    keyed_turn()
    scene = bpy.context.scene
    started = time.perf_counter()
    for frame in range(1, 11):
        scene.frame_set(frame)
        session.update_scene(bpy.context, bpy.context.evaluated_depsgraph_get())
        session.show(region, view, playing=True)
        session.progressive.wait(600)
    return 10 / (time.perf_counter() - started)


def main() -> int:
    options = arguments()
    if not bpy.app.background:
        return window_main(options)
    import addon
    from addon.engine import viewport

    bpy.ops.wm.read_factory_settings(use_empty=True)
    addon.register()
    assert bpy.ops.weathervane.build() == {"FINISHED"}
    scene = bpy.context.scene
    scene.weathervane.workers = options.workers
    obj = scene.camera
    depsgraph = bpy.context.evaluated_depsgraph_get()
    region = SimpleNamespace(width=options.width, height=options.height)
    view = SimpleNamespace(
        view_matrix=obj.matrix_world.inverted(),
        window_matrix=obj.calc_matrix_camera(depsgraph, x=options.width, y=options.height),
    )
    session = viewport.ViewportSession(options.workers)
    session.update_scene(bpy.context, depsgraph)
    session.show(region, view)
    session.progressive.wait(600)  # the workers started and the first scene traced: not counted
    materials = {entry.name: entry for entry in scene.weathervane.materials}
    edits = {"tail fin colour": materials["verdigris"], "ground colour": materials["tiles"]}
    results: dict[str, list[dict[int, float]]] = {**{name: [] for name in edits}, "view orbited": []}
    for repeat in range(options.repeats):
        for name, material in edits.items():
            started = time.perf_counter()
            material.color = (0.2 + 0.1 * repeat, 0.3, 0.6)
            session.update_scene(bpy.context, bpy.context.evaluated_depsgraph_get())
            session.show(region, view)
            results[name].append(timed_levels(session, view, started))
            session.progressive.wait(600)  # the kept ray trees rebuilt after a coarse-to-fine answer
        started = time.perf_counter()
        view.view_matrix = Matrix.Rotation(0.05, 4, "Z") @ view.view_matrix
        session.show(region, view)
        results["view orbited"].append(timed_levels(session, view, started))
    fps = [playback(session, region, view) for _ in range(options.repeats)]
    session.close()
    print(
        f"Rendered view {options.width}x{options.height}, {options.workers} workers, "
        f"samples {scene.weathervane.samples}, Blender {bpy.app.version_string}; medians of {options.repeats}:"
    )
    print(f"  playback of 10 frames at 1/4: {statistics.median(fps):.1f} frames a second")
    for change, runs in results.items():
        levels = "  ".join(
            f"1/{divisor}: {1000 * statistics.median(run[divisor] for run in runs):.0f} ms"
            for divisor in sorted(runs[0], reverse=True)
        )
        print(f"  {change:16} {levels}")
    addon.unregister()
    return 0


# --- in a real window -----------------------------------------------------------------------------------------------

FINISHED = ("Weathervane Tracer: done", "Weathervane Tracer: edit")
REDRAWS = 10  # draws of the view per timing of Blender's draw


class Window:
    """The window harness: each stage logged with its time, the steps run from a timer one after another."""

    def __init__(self, options: argparse.Namespace) -> None:
        self.options, self.log, self.results = options, [], {}
        self.steps: list = []

    def record(self, kind: str, info=None) -> None:
        self.log.append((time.perf_counter(), kind, info))

    def instrument(self) -> None:
        """The session's export, hand-over and draw, the tracer's finished levels and the end of each view draw."""
        from addon.engine import viewport
        from tracer.frames import progressive

        cls = viewport.ViewportSession
        for name in ("update_scene", "show", "draw"):
            original = getattr(cls, name)

            def wrapped(session, *arguments, _original=original, _name=name, **keywords):
                started = time.perf_counter()
                answer = _original(session, *arguments, **keywords)
                drawn = getattr(session._texture_level, "generation", None)  # the scene of the image it showed
                info = (started, time.perf_counter(), session.progressive.generation, answer, drawn)
                self.record(_name, info)
                return answer

            setattr(cls, name, wrapped)
        deliver = progressive.ProgressiveRender._deliver

        def delivered(render, level, handed_over, _deliver=deliver):
            answer = _deliver(render, level, handed_over)
            self.record("level", level.divisor)
            return answer

        progressive.ProgressiveRender._deliver = delivered
        bpy.types.SpaceView3D.draw_handler_add(lambda: self.record("drawn"), (), "WINDOW", "POST_PIXEL")

    def run(self) -> float | None:
        try:
            if not self.steps:
                self.report()
                bpy.ops.wm.quit_blender()
                return None
            if self.steps[0]() is None:
                self.steps.pop(0)
                return 0.01
            return 0.005
        except Exception:
            import traceback

            traceback.print_exc()
            bpy.ops.wm.quit_blender()
            return None

    def setup(self) -> None:
        import addon

        addon.register()
        self.instrument()
        window, area, region = view3d()
        with bpy.context.temp_override(window=window, area=area, region=region):
            cube = bpy.data.objects.get("Cube")
            if cube is not None:
                bpy.data.objects.remove(cube)
            assert bpy.ops.weathervane.build() == {"FINISHED"}
            for obj in bpy.context.view_layer.objects:
                obj.select_set(False)
            bpy.context.view_layer.objects.active = None
        scene = bpy.context.scene
        scene.weathervane.workers = self.options.workers
        scene.render.engine = "WEATHERVANE_TRACER"
        area.spaces.active.shading.type = "RENDERED"
        print(
            f"Rendered view {region.width}x{region.height} in a {window.width}x{window.height} window, Blender "
            f"{bpy.app.version_string}, {self.options.workers} workers; seconds from the change, medians of "
            f"{self.options.repeats}:",
            flush=True,
        )

    def idle(self, least: float = 0.5):
        """A step that ends when the view's image is finished and its ray trees kept (and least seconds passed)."""
        began = []

        def step():
            began.append(time.perf_counter())
            session = _session()
            if session is None or session.progressive.busy or not session.progressive.done:
                return 0.05
            return None if time.perf_counter() - began[0] >= least else 0.05

        return step

    def measure(self, name: str, change, traces: bool = True):
        state: dict = {}

        def step():
            session = _session()
            if "started" not in state:
                state.update(generation=session.progressive.generation, first=len(self.log))
                state["started"] = time.perf_counter()
                change()
                return 0.005
            waited = time.perf_counter() - state["started"]
            events = self.log[state["first"] :]
            finished = [
                e for e in events if e[1] == "draw" and e[2][2] > state["generation"] and e[2][3].startswith(FINISHED)
            ]
            if (traces and finished and waited > finished[0][0] - state["started"] + 0.5) or waited > (
                30 if traces else 2
            ):
                self.results.setdefault(name, []).append(self.stages(state, events))
                return None
            return 0.005

        return step

    def stages(self, state: dict, events: list) -> dict:
        started, generation = state["started"], state["generation"]
        out: dict = {"traces": _session().progressive.generation - generation}
        for kind, label in (("update_scene", "export"), ("show", "hand-over")):
            found = [info for _, k, info in events if k == kind and (kind != "show" or info[2] > generation)]
            if found:
                out[label] = found[0][1] - started
        draws = [(t, info) for t, k, info in events if k == "draw" and info[2] > generation]
        ends = [t for t, k, _ in events if k == "drawn"]
        for label, draw in (
            ("first draw", draws[:1]),
            ("finished", [d for d in draws if d[1][3].startswith(FINISHED)][:1]),
        ):
            if draw:
                out[label] = draw[0][0] - started
                shown = [t for t in ends if t >= draw[0][0]]
                if shown:
                    out[label + " drawn"] = shown[0] - started
        traced = [t for t, k, d in events if k == "level" and d == 1]
        if traced:
            out["traced"] = traced[0] - started
        out["view draws"] = len([t for t in ends if t >= started])
        return out

    def playback(self):
        state: dict = {}

        def step():
            # Space over the view, as the user starts and stops it: an operator called under a context override
            # while the view traces can crash Blender (tests/addon/gui_session.py's tracing_quiet says why)
            if "keyed" not in state:  # keyed first, then Space once the view is idle again (as a user would)
                keyed_turn()
                bpy.context.scene.frame_set(1)
                state["keyed"] = self.idle(0.3)
                return 0.05
            if "started" not in state:
                if state["keyed"]() is not None:
                    return 0.05
                state.update(first=len(self.log), started=time.perf_counter())
                _keys("ESC", "SPACE")()  # Esc: the splash screen of --factory-startup would take the Space
                return 0.05
            if time.perf_counter() - state["started"] < 5.0:
                return 0.05
            _keys("SPACE")()
            events = self.log[state["first"] :]
            # each new image on screen: a draw of a level not drawn before (while the frames come faster than they
            # are traced, the status says "updating" over each newly finished frame's image)
            frames = {info[4] for _, k, info in events if k == "draw"} - {None}
            draws = sum(1 for _, k, _ in events if k == "drawn")
            self.results.setdefault("playback", []).append(
                {"frames a second": len(frames) / 5.0, "view draws a second": draws / 5.0}
            )
            return None

        return step

    def redraw_costs(self):
        """A step: with the view finished, Blender's own draw of it (wm.redraw_timer, the 3D View's region) in
        Rendered shading with the overlays on and off, and in Solid shading, and the engine's share of the Rendered
        draw (ViewportSession.draw): what an edit's "updating" waits for after view_update."""

        def step():
            window, area, region = view3d()
            space = area.spaces.active
            first = len(self.log)
            costs = {}
            for label, shading, overlays in (
                ("rendered, overlays on", "RENDERED", True),
                ("rendered, overlays off", "RENDERED", False),
                ("solid, overlays on", "SOLID", True),
            ):
                space.shading.type, space.overlay.show_overlays = shading, overlays
                with bpy.context.temp_override(window=window, area=area, region=region):
                    bpy.ops.wm.redraw_timer(type="DRAW", iterations=2)  # a shading's first draws set it up
                    started = time.perf_counter()
                    bpy.ops.wm.redraw_timer(type="DRAW", iterations=REDRAWS)
                costs[label] = (time.perf_counter() - started) / REDRAWS
            space.shading.type, space.overlay.show_overlays = "RENDERED", True
            draws = [info[1] - info[0] for _, kind, info in self.log[first:] if kind == "draw"]
            costs["the engine's draw"] = statistics.median(draws) if draws else float("nan")
            self.results.setdefault("region draw", []).append(costs)
            return None

        return step

    def report(self) -> None:
        for name, runs in self.results.items():
            keys = [key for key in runs[0] if all(key in run for run in runs)]
            places = 4 if name == "region draw" else 2  # the engine's share of a draw is a millisecond
            figures = ", ".join(f"{key} {statistics.median(run[key] for run in runs):.{places}f}" for key in keys)
            print(f"  {name:22} {figures}", flush=True)


def view3d():
    window = bpy.context.window_manager.windows[0]
    area = max((a for a in window.screen.areas if a.type == "VIEW_3D"), key=lambda a: a.width * a.height)
    return window, area, next(r for r in area.regions if r.type == "WINDOW")


def _session():
    from addon.engine import viewport

    sessions = list(viewport._sessions)
    return sessions[0] if sessions else None


def _recolour(name: str):
    def change() -> None:
        entry = {entry.name: entry for entry in bpy.context.scene.weathervane.materials}[name]
        red, green, blue = entry.color
        entry.color = (green, blue, red)

    return change


def _keys(*keys: str, at=None):
    """Keys pressed and released over the view (at: a point of the scene to point at, else the view's centre)."""

    def change() -> None:
        from bpy_extras.view3d_utils import location_3d_to_region_2d

        window, area, region = view3d()
        x, y = region.width // 2, region.height // 2
        if at is not None:
            x, y = (int(v) for v in location_3d_to_region_2d(region, area.spaces.active.region_3d, at()))
        x, y = region.x + x, region.y + y
        window.event_simulate("MOUSEMOVE", "NOTHING", x=x, y=y)
        for key in keys:
            window.event_simulate(key, "PRESS", x=x, y=y)
            window.event_simulate(key, "RELEASE", x=x, y=y)

    return change


def _move_ball() -> None:
    bpy.data.objects["WV ball"].location.x += 0.3


def window_main(options: argparse.Namespace) -> int:
    harness = Window(options)
    ball = lambda: bpy.data.objects["WV ball"].matrix_world.translation  # noqa: E731
    steps = [harness.setup, harness.idle(2.0)]
    for _ in range(options.repeats):
        steps += [
            harness.measure("click on the ball", _keys("LEFTMOUSE", at=ball), traces=False),
            harness.idle(),
            harness.measure("click beside", _keys("LEFTMOUSE"), traces=False),
            harness.idle(),
            harness.measure("tail fin colour", _recolour("verdigris")),
            harness.idle(),
            harness.measure("ball moved", _move_ball),
            harness.idle(),
            harness.measure("ground colour", _recolour("tiles")),
            harness.idle(),
            harness.measure("numpad 4 (orbit)", _keys("NUMPAD_4")),
            harness.idle(),
        ]
    steps += [harness.playback(), harness.idle()]
    for _ in range(options.repeats):
        steps += [harness.redraw_costs(), harness.idle()]
    harness.steps = steps
    bpy.app.timers.register(harness.run, first_interval=0.5)
    bpy.app.timers.register(_sleep_as_blender_does, first_interval=0.0, persistent=True)
    return 0


def _sleep_as_blender_does() -> float:
    """With --enable-event-simulate (the keys need it) Blender's main loop skips its 5 ms sleep when no event waits
    and takes a whole core; sleeping 4 ms on every turn, as tests/addon/gui_session.py does, leaves the CPU to the
    drawing and the workers as a user's Blender does."""
    time.sleep(0.004)
    return 0.0


if __name__ == "__main__":
    code = main()
    if bpy.app.background:
        sys.exit(code)
