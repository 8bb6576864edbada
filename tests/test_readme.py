"""The README and docs/ hold up: after the set-up, `source .venv/bin/activate` puts `moonbot` on PATH
(the first line of the README's "Using it" says so); every `moonbot ...` line in their code blocks
names a real command and only options that command has; the README's command table lists every
command; docs/cli.md is what docs/make_cli_md.py writes today; every relative link (and its
#anchor) resolves; and the README stays short enough to read."""

from __future__ import annotations

import importlib.util
import re
import subprocess
import tomllib
from pathlib import Path

import click
import pytest

from moonbot.cli import main

pytestmark = pytest.mark.unit

ROOT = Path(__file__).resolve().parents[1]
README_PATH = ROOT / "README.md"
README = README_PATH.read_text(encoding="utf-8")
DOCS = sorted((ROOT / "docs").glob("*.md"))
# Every page a newcomer is sent to from the README, whose links must resolve.
LINKED_PAGES = [
    README_PATH,
    *DOCS,
    *(ROOT / folder / "README.md" for folder in ("bench", "bench/results", "bench/peers", "cluster")),
]
README_MAX_LINES = 200


def code_blocks(text: str) -> list[list[str]]:
    """The lines of each ``` block, continuation lines (indented, after a command) joined to it."""
    blocks = []
    for body in re.findall(r"^```[a-z]*\n(.*?)^```", text, re.M | re.S):
        lines: list[str] = []
        for line in body.splitlines():
            if line.startswith((" ", "\t")) and lines:
                lines[-1] += " " + line.strip()
            else:
                lines.append(line)
        blocks.append(lines)
    return blocks


def resolve(words: list[str]) -> tuple[click.Command, list[str]]:
    """The (sub)command a `moonbot` line calls, and the words after its name."""
    command: click.Command = main
    while isinstance(command, click.Group) and words and words[0] in command.commands:
        command, words = command.commands[words[0]], words[1:]
    return command, words


def leaf_command_names(group: click.Group = main, prefix: str = "moonbot") -> set[str]:
    """'moonbot render-one', 'moonbot terrain import', ...: every runnable command."""
    names = set()
    for name, command in group.commands.items():
        if isinstance(command, click.Group):
            names |= leaf_command_names(command, f"{prefix} {name}")
        else:
            names.add(f"{prefix} {name}")
    return names


def github_anchor(heading: str) -> str:
    """The #anchor GitHub gives a markdown heading: lower case, punctuation dropped, spaces → '-'."""
    text = re.sub(r"[^\w\- ]", "", heading.strip().lower())
    return text.replace(" ", "-")


def anchors(page: Path) -> set[str]:
    """Every heading anchor of a markdown page (GitHub numbers repeated headings -1, -2, ...)."""
    text = re.sub(r"^```.*?^```", "", page.read_text(encoding="utf-8"), flags=re.M | re.S)
    found: set[str] = set()
    for heading in re.findall(r"^#{1,6} (.+)$", text, re.M):
        anchor = base = github_anchor(heading)
        repeat = 0
        while anchor in found:
            repeat += 1
            anchor = f"{base}-{repeat}"
        found.add(anchor)
    return found


def relative_links(page: Path) -> list[tuple[int, str]]:
    """(line, target) of every markdown link and image on `page` that is not a URL; code is skipped."""
    text = page.read_text(encoding="utf-8")
    # Blank out code (fenced and inline) but keep its newlines, so line numbers stay true.
    text = re.sub(r"^```.*?^```", lambda m: re.sub(r"[^\n]", " ", m.group(0)), text, flags=re.M | re.S)
    text = re.sub(r"`[^`\n]*`", lambda m: " " * len(m.group(0)), text)
    links = []
    for match in re.finditer(r"!?\[[^\]]*\]\(([^)\s]+)\)", text):
        target = match.group(1)
        if not re.match(r"[a-z][a-z0-9+.-]*:", target):  # http:, https:, mailto: ...
            links.append((text.count("\n", 0, match.start()) + 1, target))
    return links


def test_using_it_starts_by_putting_moonbot_on_path():
    section = README.split("## Using it", 1)[1]
    first = code_blocks(section)[0]
    assert first[0].split("#")[0].strip() == "source .venv/bin/activate"
    scripts = tomllib.loads((ROOT / "pyproject.toml").read_text())["project"]["scripts"]
    assert scripts["moonbot"] == "moonbot.cli:main"  # what pip installs as .venv/bin/moonbot


