"""The packages' layers (docs/architecture.md) hold: imports point down or sideways within a layer, never up, and
never in a circle; the tracer imports nothing from Blender or the add-on.

Read from the source with `ast`, every import counted, also those inside functions (a lazy import still ties the
modules together). The add-on reaches the tracer through one module, its facade (addon/tracer_api.py), by ordinary
imports: no other add-on module imports the tracer, and none looks a module up by its name in a string.
"""

from __future__ import annotations

import ast
from pathlib import Path

import pytest

ROOT = Path(__file__).resolve().parents[1]

# Lowest first. A module may import modules of its own layer or of a lower one.
TRACER_LAYERS = ("scene", "geometry", "tracing", "workers", "frames", "")  # "": the package's top (entry points)
ADDON_LAYERS: tuple[tuple[str, ...], ...] = (
    # Blender's API, the tracer (through its facade), plain data both ways; the folders' docstring-only __init__s
    (
        "compat",
        "tracer_api",
        "vane",
        "convert",
        "engine",
        "engine.workers",
        "engine.messages",
        "engine.collector",
        "vane.camera",
        "vane.lights",
        "vane.materials",
        "convert.mesh_export",
        "convert.node_tree",
        "convert.material_convert",
        "convert.light_convert",
        "convert.world_convert",
        "convert.pass_map",
        "convert.motion_blur",
    ),
    (
        "vane.build",
        "vane.animation",
        "vane.properties",
        "vane.sync",
        "convert.export",
        "convert.twin",
        "convert.exact_twin",
        "convert.conversion_report",
    ),  # the scene the add-on builds, reads and keys
    ("engine.viewport", "engine.engine"),  # the render engine and the Rendered view
    ("vane.operators", "vane.panels", "engine.render_panels", "engine.motion_panel"),  # what the user clicks
    ("__init__",),  # registration
)
# The add-on's folders: the weathervane (vane/), the conversion between Blender and the tracer (convert/), the render
# engine (engine/); at the top only registration, Blender's version differences and the tracer's facade.
ADDON_FOLDERS = ("vane", "convert", "engine")
ADDON_TOP = ("__init__", "compat", "tracer_api")
FACADE = "tracer_api"  # the one module of the add-on that imports the tracer
TRACER_PACKAGES = ("tracer", "weathervane_tracer")  # the repository's package; the built add-on's copy of it


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


ADDON_MODULES = sorted((ROOT / "addon").rglob("*.py"))


def addon_id(path: Path) -> str:
    return path.relative_to(ROOT / "addon").as_posix()


@pytest.mark.parametrize("path", ADDON_MODULES, ids=addon_id)
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


def test_every_addon_module_is_in_a_layer_and_a_folder():
    for path in ADDON_MODULES:
        name = module_name(path, ROOT / "addon") or "__init__"
        assert any(name in layer for layer in ADDON_LAYERS), f"addon/{addon_id(path)}: not in a layer of ADDON_LAYERS"
        parts = path.relative_to(ROOT / "addon").parts
        if len(parts) == 1:
            assert path.stem in ADDON_TOP, f"addon/{addon_id(path)}: belongs in one of the folders {ADDON_FOLDERS}"
        else:
            assert len(parts) == 2 and parts[0] in ADDON_FOLDERS, f"addon/{addon_id(path)}: not in {ADDON_FOLDERS}"


def test_each_addon_folder_says_what_it_turns_into_what():
    for folder in ADDON_FOLDERS:
        tree = ast.parse((ROOT / "addon" / folder / "__init__.py").read_text(encoding="utf-8"))
        docstring = ast.get_docstring(tree)
        assert docstring and "->" in docstring and len(docstring.splitlines()) == 1, f"addon/{folder}/__init__.py"


