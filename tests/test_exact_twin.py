"""The exact twin (addon/convert/exact_twin.py): Cycles computing the documented model in OSL agrees with the tracer.

On flat primitives (boxes, planes, pyramids: Blender's meshes are the tracer's triangles, nothing is tessellated)
with mirrors at depth 3, both highlight models. Pixels are compared at their centres (--pixel-centres: the tracer's
one sample per pixel, Cycles' narrowest filter), so what is left is the shading itself; the tracer's robust numerics,
since the documented Moller-Trumbore leaks light through shared triangle edges (docs/stability.md) where Cycles'
watertight triangles do not. The 3.4.1 fallback is checked in test_render_both.py (test_runs_inside_blender_34_too).
"""

from __future__ import annotations

import json
from pathlib import Path

import pytest

from tests.scripts_run import in_python

pytest.importorskip("bpy", reason="the exact twin renders on the bpy wheel's Cycles (OSL)")
pytest.importorskip("flip_evaluator", reason="the report extra computes the metrics")


def flat_scene(model: str) -> dict:
    """Boxes, pyramids, a mirror and a reflective floor, lit by every documented light, seen against the sky."""
    return {
        "materials": {
            "floor": {"color": [0.55, 0.53, 0.48], "specular": 10, "reflective": 0.3},
            "red": {"color": [0.8, 0.2, 0.15], "specular": 40, "reflective": 0.0},
            "blue": {"color": [0.2, 0.3, 0.8], "specular": 100, "reflective": 0.2},
            "steel": {"color": [0.5, 0.55, 0.6], "specular": 25, "reflective": 0.5},
            "mirror": {"color": [0.9, 0.9, 0.9], "specular": 200, "reflective": 0.8},
        },
        "objects": [
            {"name": "floor", "type": "plane", "material": "floor", "size": [8, 8]},
            {
                "name": "box",
                "type": "box",
                "material": "red",
                "location": [-0.8, 0.3, 0.5],
                "rotation": [0, 0, 25],
                "size": [1, 1, 1],
            },
            {
                "name": "slab",
                "type": "box",
                "material": "steel",
                "location": [0.2, 1.0, 0.15],
                "rotation": [0, 0, -15],
                "size": [1.4, 0.5, 0.3],
            },
            {
                "name": "pyramid",
                "type": "pyramid",
                "material": "blue",
                "location": [0.9, -0.2, 0.0],
                "rotation": [0, 0, 10],
                "size": [1.2, 1.2, 1.4],
            },
            {
                "name": "mirror",
                "type": "plane",
                "material": "mirror",
                "location": [0, 2.2, 1.2],
                "rotation": [90, 0, 0],
                "size": [4, 2.4],
            },
        ],
        "lights": [
            {"type": "ambient", "intensity": 0.15},
            {"type": "point", "location": [3.0, -2.5, 4.0], "intensity": 0.6},
            {"type": "directional", "direction": [-1.0, -0.5, 2.0], "intensity": 0.3},
        ],
        "background": {"type": "sky"},
        "camera": {"location": [1.5, -6.0, 2.6], "rotation": [72, 0, 12], "lens": 35},
        "render": {"depth": 3, "model": model, "coef": 3, "numerics": "robust"},
    }


@pytest.mark.parametrize("model", ["blinn-phong", "phong"])
def test_exact_twin_matches_the_tracer_on_flat_primitives_with_mirrors(tmp_path: Path, model: str) -> None:
    scene = tmp_path / "flat.json"
    scene.write_text(json.dumps(flat_scene(model)))
    out = tmp_path / "out"
    result = in_python(
        "render_both.py", str(scene), "--out", str(out), "--engines", "tracer,exact", "--pixel-centres",
        "--width", "96", "--height", "72", "--cycles-samples", "4",
    )  # fmt: skip
    assert result.returncode == 0, result.stdout[-3000:] + result.stderr[-3000:]
    metrics = json.loads((out / "metrics.json").read_text())["pairs"]["exact_vs_tracer"]
    assert metrics["psnr_db"] >= 55.0, metrics  # measured 61.2 dB in both models
    assert metrics["mean_flip"] <= 0.002, metrics
    assert (out / "diff_exact_vs_tracer.png").exists()


def test_the_shader_is_the_listing(tmp_path: Path) -> None:
    """The generated OSL names each documented term: the point light's unnormalised L and its shadow range, the
    directional light's open range, the ungated highlight, and the mirror closure weighted by r."""
    script = tmp_path / "source.py"
    script.write_text(
        "import sys, json\n"
        f"sys.path.insert(0, {str(Path(__file__).resolve().parents[1])!r})\n"
        "from tests.test_exact_twin import flat_scene\n"
        "from addon.convert import exact_twin\n"
        "from tracer.scene.loader import scene_from_dict\n"
        "for model in ('blinn-phong', 'phong'):\n"
        "    print(exact_twin.shader_source(scene_from_dict(flat_scene(model), 'test')))\n"
        "print(exact_twin.background_source(scene_from_dict(flat_scene('phong'), 'test')))\n"
        "print('UNAVAILABLE', exact_twin.unavailable())\n"
        "shadowless = flat_scene('phong')\n"
        "shadowless['objects'][1]['visible_shadow'] = False\n"
        "print('APPROXIMATED', exact_twin.approximated(scene_from_dict(shadowless, 'test')))\n"
        "print('EXACT', exact_twin.approximated(scene_from_dict(flat_scene('phong'), 'test')))\n"
        "glassy = flat_scene('phong')\n"
        "first = sorted(glassy['materials'])[0]\n"
        "glassy['materials'][first].update(transmission=1.0, alpha=0.5)\n"
        "print('GLASS', exact_twin.approximated(scene_from_dict(glassy, 'test')), first)\n"
    )
    import subprocess
    import sys

    result = subprocess.run([sys.executable, str(script)], capture_output=True, text=True, timeout=120)
    assert result.returncode == 0, result.stderr[-3000:]
    source = result.stdout
    assert "vector L = vector(3.0, -2.5, 4.0) - P;" in source
    assert 'trace(P, L / dist, "mindist", 0.001 * dist, "maxdist", dist)' in source  # t in (0.001, 1) along L
    assert 'trace(P, L / dist, "mindist", 0.001 * dist);' in source  # directional: t in (0.001, inf)
    assert "if (NL > 0.0) lit += weight * NL / dist;" in source  # no falloff
    assert "if (Specular > 0.0) {" in source and "NL > 0.0 && Specular" not in source  # not gated, as documented
    assert "pow(HN / length(H), Specular * 3.0)" in source and "pow(RV / (length(R) * length(V)), Specular)" in source
    assert "BSDF = local * emission();" in source and "BSDF += Reflective * reflection(N);" in source
    assert "(1.0 - Reflective)" in source
    assert "UNAVAILABLE None" in source
    # what the twin cannot say is named: trace() sees every object, so a shadowless one casts a shadow
    assert "APPROXIMATED ['1 object casting no shadow (they cast one here)']" in source and "EXACT []" in source
    # glass and alpha: the twin's OSL is the documented (opaque) model, and says so
    glass = next(line for line in source.splitlines() if line.startswith("GLASS"))
    first = glass.rsplit(" ", 1)[1]
    assert f"glass ({first}: transmission, opaque here)" in glass
    assert f"partly transparent materials ({first}: alpha, opaque here)" in glass
