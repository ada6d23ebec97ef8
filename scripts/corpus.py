"""A corpus of .blend files nobody on the team wrote -> each classified beside Cycles, and the table in docs.

    python scripts/corpus.py [--folder DIR ...] [--blender PATH] [--out docs/corpus]

Sources: the .blend files Blender itself ships that hold a scene (its application templates; the material library
add-on's samples where the Blender has them) and every .blend file under each --folder (public projects' test or
demo scenes, unchanged: for example glTF-Blender-IO's tests/, as `make corpus` describes). Each file is measured by
scripts/corpus_scene.py in a process of its own (a crash or a hang is recorded, not fatal) and classified:

    right            coverage IoU >= 0.95, the covered pixels' mean colour within 10% per channel (of at least
                     0.02), and PSNR over them >= 25 dB (the texture's content, not only its mean)
    named            not right, and F12 says why: it refuses the scene with a message, or Scene Conversion names
                     an approximation of a material or light, or the scene leaves something out; the world
                     light's note (shadowed, no bounces) counts only where the world is the scene's only light (with
                     lamps, it alone does not explain a difference)
    silently wrong   not right, and F12 says nothing
    crash            the engine raised, or the process died or hung
    skipped          the file does not open in this Blender (or Blender crashes reading it), Cycles crashes on it, or
                     Cycles shows nothing at its camera

Writes OUT.json (every record) and OUT.md (the counts, the silently wrong and crashes listed, then every file).
"""

from __future__ import annotations

import argparse
import json
import subprocess
import sys
import tempfile
import time
from pathlib import Path

ROOT = Path(__file__).resolve().parents[1]
RIGHT_IOU, RIGHT_MEAN, RIGHT_PSNR = 0.95, 0.10, 25.0
TIMEOUT = 300  # seconds for one file, both renders


def bundled_files(python: str, blender: str | None) -> list[Path]:
    """The .blend files with scenes that the Blender in use ships (application templates, sample materials)."""
    probe = (
        "import bpy, pathlib; roots = [pathlib.Path(p) for p in bpy.utils.script_paths()] + "
        "[pathlib.Path(bpy.utils.system_resource('DATAFILES'))]; "
        "print('\\n'.join(sorted({str(f) for r in roots for f in r.rglob('*.blend') "
        "if 'bl_app_templates_system' in str(f) or 'materials_library' in str(f)})))"
    )
    command = [blender, "-b", "--factory-startup", "--python-expr", probe] if blender else [python, "-c", probe]
    run = subprocess.run(command, capture_output=True, text=True, timeout=120)
    return [Path(line) for line in run.stdout.splitlines() if line.endswith(".blend") and Path(line).is_file()]


def classify(record: dict) -> str:
    if record.get("crash"):
        return "crash"
    if record.get("skipped"):
        return "skipped"
    error = record.get("engine_error", "")
    if "Traceback" in error or "Python script error" in record.get("log", ""):
        return "crash"
    right = (
        record.get("iou", 0.0) >= RIGHT_IOU
        and record.get("mean_error", 1e9) <= RIGHT_MEAN
        and record.get("psnr", 0.0) >= RIGHT_PSNR
    )
    if right:
        return "right"
    said = record.get("said")
    if error or said is None:  # a refusal; or an export that raised, recorded in its notes
        return "named" if error or record.get("notes") else "silently wrong"
    world = [note for note in said["world"] if not note.startswith("world light: ")]
    explained = said["materials"] or said["lights"] or said["scene"] or world
    explained = explained or (said["world"] and record.get("lamps", 0) == 0)
    return "named" if explained else "silently wrong"


def run_one(path: Path, python: str, blender: str | None) -> dict:
    with tempfile.TemporaryDirectory(prefix="corpus-") as folder:
        out = Path(folder) / "record.json"
        script = str(ROOT / "scripts" / "corpus_scene.py")
        if blender:
            command = [blender, "-b", "--factory-startup", "--python", script, "--", str(path), str(out)]
        else:
            command = [python, script, str(path), str(out)]
        started = time.perf_counter()
        try:
            run = subprocess.run(command, capture_output=True, text=True, timeout=TIMEOUT, cwd=ROOT)
        except subprocess.TimeoutExpired:
            return {"file": str(path), "crash": f"no result within {TIMEOUT} s"}
        log = (run.stdout + run.stderr)[-4000:]
        if not out.exists():
            return {"file": str(path), "crash": f"exit status {run.returncode}", "log": log[-1500:]}
        record = json.loads(out.read_text())
        stage = record.pop("stage", None)
        if stage == "open":  # Blender died reading the file (one saved by a much newer Blender)
            record["skipped"] = f"Blender crashed opening it (exit status {run.returncode})"
        elif stage == "cycles":  # Blender died inside Cycles' render: nothing to compare with
            record["skipped"] = f"Cycles crashed (exit status {run.returncode})"
        elif stage == "engine":
            record["crash"] = f"the engine's render ended the process (exit status {run.returncode})"
            record["log"] = log[-1500:]
        record["seconds"] = time.perf_counter() - started
        if "Python script error in WEATHERVANE_TRACER" in log:
            record["log"] = log[-1500:]
        return record