def _string_lookups(tree: ast.AST) -> list[str]:
    """Calls that import a module by a name in a string: importlib.import_module, __import__, and the add-on's old
    `module("layer.name")` helper."""
    found = []
    for node in ast.walk(tree):
        if not isinstance(node, ast.Call):
            continue
        function = node.func
        called = function.attr if isinstance(function, ast.Attribute) else getattr(function, "id", None)
        if called in {"import_module", "__import__", "module", "find_spec", "spec_from_file_location"}:
            found.append(ast.unparse(node))
    return found


def test_the_addon_looks_no_module_up_by_a_name_in_a_string():
    """A module named in a string is one that neither a reader nor an IDE can follow; the add-on imports the tracer
    (through its facade) and its own modules by ordinary imports."""
    for path in ADDON_MODULES:
        found = _string_lookups(ast.parse(path.read_text(encoding="utf-8")))
        assert not found, f"addon/{addon_id(path)} looks modules up by name: {found}"


def test_the_string_lookup_guard_sees_the_ways_of_importing_by_name():
    source = (
        "import importlib\nfrom ._tracer import module\n"
        "a = importlib.import_module('tracer.scene.loader')\nb = module('scene.loader')\nc = __import__('tracer')\n"
    )
    assert len(_string_lookups(ast.parse(source))) == 3


def _tracer_imports(tree: ast.AST) -> list[str]:
    """The modules of the tracer (the repository's package or the built add-on's copy) that the source imports."""
    found = []
    for node in ast.walk(tree):
        names = [node.module or ""] if isinstance(node, ast.ImportFrom) and not node.level else []
        names += [alias.name for alias in node.names] if isinstance(node, ast.Import) else []
        found += [name for name in names if name.split(".")[0] in TRACER_PACKAGES]
    return found


def test_the_addon_reaches_the_tracer_only_through_its_facade():
    for path in ADDON_MODULES:
        if path.stem != FACADE:
            found = _tracer_imports(ast.parse(path.read_text(encoding="utf-8")))
            assert not found, f"addon/{addon_id(path)} imports the tracer past addon/{FACADE}.py: {found}"


def test_the_facades_two_branches_import_the_same_names_and_all_lists_them():
    """The facade imports the tracer's names from the repository's package or from the built add-on's copy; both
    branches take the same names from the same modules, every name the add-on uses, and __all__ lists them."""
    tree = ast.parse((ROOT / "addon" / f"{FACADE}.py").read_text(encoding="utf-8"))
    branch = next(node for node in tree.body if isinstance(node, ast.If) and _tracer_imports(node))
    imported = []
    for body, package in ((branch.body, "weathervane_tracer"), (branch.orelse, "tracer")):
        names = set()
        for node in ast.walk(ast.Module(body=body, type_ignores=[])):
            if isinstance(node, ast.ImportFrom) and node.module and node.module.split(".")[0] in TRACER_PACKAGES:
                assert node.module.split(".")[0] == package, f"{node.module} in the {package} branch"
                relative = node.module.split(".", 1)[1]
                assert (ROOT / "tracer" / f"{relative.replace('.', '/')}.py").is_file(), f"no tracer.{relative}"
                names |= {(relative, alias.name, alias.asname or alias.name) for alias in node.names}
        imported.append(names)
    assert imported[0] == imported[1]
    exported = next(
        ast.literal_eval(node.value)
        for node in tree.body
        if isinstance(node, ast.Assign) and getattr(node.targets[0], "id", None) == "__all__"
    )
    assert sorted(exported) == sorted(name for _, _, name in imported[1])
    used = set()
    for path in ADDON_MODULES:
        for node in ast.walk(ast.parse(path.read_text(encoding="utf-8"))):
            if isinstance(node, ast.Attribute) and getattr(node.value, "id", None) == "tracer":
                used.add(node.attr)  # `from .. import tracer_api as tracer`, then tracer.name
            elif isinstance(node, ast.ImportFrom) and (node.module or "").split(".")[-1] == FACADE:
                used |= {alias.name for alias in node.names}
    assert used == set(exported), f"unused: {sorted(set(exported) - used)}; missing: {sorted(used - set(exported))}"


