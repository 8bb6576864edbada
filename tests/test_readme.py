"""The README's command examples run as written: after the set-up, `source .venv/bin/activate`
puts `moonbot` on PATH (the first line of "Using it" says so), and every `moonbot ...` line in
the README's code blocks names a real command and only options that command has."""

from __future__ import annotations

import re
import tomllib
from pathlib import Path

import click
import pytest

from moonbot.cli import main

pytestmark = pytest.mark.unit

ROOT = Path(__file__).resolve().parents[1]
README = (ROOT / "README.md").read_text()


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


def test_using_it_starts_by_putting_moonbot_on_path():
    section = README.split("## Using it", 1)[1]
    first = code_blocks(section)[0]
    assert first[0].split("#")[0].strip() == "source .venv/bin/activate"
    scripts = tomllib.loads((ROOT / "pyproject.toml").read_text())["project"]["scripts"]
    assert scripts["moonbot"] == "moonbot.cli:main"  # what pip installs as .venv/bin/moonbot


def test_every_moonbot_line_names_a_real_command_and_its_options():
    lines = [line.split("  #")[0] for block in code_blocks(README) for line in block if line.startswith("moonbot ")]
    assert len(lines) >= 10
    for line in lines:
        command, rest = resolve(line.split()[1:])
        assert not isinstance(command, click.Group), f"{line!r}: no such moonbot command"
        known = {name for p in command.params for name in (*p.opts, *p.secondary_opts)}
        for word in rest:
            option = re.match(r"\[?(--[a-z][a-z0-9-]*)", word.strip("'\""))
            if option:
                assert option.group(1) in known, f"{line!r}: {command.name} has no option {option.group(1)}"
