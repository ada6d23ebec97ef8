"""scripts/speed_accuracy.py: every renderer measured against both references, and the Pareto front."""

from __future__ import annotations

import json
import sys
from pathlib import Path

import pytest

from tests.scripts_run import ROOT, in_python

pytest.importorskip("bpy", reason="the script renders with the bpy wheel")
pytest.importorskip("flip_evaluator", reason="the report extra computes the metrics")


def test_pareto_front_keeps_only_unbeaten_points() -> None:
    sys.path.insert(0, str(ROOT / "scripts"))
    from speed_accuracy import pareto

    points = [(1.0, 0.5), (2.0, 0.2), (1.5, 0.6), (3.0, 0.3), (0.5, 0.9), (4.0, 0.1)]
    assert sorted(pareto(points)) == [0, 1, 4, 5]


def test_small_run_measures_every_renderer(tmp_path: Path) -> None:
    result = in_python(
        "speed_accuracy.py", "--width", "32", "--height", "24", "--cycles-reference", "64", "--out", str(tmp_path)
    )
    assert result.returncode == 0, result.stdout[-3000:] + result.stderr[-3000:]
    data = json.loads((tmp_path / "speed-accuracy.json").read_text())
    assert {run["renderer"] for run in data["runs"]} == {"tracer", "cycles", "eevee", "workbench"}
    assert (tmp_path / "speed-accuracy.png").stat().st_size > 10_000
    tracer = {run["setting"]: run for run in data["runs"] if run["renderer"] == "tracer"}
    # more samples, closer to the converged documented model
    flips = [tracer[f"{spp} spp, depth 3, float64"]["against_documented"]["flip"] for spp in (1, 4, 16, 64)]
    assert flips == sorted(flips, reverse=True) and flips[-1] < flips[0] / 3
    cycles = {run["setting"]: run for run in data["runs"] if run["renderer"] == "cycles"}
    assert cycles["1024 samples"]["against_cycles"]["flip"] < cycles["1 samples"]["against_cycles"]["flip"]
