"""The docs cite only what exists: every repository path, dotted Python name, test
function and section heading cited in README.md, docs/**/*.md, the other tracked Markdown
files (not CHANGELOG.md: it is history), the comments of pyproject.toml, mkdocs.yml, the
scenario and asset YAML files and the CI scripts, and the code's docstrings and comments
resolves in today's tree; and the README's commands table is `twin --help`'s."""

from __future__ import annotations

import ast
import dataclasses
import importlib
import io
import re
import subprocess
import tokenize
from functools import cache
from pathlib import Path

import pytest

ROOT = Path(__file__).resolve().parents[1]

#: Top-level folders of the repository: a cited path starting with one of them must exist.
TOP_LEVEL = ("twin", "tests", "hardware", "scenarios", "assets", "docs", ".ci")
_TOP = "|".join(re.escape(t) for t in TOP_LEVEL)
PATH = re.compile(rf"(?<![\w./-])((?:{_TOP})/[\w./*-]*[\w*-])(?:::([\w:]+))?")
DOTTED = re.compile(r"(?<![\w./-])((?:twin|hardware)(?:\.[A-Za-z_]\w*)+)")
#: a test function cited by name alone (two words at least, so that `test_dir` is no citation)
TEST_NAME = re.compile(r"(?<![\w./:-])(test_[a-z0-9]+_\w+)(?![\w./])")
#: a section cited by its heading: README "Conventions", docs/scenarios.md, "Effects"
SECTION = re.compile(rf"(README|(?:{_TOP})/[\w./-]*\.md)['’]?s?,? (?:section )?[\"“]([^\"”]+)[\"”]")
#: what ends a file name, not a dotted Python name (`hardware.md`, `twin.yaml`)
FILE_SUFFIXES = {"md", "py", "yaml", "yml", "json", "toml", "csv", "png", "mp4", "txt", "stl", "html"}
#: Dotted names that are not Python objects: the entry-point group of the backends.
NOT_PYTHON = {"twin.backends"}
#: Slash-separated names that are not repository paths: where the wheel puts the package
#: data (pyproject.toml, force-include) and the Gymnasium id.
NOT_PATHS = {"twin/_data", "twin/ContourFollowing-v0"}
#: History, not a description of today's tree.
HISTORY = {"CHANGELOG.md", "assets/irb120/CHANGELOG.md"}


def _tracked(pattern: str) -> list[Path]:
    out = subprocess.run(
        ["git", "ls-files", "--cached", "--others", "--exclude-standard", pattern],
        cwd=ROOT,
        capture_output=True,
        text=True,
        check=True,
    ).stdout
    return sorted(ROOT / line for line in out.splitlines() if (ROOT / line).exists())


def markdown_sources() -> list[Path]:
    return [p for p in _tracked("*.md") if p.relative_to(ROOT).as_posix() not in HISTORY]


def hash_comments(path: Path) -> str:
    """The `#` comments of a TOML, YAML or shell file (a `#` inside a quoted string counts too)."""
    return "\n".join(line.split("#", 1)[1] for line in path.read_text().splitlines() if "#" in line)


def code_prose(path: Path) -> str:
    """A Python file's comments and docstrings (what it says about other code)."""
    text = path.read_text()
    parts = [tok.string for tok in tokenize.generate_tokens(io.StringIO(text).readline) if tok.type == tokenize.COMMENT]
    for node in ast.walk(ast.parse(text)):
        if isinstance(node, (ast.Module, ast.ClassDef, ast.FunctionDef, ast.AsyncFunctionDef)):
            doc = ast.get_docstring(node, clean=False)
            if doc:
                parts.append(doc)
    return "\n".join(parts)


def sources() -> dict[str, str]:
    """{source name: text} of everything whose citations are checked."""
    texts = {p.relative_to(ROOT).as_posix(): p.read_text() for p in markdown_sources()}
    for p in [ROOT / "pyproject.toml", ROOT / "mkdocs.yml", *_tracked("*.yaml"), *_tracked(".ci/*")]:
        texts[f"{p.relative_to(ROOT).as_posix()} (comments)"] = hash_comments(p)
    for p in _tracked("*.py"):
        rel = p.relative_to(ROOT).as_posix()
        if rel != "tests/test_docs.py":
            texts[rel] = code_prose(p)
    return texts