def test_every_moonbot_line_names_a_real_command_and_its_options():
    pages = [README_PATH, *DOCS]
    lines = [
        (page.name, line.split("  #")[0])
        for page in pages
        for block in code_blocks(page.read_text(encoding="utf-8"))
        for line in block
        if line.startswith("moonbot ")
    ]
    assert len([line for name, line in lines if name == "README.md"]) >= 10
    for name, line in lines:
        command, rest = resolve(line.split()[1:])
        assert not isinstance(command, click.Group), f"{name}: {line!r}: no such moonbot command"
        known = {option for p in command.params for option in (*p.opts, *p.secondary_opts)}
        for word in rest:
            option = re.match(r"\[?(--[a-z][a-z0-9-]*)", word.strip("'\""))
            if option:
                assert option.group(1) in known, f"{name}: {line!r}: {command.name} has no option {option.group(1)}"


def test_readme_command_table_lists_every_command():
    table = set(re.findall(r"^\| `(moonbot [a-z -]+)` \|", README, re.M))
    assert table == leaf_command_names(), (
        f"missing from the README's table: {sorted(leaf_command_names() - table)}; "
        f"not commands: {sorted(table - leaf_command_names())}"
    )


def test_cli_md_is_what_make_cli_md_writes():
    spec = importlib.util.spec_from_file_location("make_cli_md", ROOT / "docs" / "make_cli_md.py")
    make_cli_md = importlib.util.module_from_spec(spec)
    spec.loader.exec_module(make_cli_md)
    assert (ROOT / "docs" / "cli.md").read_text(encoding="utf-8") == make_cli_md.render_cli_md(), (
        "docs/cli.md is stale: run `.venv/bin/python docs/make_cli_md.py`"
    )
    documented = set(re.findall(r"^## (moonbot [a-z -]+)$", make_cli_md.render_cli_md(), re.M))
    assert documented == leaf_command_names()


def test_every_relative_link_resolves():
    broken = []
    for page in LINKED_PAGES:
        for line, target in relative_links(page):
            path_part, _, anchor = target.partition("#")
            linked = (page.parent / path_part).resolve() if path_part else page
            if not linked.exists():
                broken.append(f"{page.relative_to(ROOT)}:{line}: {target} (no such file)")
            elif anchor and linked.suffix == ".md" and anchor not in anchors(linked):
                broken.append(f"{page.relative_to(ROOT)}:{line}: {target} (no heading #{anchor})")
    assert not broken, "\n".join(broken)


def test_link_checker_sees_links_and_their_anchors(tmp_path):
    page = tmp_path / "page.md"
    page.write_text(
        "# A title\n\n## Units and frames (SI)\n\nSee [x](other.md#y), ![img](pic.png) and\n"
        "[same page](#units-and-frames-si), not `[code](nowhere.md)` nor [web](https://e.org).\n"
        "```\n[in a block](gone.md)\n```\n",
        encoding="utf-8",
    )
    assert relative_links(page) == [(5, "other.md#y"), (5, "pic.png"), (6, "#units-and-frames-si")]
    assert anchors(page) == {"a-title", "units-and-frames-si"}


def test_readme_is_short():
    assert len(README.splitlines()) <= README_MAX_LINES


def test_no_internal_references_in_readme_or_docs():
    for page in LINKED_PAGES:
        text = page.read_text(encoding="utf-8")
        for pattern in (r"\.\./shared", r"/work/shared", r"\bissue \d", r"\bprinciple \d"):
            assert not re.search(pattern, text, re.I), f"{page.relative_to(ROOT)} mentions {pattern}"


# The design notes the code was first written against are not part of the project: the code and
# its comments cite docs/ and the literature instead (bench/results/ keeps dated records as run).
INTERNAL_NOTES = (
    r"\.\./shared",
    r"/work/shared",
    r"\b[Ii]ssue \d",
    r"\b[Pp]rinciple \d",
    r"lunar-physics\.md",
    r"regolith-scales\.md",
    r"lighting-options\.md",
    r"bop-format\.md",
    r"dask-distribution\.md",
    r"performance-limits\.md",
    r"\bDESIGN\.md",
)


def test_no_internal_references_in_code():
    tracked = subprocess.run(["git", "ls-files"], cwd=ROOT, capture_output=True, text=True, check=True).stdout
    offenders = []
    for name in tracked.splitlines():
        path = ROOT / name
        if name.startswith("bench/results/") or name == "tests/test_readme.py" or not path.is_file():
            continue
        if path.suffix not in {".py", ".pyi", ".h", ".cpp", ".sh", ".yaml", ".yml", ".toml", ".txt", ".md", ""}:
            continue
        text = path.read_text(encoding="utf-8", errors="replace")
        for pattern in INTERNAL_NOTES:
            for match in re.finditer(pattern, text):
                offenders.append(f"{name}:{text.count(chr(10), 0, match.start()) + 1}: {match.group(0)}")
    assert not offenders, "references to notes outside the project:\n" + "\n".join(offenders)
