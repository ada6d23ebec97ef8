"""The packages' layers (docs/architecture.md) hold: imports point down or sideways within a layer, never up, and
never in a circle; the tracer imports nothing from Blender or the add-on.

Read from the source with `ast`, every import counted, also those inside functions (a lazy import still ties the
modules together) and the add-on's `module("layer.name")` look-ups of the tracer.
"""

from __future__ import annotations

import ast
from pathlib import Path

import pytest

ROOT = Path(__file__).resolve().parents[1]

# Lowest first. A module may import modules of its own layer or of a lower one.
TRACER_LAYERS = ("scene", "geometry", "tracing", "workers", "frames", "")  # "": the package's top (entry points)
ADDON_LAYERS: tuple[tuple[str, ...], ...] = (
    # Blender's API, the tracer, plain data both ways
    (
        "compat",
        "_tracer",
        "workers",
        "camera",
        "lights",
        "materials",
        "mesh_export",
        "node_tree",
        "material_convert",
        "light_convert",
        "world_convert",
        "pass_map",
    ),
    (
        "build",
        "animation",
        "export",
        "twin",
        "exact_twin",
        "properties",
        "conversion_report",
        "sync",
    ),  # the scene the add-on builds, reads and keys
    ("viewport", "engine"),  # the render engine and the Rendered view
    ("operators", "panels", "render_panels"),  # what the user clicks
    ("__init__",),  # registration
)


def module_name(path: Path, package_root: Path) -> str:
    parts = list(path.relative_to(package_root).with_suffix("").parts)
    return ".".join(parts[:-1] if parts[-1] == "__init__" else parts) if parts != ["__init__"] else ""


def imports_of(path: Path, package_root: Path) -> set[str]:
    """The package's own modules that the file imports (dotted names relative to the package root)."""
    name = module_name(path, package_root)
    is_package = path.name == "__init__.py"
    here = name.split(".") if name else []
    base_package = here if is_package else here[:-1]
    known = {module_name(p, package_root) for p in package_root.rglob("*.py")}
    found: set[str] = set()
    for node in ast.walk(ast.parse(path.read_text(encoding="utf-8"))):
        targets: list[str] = []
        if isinstance(node, ast.ImportFrom) and node.level:
            anchor = base_package[: len(base_package) - (node.level - 1)]
            stem = [*anchor, *(node.module.split(".") if node.module else [])]
            targets = [".".join([*stem, alias.name]) for alias in node.names]
            targets += [".".join(stem)] if node.module else []  # `from . import x` does not tie x to its package
        elif isinstance(node, ast.ImportFrom | ast.Import):
            top = package_root.name
            names = [node.module] if isinstance(node, ast.ImportFrom) else [alias.name for alias in node.names]
            for dotted in filter(None, names):
                if dotted == top or dotted.startswith(top + "."):
                    stem = dotted.split(".")[1:]
                    extra = [alias.name for alias in node.names] if isinstance(node, ast.ImportFrom) else []
                    targets += [".".join(stem)] + [".".join([*stem, alias]) for alias in extra]
        found.update(target for target in targets if target in known and target != name)
    return found


def graph(package_root: Path) -> dict[str, set[str]]:
    return {module_name(path, package_root): imports_of(path, package_root) for path in package_root.rglob("*.py")}


def circles(edges: dict[str, set[str]]) -> list[list[str]]:
    """Every import circle, as the modules on it (Tarjan's strongly connected components of more than one)."""
    index: dict[str, int] = {}
    low: dict[str, int] = {}
    stack: list[str] = []
    found: list[list[str]] = []

    def visit(node: str) -> None:
        index[node] = low[node] = len(index)
        stack.append(node)
        for successor in edges.get(node, ()):
            if successor not in index:
                visit(successor)
                low[node] = min(low[node], low[successor])
            elif successor in stack:
                low[node] = min(low[node], index[successor])
        if low[node] == index[node]:
            component = []
            while True:
                member = stack.pop()
                component.append(member)
                if member == node:
                    break
            if len(component) > 1:
                found.append(sorted(component))

    for node in sorted(edges):
        if node not in index:
            visit(node)
    return found


def tracer_layer(module: str) -> int:
    first = module.split(".")[0]
    return TRACER_LAYERS.index(first if first in TRACER_LAYERS else "")


