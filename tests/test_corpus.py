"""The corpus (scripts/corpus.py): .blend files nobody on the team wrote, each rendered by Cycles and the engine in a
process of its own and classified. Slow (minutes): `make corpus` writes the docs' table; this test runs the same
classification on Blender's own templates and samples and on the folders in WEATHERVANE_CORPUS (colon-separated,
e.g. a checkout of glTF-Blender-IO's tests/) and holds the engine to no crash and no silently wrong image."""

from __future__ import annotations

import json
import os
import subprocess
import sys
from pathlib import Path

import pytest

ROOT = Path(__file__).resolve().parents[1]

pytestmark = pytest.mark.slow


def test_no_corpus_file_crashes_or_is_silently_wrong(tmp_path: Path) -> None:
    folders = [folder for folder in os.environ.get("WEATHERVANE_CORPUS", "").split(":") if folder]
    arguments = ["--out", str(tmp_path / "corpus")] + [part for folder in folders for part in ("--folder", folder)]
    run = subprocess.run(
        [sys.executable, str(ROOT / "scripts" / "corpus.py"), *arguments], capture_output=True, text=True, timeout=7200
    )
    assert run.returncode == 0, run.stdout[-2000:] + run.stderr[-2000:]
    records = json.loads((tmp_path / "corpus.json").read_text())
    rendered = [record for record in records if record["class"] != "skipped"]
    assert rendered, "no corpus file rendered"
    right = sum(record["class"] == "right" for record in rendered)
    print(f"corpus: {right} of {len(rendered)} right ({right / len(rendered):.0%})")
    bad = [f"{r['class']}: {r['file']}" for r in rendered if r["class"] in ("crash", "silently wrong")]
    assert not bad, "\n".join(bad)
