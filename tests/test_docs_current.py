"""The documentation describes the product as it is: no page, test or code comment cites a number of the project's
issue tracker (which is not in the repository: the reader cannot follow "issue 21"; name the behaviour instead), and
docs/architecture.md's module map lists every module of the tracer and of the add-on.

Issue numbers. Searched: every Markdown file of the repository outside its virtual environments and build output
(README.md, docs/, addon/README.md, ...), every .py file of tests/ (comments, docstrings and any string), and the
comments and docstrings of every .py file of tracer/, addon/ and scripts/. A citation is

- the word "issue" or "issues" followed by a number, with or without `#` or a hyphen between ("issue 21",
  "Issue #36", "issues 21 and 22", "the issue-21 scenes"), anywhere in the searched text; and
- a bare `#` and a number, as GitHub writes a reference ("(#36)", "see #12", "#7's fix"), in Markdown and in
  comments and docstrings (not in other strings of code, where `#555` is a CSS colour).

Not a citation: a link (any `scheme://...` address is removed before the search, so
`https://github.com/KhronosGroup/glTF-Blender-IO/issues/123` and other projects' trackers are cited by their
address, which a reader can follow); this file's own examples; a `#` and a number inside quotes (`"#2"`: the
suffix Blender gives a repeated name); a `#` glued to a word or another `#` (`frame_####`, `Cube#2`); a Markdown
heading's `#`s. Another project's issue is cited by its link, never as a bare "issue N", which reads as this tracker's.

The module map. Every .py file under tracer/ and addon/, at any depth, is listed in docs/architecture.md: in the
section (level-2 heading) whose title names its package in backticks (`tracer/` or `addon/`), as a backticked path
relative to the package (`scene/wind.py`, `engine/viewport.py`) or from the repository root (`tracer/scene/wind.py`)
in the first cell of a table row. A package's `__init__.py` whose whole body is its docstring says no more than the
folder's row and need not be listed; one with code (the tracer's public API, the add-on's registration) is listed.
"""

from __future__ import annotations

import ast
import io
import os
import re
import tokenize
from pathlib import Path

ROOT = Path(__file__).resolve().parents[1]
ARCHITECTURE = ROOT / "docs" / "architecture.md"
PACKAGES = ("tracer", "addon")
CODE_FOLDERS = ("tracer", "addon", "scripts")
SKIPPED_FOLDERS = {".git", "out", "dist", "node_modules", "__pycache__", "build", ".ruff_cache", "weathervane.egg-info"}

URL = re.compile(r"\b[a-z][a-z0-9+.-]*://\S+", re.IGNORECASE)
ISSUE_WORD = re.compile(r"\bissues?[ \t]*(?:#|-|no\.?[ \t]*)?[ \t]*\d+", re.IGNORECASE)
BARE_HASH = re.compile(r"(?<![\w#&\"'`/])#\d+\b(?![\w\"'])")
HEADING_HASHES = re.compile(r"^[ \t]*#{1,6}[ \t]")


def tracked_files(folder: str, suffix: str) -> list[Path]:
    """Files under the folder (the repository's root: "") ending in suffix, at any depth, outside virtual
    environments, build output and caches (pruned, not walked)."""
    found = []
    for top, folders, files in os.walk(ROOT / folder):
        folders[:] = [name for name in folders if name not in SKIPPED_FOLDERS and not name.startswith(".venv")]
        found += [Path(top) / name for name in files if name.endswith(suffix)]
    return sorted(found)


def citations(text: str, bare_hash: bool) -> list[str]:
    """The tracker citations in text (links removed first), each as it is written."""
    found = []
    for line in URL.sub(" ", text).splitlines():
        found += [match.group(0) for match in ISSUE_WORD.finditer(line)]
        if bare_hash:
            rest = HEADING_HASHES.sub(" ", ISSUE_WORD.sub(" ", line))
            found += [match.group(0) for match in BARE_HASH.finditer(rest)]
    return found


def comments_and_docstrings(source: str) -> list[tuple[int, str]]:
    """(line number, text) of every comment and of every line of every docstring (module, class, function); none
    where the source has no candidate citation at all (tokenizing every module would take a second)."""
    if not (ISSUE_WORD.search(source) or BARE_HASH.search(source)):
        return []
    found = [
        (token.start[0], token.string)
        for token in tokenize.generate_tokens(io.StringIO(source).readline)
        if token.type == tokenize.COMMENT
    ]
    for node in ast.walk(ast.parse(source)):
        if isinstance(node, ast.Module | ast.ClassDef | ast.FunctionDef | ast.AsyncFunctionDef):
            body = node.body
            first = body[0] if body else None
            if (
                isinstance(first, ast.Expr)
                and isinstance(first.value, ast.Constant)
                and isinstance(first.value.value, str)
            ):
                lines = first.value.value.splitlines()
                found += [(first.lineno + offset, line) for offset, line in enumerate(lines)]
    return found


