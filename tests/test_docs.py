"""The documentation stays current: every doc in docs/ says what it is for and is linked from the README's list of
documents, every module opens with a docstring, and every figure in docs/performance.md's table of current figures
carries the date it was taken and a command that exists (a make target of the Makefile, or a script that is there).
"""

from __future__ import annotations

import ast
import datetime
import re
import sys
from pathlib import Path

ROOT = Path(__file__).resolve().parents[1]
README = ROOT / "README.md"
GUIDE = ROOT / "docs" / "performance.md"
DOCS = sorted((ROOT / "docs").glob("*.md"))
MODULES = sorted([*ROOT.glob("tracer/**/*.py"), *ROOT.glob("addon/**/*.py"), *ROOT.glob("scripts/*.py")])
FIGURE_COLUMNS = ["what", "figure", "taken", "command"]
# how the work was organised is commit history, not documentation
NARRATION = re.compile(
    r"\b(?:first|second|third|fourth|fifth|sixth|seventh|eighth|ninth|tenth|this|that|next|last|later|earlier|"
    r"previous|same)\s+(?:working\s+)?session\b|\b(?:this|later|earlier|previous|next)\s+round\b|\bround\s+of\s+work\b",
    re.IGNORECASE,
)
# a figure as the README states it: a number or range followed by its unit, or a decimal (not a share in %)
FIGURE = re.compile(
    r"(?<![\w.-])(\d[\d,]*(?:\.\d+)?(?:-\d[\d,]*(?:\.\d+)?)?)(?=\s?(?:x|ms|s|MB|MiB|GB|GiB)\b)"
    r"|(?<![\w.-])(\d[\d,]*\.\d+)(?![\w.%])"
)


def section(text: str, title: str) -> str:
    """The text under the level-2 heading `## title`, up to the next level-2 heading."""
    match = re.search(rf"^## {re.escape(title)}\n(.*?)(?=^## |\Z)", text, re.MULTILINE | re.DOTALL)
    assert match, f"no section '## {title}'"
    return match.group(1)


def table(text: str) -> list[list[str]]:
    """The first markdown table in text, as rows of stripped cells (the header first, the separator left out)."""
    lines = [line for line in text.splitlines() if line.startswith("|")]
    rows = [[cell.strip() for cell in line.strip().strip("|").split("|")] for line in lines]
    return [row for row in rows if not all(set(cell) <= set("-: ") for cell in row)]


def figures() -> list[dict[str, str]]:
    header, *rows = table(section(GUIDE.read_text(), "Current figures"))
    assert header == FIGURE_COLUMNS, header
    return [dict(zip(header, row, strict=True)) for row in rows]


def make_targets() -> set[str]:
    return set(re.findall(r"^([A-Za-z][\w-]*)\s*:(?!=)", (ROOT / "Makefile").read_text(), re.MULTILINE))


def slug(heading: str) -> str:
    """GitHub's anchor for a heading: lower case, punctuation dropped, spaces as hyphens."""
    return re.sub(r"[^\w\- ]", "", heading.strip().lower()).replace(" ", "-")


def anchors(page: Path) -> set[str]:
    found: set[str] = set()
    fenced = False
    for line in page.read_text().splitlines():
        fenced ^= line.startswith("```")
        heading = re.match(r"#{1,6} +(.+?) *$", line)
        if heading and not fenced:
            name = slug(heading.group(1))
            count = sum(1 for anchor in found if anchor == name or re.fullmatch(rf"{re.escape(name)}-\d+", anchor))
            found.add(f"{name}-{count}" if count else name)
    return found


def test_every_doc_is_one_line_in_the_readmes_list_of_documents():
    listed = section(README.read_text(), "Documents").splitlines()
    for doc in DOCS:
        link = f"[docs/{doc.name}](docs/{doc.name})"
        lines = [number for number, line in enumerate(listed) if line.startswith(f"- {link}")]
        assert lines, f"README.md's Documents list has no line '- {link}: what it is for'"
        after = listed[lines[0] + 1] if lines[0] + 1 < len(listed) else ""
        assert not after.startswith("  "), f"README.md lists {doc.name} on more than one line"