def _display(path: str) -> str:
    """A corpus file's name as the table shows it: Blender's own under "blender:", the others from the folder's
    own name on."""
    if "/scripts/" in path and ("bl_app_templates_system" in path or "materials_library" in path):
        return "blender:" + path.split("/scripts/", 1)[1]
    return "/".join(Path(path).parts[-3:])


def _row(record: dict) -> str:
    name = record["file"]
    measured = ""
    if "iou" in record:
        measured = (
            f"IoU {record['iou']:.3f}, mean {record.get('mean_error', 0):.0%}, PSNR {record.get('psnr', 0):.1f} dB"
        )
    said = record.get("skipped") or record.get("crash") or record.get("engine_error") or ""
    if not said and "said" in record:  # what Scene Conversion says, a few notes of each kind
        detail = record["said"]
        parts = [*detail["scene"]]
        parts += [f"{name}: {', '.join(found[:2])}" for kind in ("materials", "lights") for name, found in
                  list(detail[kind].items())[:2]]  # fmt: skip
        parts += [f"world: {', '.join(detail['world'][:2])}"] if detail["world"] else []
        said = "; ".join(parts)
    said = (said or record.get("notes") or "").replace("|", "/").replace("\n", " ")
    if len(said) > 240:
        said = said[:237] + "..."
    return f"| {name} | {record['class']} | {measured} | {said} |"


def _portable(records: list[dict], folders: list[Path]) -> list[dict]:
    """The records with this machine's paths shortened as the table shows them: a folder's path to its own name,
    Blender's files to "blender:"."""
    text = json.dumps(records)
    for folder in folders:
        text = text.replace(json.dumps(str(folder.resolve()))[1:-1] + "/", folder.resolve().name + "/")
        text = text.replace(json.dumps(str(folder))[1:-1] + "/", folder.name + "/")
    return [{**record, "file": _display(record["file"])} for record in json.loads(text)]


def write(records: list[dict], out: Path, sources: list[str], blender_version: str) -> None:
    out.parent.mkdir(parents=True, exist_ok=True)
    out.parent.joinpath(out.name + ".json").write_text(json.dumps(records, indent=1) + "\n")
    counted = {kind: [r for r in records if r["class"] == kind] for kind in
               ("right", "named", "silently wrong", "crash", "skipped")}  # fmt: skip
    rendered = len(records) - len(counted["skipped"])
    share = len(counted["right"]) / rendered if rendered else 0.0
    lines = [
        "# The corpus: .blend files nobody on the team wrote, beside Cycles",
        "",
        f"Written by `scripts/corpus.py` ({blender_version}); sources: {', '.join(sources)}. How each file is "
        "rendered and classified: the script's docstring.",
        "",
        "| class | files |",
        "| --- | --- |",
        *(f"| {kind} | {len(found)} |" for kind, found in counted.items()),
        "",
        f"Right: {len(counted['right'])} of {rendered} rendered ({share:.0%}).",
        "",
    ]
    for kind in ("silently wrong", "crash"):
        lines += [f"## {kind.capitalize()}", ""]
        lines += [_row(r) for r in counted[kind]] or ["None."]
        lines.append("")
    lines += ["## Every file", "", "| file | class | measured | what F12 says |", "| --- | --- | --- | --- |"]
    lines += [_row(r) for r in records]
    out.parent.joinpath(out.name + ".md").write_text("\n".join(lines) + "\n")


def main(argv: list[str] | None = None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("--folder", action="append", default=[], type=Path, help="more .blend files, searched deep")
    parser.add_argument("--blender", help="a Blender executable (default: this Python's bpy)")
    parser.add_argument("--out", type=Path, default=ROOT / "docs" / "corpus")
    parser.add_argument("--limit", type=int, default=0, help="at most this many files (0: all)")
    parser.add_argument("--describe", default="", help="what the folders are, for the table's header")
    arguments = parser.parse_args(argv)
    python = sys.executable
    files = bundled_files(python, arguments.blender)
    sources = ["the Blender's own templates and samples"]
    for folder in arguments.folder:
        if not folder.is_dir():
            print(f"error: --folder {folder}: not a folder", file=sys.stderr)
            return 2
        files += sorted(folder.rglob("*.blend"))
        sources.append(f"`{folder.name}/`")
    if arguments.describe:
        sources.append(arguments.describe)
    if arguments.limit:
        files = files[: arguments.limit]
    records = []
    for index, path in enumerate(files, 1):
        record = run_one(path, python, arguments.blender)
        record["class"] = classify(record)
        records.append(record)
        print(f"[{index}/{len(files)}] {record['class']:15} {path}", flush=True)
    version = records[0].get("blender", "?") if records else "?"
    write(_portable(records, arguments.folder), arguments.out, sources, f"Blender {version}")
    print(f"wrote {arguments.out}.md")
    return 0


if __name__ == "__main__":
    sys.exit(main())
