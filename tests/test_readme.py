"""The README's Python examples run, and import nothing they do not use."""
from __future__ import annotations

import ast
import re
from pathlib import Path

import pytest

README = Path(__file__).resolve().parents[1] / "README.md"


def python_blocks() -> list[str]:
    text = README.read_text(encoding="utf-8")
    return re.findall(r"^```python\n(.*?)^```", text, flags=re.S | re.M)


def test_readme_has_python_examples():
    assert python_blocks(), "README.md has no ```python block"


@pytest.mark.parametrize("i", range(len(python_blocks())))
def test_readme_block_imports_only_what_it_uses(i):
    tree = ast.parse(python_blocks()[i])
    imported = set()
    for node in ast.walk(tree):
        if isinstance(node, (ast.Import, ast.ImportFrom)):
            for a in node.names:
                imported.add((a.asname or a.name).split(".")[0])
    used = {n.id for n in ast.walk(tree) if isinstance(n, ast.Name)}
    assert imported <= used, f"unused imports in README block {i}: {sorted(imported - used)}"


@pytest.mark.parametrize("i", range(len(python_blocks())))
def test_readme_block_runs(i, tmp_path, monkeypatch, capsys):
    monkeypatch.chdir(tmp_path)          # files the example writes land here
    exec(compile(python_blocks()[i], f"README.md block {i}", "exec"), {"__name__": "__readme__"})
    assert capsys.readouterr().out       # every example prints something


def test_readme_commands_exist():
    """Every `pfrepro <command>` the README shows is a command of the parser."""
    from pfrepro.cli import COMMANDS

    shown = set(re.findall(r"^pfrepro (\w+)", README.read_text(encoding="utf-8"), flags=re.M))
    assert shown and shown <= set(COMMANDS)