@cache
def defined_tests() -> dict[str, set[str]]:
    """{tests/…py: the names of its test functions and classes (Class::method too)}."""
    found: dict[str, set[str]] = {}
    for p in _tracked("tests/*.py"):
        names: set[str] = set()
        for node in ast.parse(p.read_text()).body:
            if isinstance(node, (ast.FunctionDef, ast.AsyncFunctionDef, ast.ClassDef)):
                names.add(node.name)
            if isinstance(node, ast.ClassDef):
                names.update(
                    f"{node.name}::{m.name}"
                    for m in node.body
                    if isinstance(m, (ast.FunctionDef, ast.AsyncFunctionDef))
                )
        found[p.relative_to(ROOT).as_posix()] = names
    return found


def path_problem(path: str, test: str | None) -> str | None:
    """Why a cited repository path (and pytest node) does not resolve, or None."""
    if path in NOT_PATHS:
        return None
    if "*" in path:
        return None if any(ROOT.glob(path)) else f"nothing matches {path}"
    target = ROOT / path
    if not target.exists():
        return f"no such path {path}"
    if test is not None and test not in defined_tests().get(path, set()):
        return f"{path} has no test {test}"
    return None


def _has_attribute(obj, name: str):
    """obj.name, or a dataclass' / pydantic model's field of that name, else a sentinel."""
    try:
        return getattr(obj, name)
    except AttributeError:
        pass
    if dataclasses.is_dataclass(obj) and name in {f.name for f in dataclasses.fields(obj)}:
        return None
    if name in getattr(obj, "model_fields", {}):
        return None
    return _MISSING


_MISSING = object()


@cache
def dotted_problem(name: str) -> str | None:
    """Why a dotted name (module, then attributes) does not resolve, or None."""
    if name in NOT_PYTHON:
        return None
    parts = name.split(".")
    obj, depth = None, 0
    for depth in range(len(parts), 0, -1):
        try:
            obj = importlib.import_module(".".join(parts[:depth]))
            break
        except ModuleNotFoundError:
            continue
    else:
        return f"no module {parts[0]}"
    for attr in parts[depth:]:
        if obj is None:
            return None  # a field of a dataclass or model: it resolves, its value is not walked
        obj = _has_attribute(obj, attr)
        if obj is _MISSING:
            return f"{name}: {'.'.join(parts[:depth])} has no {attr!r}"
        depth += 1
    return None


def headings(path: Path) -> set[str]:
    """A Markdown file's headings and bold run-in headings (`**The free skin beyond the cap**`)."""
    text = path.read_text()
    found = {m.group(1).strip() for m in re.finditer(r"^#+ (.+?)\s*#*$", text, re.M)}
    found |= {m.group(1).strip(" .") for m in re.finditer(r"^\*\*([^*]+)\*\*", text, re.M)}
    found |= {m.group(1).strip(" .") for m in re.finditer(r"^\* \*([^*]+)\*", text, re.M)}
    return {_plain(h) for h in found}


def _plain(heading: str) -> str:
    return " ".join(heading.replace("`", "").split()).strip(" .")


def section_problem(document: str, section: str) -> str | None:
    """Why a cited section ("README", "Conventions") is not a heading of that file, or None."""
    path = ROOT / ("README.md" if document == "README" else document)
    if not path.exists():
        return f"no such path {document}"
    wanted = _plain(section)
    if not any(h == wanted or h.startswith((wanted + " (", wanted + ":")) for h in headings(path)):
        return f"{document} has no section {section!r}"
    return None


