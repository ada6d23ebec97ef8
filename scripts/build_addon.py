"""The add-on sources and a copy of the tracer -> dist/: a Blender 4.2+ extension zip and a legacy zip for 3.4.

Usage: python scripts/build_addon.py [--dist dist]
The extension is built and validated by Blender's own tool (blender_ext.py, shipped inside the bpy wheel); the
legacy zip holds the same files under a `weathervane/` folder, as Blender 3.4's "Install Add-on" expects. Both carry
the tracer inside the add-on, so they install in a clean Blender with no pip.
"""

from __future__ import annotations

import argparse
import shutil
import subprocess
import sys
import tempfile
import tomllib
import zipfile
from pathlib import Path

ROOT = Path(__file__).resolve().parents[1]
PACKAGE = "weathervane"


def blender_ext_tool() -> Path:
    """blender_ext.py inside the installed bpy wheel."""
    import importlib.util

    spec = importlib.util.find_spec("bpy")
    if spec is None or spec.origin is None:
        sys.exit("error: the bpy wheel is not installed (pip install -e '.[blender]'); it carries blender_ext.py")
    candidates = sorted(Path(spec.origin).parent.glob("*/scripts/addons_core/bl_pkg/cli/blender_ext.py"))
    if not candidates:
        sys.exit(f"error: no blender_ext.py under {Path(spec.origin).parent}")
    return candidates[-1]


def stage(target: Path) -> None:
    """Copy the add-on and the tracer (sources and data only) into target."""
    ignore = shutil.ignore_patterns("__pycache__", "*.pyc")
    shutil.copytree(ROOT / "addon", target, ignore=ignore)
    # a top-level package of its own (addon/tracer_api.py): worker processes started afresh import it without the add-on
    shutil.copytree(ROOT / "tracer", target / "weathervane_tracer", ignore=ignore)


def run_tool(tool: Path, *arguments: str) -> None:
    result = subprocess.run([sys.executable, str(tool), *arguments], capture_output=True, text=True)
    if result.returncode != 0:
        sys.exit(f"error: blender_ext.py {arguments[0]} failed:\n{result.stdout}{result.stderr}")


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--dist", type=Path, default=ROOT / "dist")
    args = parser.parse_args()
    version = tomllib.loads((ROOT / "addon" / "blender_manifest.toml").read_text())["version"]
    tool = blender_ext_tool()
    args.dist.mkdir(parents=True, exist_ok=True)
    with tempfile.TemporaryDirectory() as scratch:
        staged = Path(scratch) / PACKAGE
        stage(staged)
        run_tool(tool, "validate", str(staged))
        extension = args.dist / f"{PACKAGE}-{version}.zip"
        built = Path(scratch) / extension.name
        run_tool(tool, "build", "--source-dir", str(staged), "--output-filepath", str(built))
        run_tool(tool, "validate", str(built))
        shutil.move(built, extension)
        legacy = args.dist / f"{PACKAGE}-{version}-blender-3.4.zip"
        partial = legacy.with_suffix(".partial")
        with zipfile.ZipFile(partial, "w", zipfile.ZIP_DEFLATED) as archive:
            for path in sorted(staged.rglob("*")):
                if path.is_file():
                    archive.write(path, Path(PACKAGE) / path.relative_to(staged))
        partial.replace(legacy)
    print(f"extension: {extension}")
    print(f"legacy (Blender 3.4): {legacy}")


if __name__ == "__main__":
    main()