def addon_layer(module: str) -> int:
    return next(rank for rank, layer in enumerate(ADDON_LAYERS) if (module or "__init__") in layer)


def test_the_graph_reader_sees_relative_absolute_and_lazy_imports(tmp_path):
    package = tmp_path / "pkg"
    (package / "low").mkdir(parents=True)
    (package / "__init__.py").write_text("from .low.a import thing\n")
    (package / "low" / "__init__.py").write_text("")
    (package / "low" / "a.py").write_text("def f():\n    from ..top import g\n")
    (package / "low" / "b.py").write_text("from . import a\nimport pkg.top\n")
    (package / "top.py").write_text("from pkg.low import b\n")
    edges = graph(package)
    assert edges["low.a"] == {"top"} and edges["low.b"] == {"low.a", "top"} and edges["top"] == {"low", "low.b"}
    assert edges[""] == {"low.a"}
    assert circles(edges) == [["low.a", "low.b", "top"]]


def test_tracer_has_no_import_circle():
    assert circles(graph(ROOT / "tracer")) == []


def test_addon_has_no_import_circle():
    assert circles(graph(ROOT / "addon")) == []


@pytest.mark.parametrize("path", sorted((ROOT / "tracer").rglob("*.py")), ids=lambda path: path.name)
def test_tracer_modules_import_only_their_layer_and_below(path):
    name = module_name(path, ROOT / "tracer")
    upward = {target for target in imports_of(path, ROOT / "tracer") if tracer_layer(target) > tracer_layer(name)}
    assert not upward, f"tracer.{name} (layer {tracer_layer(name)}) imports higher layers: {sorted(upward)}"


def test_every_tracer_module_is_in_a_layer():
    for path in (ROOT / "tracer").rglob("*.py"):
        parts = path.relative_to(ROOT / "tracer").parts
        assert len(parts) == 1 or parts[0] in TRACER_LAYERS, f"{path}: not in a layer of TRACER_LAYERS"


@pytest.mark.parametrize("path", sorted((ROOT / "addon").glob("*.py")), ids=lambda path: path.name)
def test_addon_modules_import_only_their_layer_and_below(path):
    name = module_name(path, ROOT / "addon")
    upward = {target for target in imports_of(path, ROOT / "addon") if addon_layer(target) > addon_layer(name)}
    assert not upward, f"addon.{name or '__init__'} imports higher layers: {sorted(upward)}"


def test_the_tracer_never_imports_blender_or_the_addon():
    for path in (ROOT / "tracer").rglob("*.py"):
        for node in ast.walk(ast.parse(path.read_text(encoding="utf-8"))):
            names = [node.module or ""] if isinstance(node, ast.ImportFrom) else []
            names += [alias.name for alias in node.names] if isinstance(node, ast.Import) else []
            for name in names:
                assert name.split(".")[0] not in {"bpy", "mathutils", "gpu", "addon"}, f"{path} imports {name}"


def test_the_addons_tracer_lookups_name_existing_modules():
    """The add-on reaches the tracer through `module("layer.name")` (addon/_tracer.py); a moved module must be
    followed there too."""
    known = {module_name(path, ROOT / "tracer") for path in (ROOT / "tracer").rglob("*.py")}
    for path in (ROOT / "addon").glob("*.py"):
        for node in ast.walk(ast.parse(path.read_text(encoding="utf-8"))):
            if isinstance(node, ast.Call) and getattr(node.func, "id", None) == "module" and node.args:
                argument = node.args[0]
                if isinstance(argument, ast.Constant):
                    assert argument.value in known, f"{path.name}: module({argument.value!r}) is not a tracer module"


def test_every_module_is_on_the_map():
    """docs/architecture.md names every module with what it turns into what: a new module is added there too."""
    text = (ROOT / "docs" / "architecture.md").read_text(encoding="utf-8")
    tracer_modules = [path.relative_to(ROOT / "tracer").as_posix() for path in (ROOT / "tracer").rglob("*.py")]
    tracer_modules = [name for name in tracer_modules if not name.endswith("/__init__.py") and name != "__main__.py"]
    addon_modules = [path.name for path in (ROOT / "addon").glob("*.py")]
    missing = [name for name in tracer_modules + addon_modules if f"`{name}`" not in text]
    assert not missing, f"docs/architecture.md does not name: {missing}"
