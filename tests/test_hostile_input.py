"""Hostile scene files and animation folders: one message per problem and exit 2, never a traceback or a hang."""

from __future__ import annotations

import json
import os
import subprocess
import sys
from pathlib import Path

import numpy as np
import pytest

from tests.hostile_scenes import extreme_scene, hostile_text
from tracer import cli
from tracer.frames.animate import animate, frame_path
from tracer.scene import loader
from tracer.scene.loader import SceneError, default_scene_dict, load_scene, scene_from_dict
from tracer.workers.parallel import render

ROOT = Path(__file__).resolve().parents[1]


def write(tmp_path: Path, text: str, name: str = "scene.json") -> Path:
    path = tmp_path / name
    path.write_text(text)
    return path


def problems_of(path: Path) -> list[str]:
    with pytest.raises(SceneError) as raised:
        load_scene(path)
    return raised.value.problems


def mutated(change) -> str:
    document = default_scene_dict()
    change(document)
    return json.dumps(document)


def set_in(section: str, key: str, value):
    return lambda document: document[section].__setitem__(key, value)


def first_cylinder(key: str, value):
    def change(document):
        next(o for o in document["objects"] if o["type"] == "cylinder")[key] = value

    return change


def use_fov(value):
    def change(document):
        document["camera"].pop("lens", None)
        document["camera"]["fov"] = value

    return change


CASES = [
    ("render.samples", set_in("render", "samples", "4"), 'must be an integer, got string "4"'),
    ("render.samples", set_in("render", "samples", True), "must be an integer, got boolean true"),
    ("render.width", set_in("render", "width", 10**400), "must be a finite number, got an integer of 401 digits"),
    ("camera.fov", use_fov(5e-324), "must be at least 0.001 (the smallest the tracer renders), got 5e-324"),
    ("radius", first_cylinder("radius", 1e308), "must be <= 1000000000, got 1e+308"),
    ("radius", first_cylinder("radius", 10**400), "must be a finite number, got an integer of 401 digits"),
    ("vane.axis", set_in("vane", "axis", [0, 0, 5e-324]), "must have a length of at least 1e-09 to give a direction"),
    ("render.model", set_in("render", "model", "x" * 5000), "(5002 characters)"),
]


@pytest.mark.parametrize(("field", "change", "message"), CASES, ids=[f"{c[0]}-{i}" for i, c in enumerate(CASES)])
def test_values_that_cannot_be_rendered_are_refused_naming_the_field(tmp_path: Path, field, change, message) -> None:
    problems = problems_of(write(tmp_path, mutated(change)))
    assert len(problems) >= 1
    assert all(len(problem) < 200 for problem in problems)  # long values are cut
    assert any(field in problem and message in problem for problem in problems), problems


def test_a_number_too_large_for_json_to_read_as_a_float_is_refused(tmp_path: Path) -> None:
    text = mutated(set_in("render", "coef", "OVERFLOW")).replace('"OVERFLOW"', "1e999")
    problems = problems_of(write(tmp_path, text))
    assert any(problem.startswith("render.coef: must be a finite number, got inf") for problem in problems), problems


def test_duplicate_keys_are_refused_naming_each(tmp_path: Path) -> None:
    document = default_scene_dict()
    first_key = next(iter(document["render"]))
    text = json.dumps(document)[:-1] + ', "camera": {}}'
    text = text.replace('"render": {', f'"render": {{"{first_key}": 1, ', 1)
    problems = problems_of(write(tmp_path, text))
    assert "camera: appears more than once in this object (JSON keeps only the last; remove the others)" in problems
    assert any(problem.startswith(f"render.{first_key}: appears more than once") for problem in problems)


def test_deeply_nested_json_is_refused_with_a_message(tmp_path: Path) -> None:
    assert problems_of(write(tmp_path, "[" * 100000 + "]" * 100000)) == [
        "nests objects and lists too deeply to read (a scene needs 5 levels)"
    ]


def test_devices_pipes_folders_and_oversized_files_are_refused_before_reading(tmp_path: Path) -> None:
    fifo = tmp_path / "fifo.json"
    os.mkfifo(fifo)  # reading it would wait forever for a writer
    assert problems_of(fifo) == ["must be a regular file (this is a device, a pipe or a socket)"]
    assert problems_of(Path("/dev/zero")) == ["must be a regular file (this is a device, a pipe or a socket)"]
    assert problems_of(tmp_path) == ["is a folder, not a scene file"]
    huge = tmp_path / "huge.json"
    with huge.open("wb") as stream:
        stream.truncate(loader.MAX_SCENE_BYTES + 1)  # sparse: no disk used
    assert problems_of(huge) == [
        f"is {loader.MAX_SCENE_BYTES + 1} bytes; scene files of at most {loader.MAX_SCENE_BYTES} bytes are read"
    ]