# ---- the tracing core: no mixins calling each other back, classes and functions of a size a reader can hold ------

TRACING = sorted((ROOT / "tracer" / "tracing").glob("*.py"))
LARGEST_CLASS = 400  # lines
MOST_PARAMETERS, LONGEST_FUNCTION = 8, 80  # beyond these a function's docstring says why ("The reason for ...")


def _classes(paths: list[Path]) -> dict[str, tuple[str, ast.ClassDef]]:
    """Every class of the modules, by name: (its module's file name, its definition)."""
    found = {}
    for path in paths:
        for node in ast.walk(ast.parse(path.read_text())):
            if isinstance(node, ast.ClassDef):
                found[node.name] = (path.name, node)
    return found


def _own_and_inherited(name: str, classes: dict[str, tuple[str, ast.ClassDef]]) -> set[str]:
    """The names a class defines (methods, class-level names) with those of its bases among the classes."""
    _, node = classes[name]
    names = {item.name for item in node.body if isinstance(item, ast.FunctionDef | ast.AsyncFunctionDef)}
    names |= {item.target.id for item in node.body if isinstance(item, ast.AnnAssign) and hasattr(item.target, "id")}
    for base in node.bases:
        if isinstance(base, ast.Name) and base.id in classes:
            names |= _own_and_inherited(base.id, classes)
    return names


def self_calls_outside_the_class(paths: list[Path]) -> list[str]:
    """Each `self.name(...)` call in a class's methods whose name the class and its bases do not define: a mixin
    calling back into the class that mixes it in (a circle of calls that no import line shows)."""
    classes = _classes(paths)
    problems = []
    for name, (module, node) in classes.items():
        known = _own_and_inherited(name, classes)
        for call in ast.walk(node):
            if (
                isinstance(call, ast.Call)
                and isinstance(call.func, ast.Attribute)
                and isinstance(call.func.value, ast.Name)
                and call.func.value.id == "self"
                and call.func.attr not in known
            ):
                problems.append(f"{module}: {name} calls self.{call.func.attr}(), which it does not define")
    return problems


def test_the_self_call_guard_sees_a_mixin_calling_back(tmp_path):
    mixin = tmp_path / "mixin.py"
    mixin.write_text("class Shading:\n    def shade(self):\n        return self.shadow_through()\n")
    host = tmp_path / "host.py"
    host.write_text("class Prepared(Shading):\n    def shadow_through(self):\n        return self.shade()\n")
    assert self_calls_outside_the_class([mixin, host]) == [
        "mixin.py: Shading calls self.shadow_through(), which it does not define"
    ]


def test_no_tracing_class_calls_back_through_self_into_another():
    assert self_calls_outside_the_class(TRACING) == []


def test_the_largest_tracing_class_is_under_400_lines():
    sizes = {
        f"{module}: {name}": node.end_lineno - node.lineno + 1 for name, (module, node) in _classes(TRACING).items()
    }
    assert max(sizes.values()) < LARGEST_CLASS, sorted(sizes.items(), key=lambda item: -item[1])[:3]


def test_long_tracing_functions_say_why():
    unexplained = []
    for path in TRACING:
        for node in ast.walk(ast.parse(path.read_text())):
            if not isinstance(node, ast.FunctionDef):
                continue
            arguments = [a for a in (*node.args.args, *node.args.kwonlyargs) if a.arg not in ("self", "cls")]
            lines = node.end_lineno - node.lineno + 1
            large = len(arguments) > MOST_PARAMETERS or lines > LONGEST_FUNCTION
            if large and "The reason for" not in (ast.get_docstring(node) or ""):
                unexplained.append(f"{path.name}: {node.name} ({len(arguments)} parameters, {lines} lines)")
    assert unexplained == []