def test_no_page_test_or_comment_cites_a_tracker_number():
    problems = []
    for page in tracked_files("", ".md"):
        for number, line in enumerate(page.read_text(encoding="utf-8").splitlines(), 1):
            problems += [f"{page.relative_to(ROOT)}:{number}: {cited!r}" for cited in citations(line, True)]
    for module in tracked_files("tests", ".py"):
        if module == Path(__file__).resolve():
            continue  # its docstring and examples show what a citation is
        source = module.read_text(encoding="utf-8")
        for number, line in enumerate(source.splitlines(), 1):
            problems += [f"{module.relative_to(ROOT)}:{number}: {cited!r}" for cited in citations(line, False)]
        for number, text in comments_and_docstrings(source):
            problems += [
                f"{module.relative_to(ROOT)}:{number}: {cited!r}"
                for cited in citations(text, True)
                if not ISSUE_WORD.fullmatch(cited)  # those are counted above, line by line
            ]
    for folder in CODE_FOLDERS:
        for module in tracked_files(folder, ".py"):
            for number, text in comments_and_docstrings(module.read_text(encoding="utf-8")):
                problems += [f"{module.relative_to(ROOT)}:{number}: {cited!r}" for cited in citations(text, True)]
    assert not problems, (
        "tracker numbers cited (name the behaviour instead; another project's issue by its link):\n"
        + "\n".join(problems)
    )


def sections(text: str) -> dict[str, str]:
    """Each level-2 section of a Markdown page by its heading's text (fenced code left out)."""
    found: dict[str, str] = {}
    title = ""
    fenced = False
    for line in text.splitlines():
        fenced ^= line.startswith("```")
        if not fenced and line.startswith("## "):
            title = line[3:].strip()
            found[title] = ""
        elif title and not fenced:
            found[title] += line + "\n"
    return found


def listed_modules(section: str, package: str) -> set[str]:
    """The paths (relative to the package) in the first cell of the section's table rows."""
    listed = set()
    for line in section.splitlines():
        if not line.startswith("|"):
            continue
        first = line.strip().strip("|").split("|")[0]
        for path in re.findall(r"`([^`\s]+\.py)`", first):
            listed.add(path.removeprefix(f"{package}/"))
    return listed


def needs_listing(module: Path) -> bool:
    """Every module but a package's `__init__.py` that holds nothing but its docstring."""
    if module.name != "__init__.py":
        return True
    body = ast.parse(module.read_text(encoding="utf-8")).body
    return not (len(body) <= 1 and all(isinstance(node, ast.Expr) for node in body))


def test_the_architecture_map_lists_every_module():
    pages = sections(ARCHITECTURE.read_text(encoding="utf-8"))
    unlisted = []
    for package in PACKAGES:
        titles = [title for title in pages if f"`{package}/`" in title]
        assert titles, f"docs/architecture.md has no level-2 section whose title names `{package}/`"
        listed = set().union(*(listed_modules(pages[title], package) for title in titles))
        modules = [module for module in tracked_files(package, ".py") if needs_listing(module)]
        assert modules, f"found no module in {package}/"
        for module in modules:
            path = module.relative_to(ROOT / package).as_posix()
            if path not in listed:
                unlisted.append(f"{package}/{path}")
    assert not unlisted, (
        "modules docs/architecture.md's module map does not list (a table row whose first cell holds the path in "
        "backticks, under the package's section):\n" + "\n".join(unlisted)
    )


def test_the_rules_tell_a_citation_from_what_is_not():
    assert citations("the acceptance suite of issues 21 and 22", True) == ["issues 21"]
    assert citations("Issue #36 and issue-21 scenes", True) == ["Issue #36", "issue-21"]
    assert citations("fixed in (#36), see #12", True) == ["#36", "#12"]
    assert citations("https://github.com/KhronosGroup/glTF-Blender-IO/issues/123#issuecomment-9", True) == []
    assert citations('a repeated name gets "#2", "#3"; frame_#### and Cube#2', True) == []
    assert citations("## 3 Heading", True) == []
    assert citations("border: 1px solid #555", False) == []
    assert citations("issues of stability, 3 of them", True) == []