def citations(text: str) -> tuple[list[tuple[str, str | None]], list[str], list[str], list[tuple[str, str]]]:
    """(paths with their optional ::test, dotted names, bare test names, (document, section))
    cited in `text`."""
    paths = [(m.group(1), m.group(2)) for m in PATH.finditer(text)]
    dotted = [m.group(1) for m in DOTTED.finditer(text) if m.group(1).rsplit(".", 1)[1] not in FILE_SUFFIXES]
    tests = [m.group(1) for m in TEST_NAME.finditer(text)]
    sections = [(m.group(1), m.group(2)) for m in SECTION.finditer(text)]
    return paths, dotted, tests, sections


def problems(texts: dict[str, str]) -> list[str]:
    every_test = set().union(*defined_tests().values()) | {
        n.split("::")[-1] for names in defined_tests().values() for n in names
    }
    found = []
    for source, text in texts.items():
        paths, dotted, tests, sections = citations(text)
        for document, section in sections:
            if (why := section_problem(document, section)) is not None:
                found.append(f"{source}: {why}")
        for path, test in paths:
            if (why := path_problem(path.rstrip("."), test)) is not None:
                found.append(f"{source}: {why}")
        for name in dotted:
            if (why := dotted_problem(name)) is not None:
                found.append(f"{source}: {why}")
        for test in tests:
            if (
                test not in every_test
                and not (ROOT / "tests" / f"{test}.py").exists()
                and not any(Path(p).stem == test for p in defined_tests())
            ):
                found.append(f"{source}: no test named {test}")
    return sorted(set(found))


def test_every_cited_path_and_name_exists():
    assert problems(sources()) == []


@pytest.mark.parametrize(
    "text",
    [
        "see `twin/world/no_such_module.py`",
        "tests/tools/test_evaluate.py::test_no_such_test checks it",
        "the settings live in twin.sensing.perception.NoSuchConfig",
        "`test_no_such_test_anywhere` holds it",
        "twin.no_such_package.module",
        'the pinned set (see README "No such section")',
        "scenarios/no_such_*.yaml",
    ],
)
def test_a_stale_citation_is_found(text):
    assert len(problems({"example.md": text})) == 1


@pytest.mark.parametrize(
    "text",
    [
        "`twin/core/poses.py`, scenarios/taps_rectangle.yaml and tests/test_public_api.py::test_public_names",
        "twin.core.poses.Pose and twin.sensing.perception.GPConfig (the noise floor).",
        "hardware.protocol.RequestDecoder; the `twin.backends` entry point",
        "runs/cal/calibration.yaml and out/bench are written by the commands",
        "scenarios/contour_*.yaml, the `test_dir` argument, tests/test_docs.py::test_what_exists_passes",
    ],
)
def test_what_exists_passes(text):
    assert problems({"example.md": text}) == []


def _readme_command_rows() -> dict[str, str]:
    """{command: its rows of the README's commands table}."""
    rows: dict[str, str] = {}
    for line in (ROOT / "README.md").read_text().splitlines():
        if m := re.match(r"\| `twin ([\w-]+)", line):
            rows[m.group(1)] = rows.get(m.group(1), "") + line
    return rows


def test_the_readme_lists_every_command_and_option():
    from twin.tools.cli import build_parser

    parser = build_parser()
    commands = next(a for a in parser._actions if a.dest == "command").choices
    rows = _readme_command_rows()
    assert set(rows) == set(commands), "the README's commands table against twin --help"
    missing = [
        f"twin {name} {option}"
        for name, sub in commands.items()
        for action in sub._actions
        for option in action.option_strings
        if option.startswith("--") and option != "--help" and option not in rows[name]
    ]
    missing += [  # a positional argument's choices: `twin bench [all|render|...]`
        f"twin {name} {choice}"
        for name, sub in commands.items()
        for action in sub._actions
        if not action.option_strings and action.choices
        for choice in action.choices
        if choice not in re.split(r"[\s\[\]|\\]+", re.match(r"\| `([^`]*)`", rows[name]).group(1))
    ]
    assert missing == [], "options and choices twin --help lists and the README's table does not"


def test_the_readme_reads_in_ten_minutes():
    assert len((ROOT / "README.md").read_text().splitlines()) <= 300, "the rest belongs on the docs site (docs/)"