def test_the_command_line_reports_a_fifo_and_exits_2_without_waiting(tmp_path: Path) -> None:
    fifo = tmp_path / "scene.json"
    os.mkfifo(fifo)
    done = subprocess.run(
        [sys.executable, "-m", "tracer", "render", str(fifo), "-o", str(tmp_path / "out.png")],
        cwd=ROOT,
        capture_output=True,
        text=True,
        timeout=60,
    )
    assert done.returncode == cli.EXIT_BAD_INPUT
    assert done.stderr.strip() == f"error: {fifo}: must be a regular file (this is a device, a pipe or a socket)"
    assert not (tmp_path / "out.png").exists()


def test_many_object_names_are_checked_for_uniqueness_with_the_duplicate_named() -> None:
    document = default_scene_dict()
    template = document["objects"][0]
    document["objects"] = [dict(template, name=f"o{i}") for i in range(5000)] + [dict(template, name="o17")]
    del document["vane"]
    with pytest.raises(SceneError) as raised:
        scene_from_dict(document)
    assert raised.value.problems == ['objects[5000].name: must be unique, got "o17" twice']


# ---- fuzz --------------------------------------------------------------------------------------------------------


def _fuzz_hostile_files(tmp_path: Path, seeds: range) -> tuple[int, int]:
    base = default_scene_dict()
    base["render"].update(width=8, height=6, workers=1)
    refused = rendered = 0
    for seed in seeds:
        path = write(tmp_path, hostile_text(seed, base))
        try:
            scene = load_scene(path)
        except SceneError as error:
            assert error.problems and all(isinstance(p, str) and 0 < len(p) < 300 for p in error.problems), seed
            refused += 1
            continue
        image = render(scene.with_render(width=8, height=6), workers=1).image
        assert np.isfinite(image).all(), seed
        rendered += 1
    return refused, rendered


def _fuzz_extreme_scenes(seeds: range) -> None:
    for seed in seeds:
        scene = scene_from_dict(extreme_scene(seed), f"extreme scene {seed}")  # valid by construction
        image = render(scene, workers=1).image
        assert np.isfinite(image).all(), f"seed {seed}: non-finite pixels"


def test_hostile_scene_files_give_messages_never_exceptions(tmp_path: Path) -> None:
    refused, rendered = _fuzz_hostile_files(tmp_path, range(300))
    assert refused > 150 and rendered > 10  # both kinds were met


def test_extreme_but_valid_scenes_render_to_finite_pixels() -> None:
    _fuzz_extreme_scenes(range(150))


@pytest.mark.slow
def test_hostile_scene_files_long_run(tmp_path: Path) -> None:
    _fuzz_hostile_files(tmp_path, range(300, 5300))


@pytest.mark.slow
def test_extreme_but_valid_scenes_long_run() -> None:
    _fuzz_extreme_scenes(range(150, 3150))


# ---- animations --------------------------------------------------------------------------------------------------


def _small_animation():
    from tracer import default_scene

    return default_scene().with_render(width=32, height=24, workers=1)


def test_a_truncated_frame_is_rendered_again_on_resume(tmp_path: Path) -> None:
    scene = _small_animation()
    animate(scene, tmp_path, 1, 3)
    whole = frame_path(tmp_path, 2).read_bytes()
    frame_path(tmp_path, 2).write_bytes(whole[: len(whole) // 2])
    result = animate(scene, tmp_path, 1, 3)
    assert result.rendered == [2] and result.skipped == [1, 3]
    assert frame_path(tmp_path, 2).read_bytes() == whole


def test_a_frame_of_another_size_is_rendered_again_on_resume(tmp_path: Path) -> None:
    animate(_small_animation().with_render(width=16, height=12), tmp_path, 1, 2)
    assert animate(_small_animation(), tmp_path, 1, 2).rendered == [1, 2]


def test_a_gif_that_cannot_be_written_is_named_in_the_message(tmp_path: Path, capsys) -> None:
    blocker = tmp_path / "not-a-folder"
    blocker.write_text("")
    gif = blocker / "preview.gif"
    args = ["animate", "-o", str(tmp_path / "frames"), "--frames", "1-2", "--width", "16", "--height", "12"]
    assert cli.main([*args, "--gif", str(gif), "--quiet", "--workers", "1"]) == cli.EXIT_FAILED
    err = capsys.readouterr().err.strip()
    assert err.startswith(f"error: cannot write {gif}: ") and "Traceback" not in err
    assert sorted(path.name for path in (tmp_path / "frames").iterdir()) == ["frame_0001.png", "frame_0002.png"]
