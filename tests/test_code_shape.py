"""Short functions and short files: no function or method in app/ is longer than 80 lines
(nested functions count on their own and inside their parent), so a step of a kind's run, a
route or a science routine stays readable on one screen; and no module in app/ is longer
than 600 lines (issue 42), so each can be read in one sitting and holds one concern."""

from __future__ import annotations

import ast
from pathlib import Path

ROOT = Path(__file__).resolve().parents[1]
LIMIT = 80
FILE_LIMIT = 600


def long_functions(root: Path, limit: int = LIMIT) -> list[tuple[int, str]]:
    out = []
    for f in sorted(root.rglob("*.py")):
        for node in ast.walk(ast.parse(f.read_text(), str(f))):
            if isinstance(node, (ast.FunctionDef, ast.AsyncFunctionDef)):
                n = node.end_lineno - node.lineno + 1
                if n > limit:
                    out.append((n, f"{f.relative_to(root.parent)}:{node.lineno} {node.name}"))
    return sorted(out, reverse=True)


def test_no_function_in_app_is_longer_than_the_limit():
    found = long_functions(ROOT / "app")
    assert not found, f"functions over {LIMIT} lines:\n" + "\n".join(f"{n} {where}" for n, where in found)


def test_the_check_finds_a_long_function(tmp_path):
    pkg = tmp_path / "app"
    pkg.mkdir()
    (pkg / "long.py").write_text("def f():\n" + "    x = 1\n" * LIMIT + "    return x\n")
    (pkg / "short.py").write_text("def g():\n    return 1\n")
    assert [w for _, w in long_functions(pkg)] == ["app/long.py:1 f"]


def long_files(root: Path, limit: int = FILE_LIMIT) -> list[tuple[int, str]]:
    out = []
    for f in sorted(root.rglob("*.py")):
        n = len(f.read_text().splitlines())
        if n > limit:
            out.append((n, str(f.relative_to(root.parent))))
    return sorted(out, reverse=True)


def test_no_file_in_app_is_longer_than_the_limit():
    found = long_files(ROOT / "app")
    assert not found, f"files over {FILE_LIMIT} lines (split them by concern):\n" + \
        "\n".join(f"{n} {where}" for n, where in found)


def test_the_check_finds_a_long_file(tmp_path):
    pkg = tmp_path / "app"
    (pkg / "sub").mkdir(parents=True)
    (pkg / "sub" / "long.py").write_text("x = 1\n" * (FILE_LIMIT + 1))
    (pkg / "short.py").write_text("x = 1\n" * FILE_LIMIT)
    assert long_files(pkg) == [(FILE_LIMIT + 1, "app/sub/long.py")]