def test_every_doc_opens_with_what_it_is_for():
    for doc in DOCS:
        title, *rest = doc.read_text().splitlines()
        assert title.startswith("# "), f"{doc.name} does not open with its title"
        opening = next((line for line in rest if line.strip()), "")
        assert opening and not opening.startswith(("#", "|", "-", "*", "```", "!", "<")), (
            f"{doc.name}: its title is not followed by a paragraph saying what the page is for: {opening!r}"
        )


def test_no_doc_narrates_how_the_work_was_organised():
    for page in [README, *DOCS]:
        for number, line in enumerate(page.read_text().splitlines(), 1):
            assert not NARRATION.search(line), f"{page.name}:{number}: {line.strip()}"


def test_every_module_opens_with_a_docstring():
    assert len(MODULES) > 50, "the module globs found too few files"
    missing = []
    for module in MODULES:
        docstring = ast.get_docstring(ast.parse(module.read_text(), str(module)))
        if not (docstring and docstring.strip()):
            missing.append(str(module.relative_to(ROOT)))
    assert not missing, f"modules without an opening docstring: {missing}"


def test_the_performance_guide_is_a_guide():
    text = GUIDE.read_text()
    assert len(text.splitlines()) <= 450
    headings = re.findall(r"^#+ .*$", text, re.MULTILINE)
    dated = [heading for heading in headings if re.search(r"\d{4}-\d{2}-\d{2}", heading)]
    assert not dated, f"sections named by date: {dated}"
    assert sum(heading == "## Current figures" for heading in headings) == 1


def test_each_current_figure_carries_its_date_and_a_command_that_exists():
    rows = figures()
    assert len(rows) >= 5
    targets = make_targets()
    for row in rows:
        what = row["what"]
        assert re.search(r"\d", row["figure"]), f"{what}: no figure"
        assert re.fullmatch(r"\d{4}-\d{2}-\d{2}", row["taken"]), f"{what}: the date taken is {row['taken']!r}"
        assert datetime.date.fromisoformat(row["taken"]) >= datetime.date(2026, 1, 1)
        commands = [code for code in re.findall(r"`([^`]+)`", row["command"]) if not code.startswith("-")]
        assert commands, f"{what}: no command"
        for command in commands:
            if command.startswith("make "):
                target = command.split()[1]
                assert target in targets, f"{what}: `{command}`: the Makefile has no target {target}"
            else:
                scripts = re.findall(r"\S+\.py\b", command)
                assert scripts, f"{what}: `{command}` is neither a make target nor a script"
                for script in scripts:
                    assert (ROOT / script).is_file(), f"{what}: `{command}`: {script} does not exist"


def test_the_readmes_speed_figures_are_the_guides():
    readme = README.read_text()
    blocks = re.split(r"\n\s*\n|\n(?=- )", readme)  # paragraphs and list items
    stated = section(readme, "Speed") + "\n".join(block for block in blocks if "](docs/performance.md" in block)
    current = section(GUIDE.read_text(), "Current figures")
    numbers = [first or second for first, second in FIGURE.findall(stated)]
    assert numbers, "the README's Speed section states no figure"
    for number in numbers:
        assert re.search(rf"(?<![\d.]){re.escape(number)}(?![\d])", current), (
            f"README.md states {number}, which is not in docs/performance.md's table of current figures"
        )


def test_the_links_of_the_readme_and_the_guide_resolve():
    for page in [README, GUIDE]:
        for target in re.findall(r"\]\(([^)\s]+)\)", page.read_text()):
            if re.match(r"[a-z]+:", target):
                continue
            path, _, anchor = target.partition("#")
            destination = (page.parent / path) if path else page
            assert destination.exists(), f"{page.name}: {target}: no such file"
            if anchor and destination.suffix == ".md":
                assert anchor in anchors(destination), f"{page.name}: {target}: no such heading"


def test_make_study_finds_its_table_in_the_guide():
    sys.path.insert(0, str(ROOT / "scripts"))
    try:
        from study import MARK_END, MARK_START
    finally:
        sys.path.remove(str(ROOT / "scripts"))
    text = GUIDE.read_text()
    assert text.count(MARK_START) == 1 and text.count(MARK_END) == 1
    assert text.index(MARK_START) < text.index(MARK_END)
    taken = text[text.index(MARK_START) + len(MARK_START) :].strip().splitlines()[0]
    assert re.match(r"Taken \d{4}-\d{2}-\d{2} \(`make study`", taken), f"the study's table carries no date: {taken}"
