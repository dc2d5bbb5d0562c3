"""The serial set of conftest.py names tests that exist: a renamed or removed test would otherwise
leave its successor on a parallel worker unnoticed, beside another test's load."""
from __future__ import annotations

import ast
from pathlib import Path

from conftest import SERIAL_FILES, SERIAL_TESTS

HERE = Path(__file__).resolve().parent


def _tests_in(name: str) -> set[str]:
    tree = ast.parse((HERE / name).read_text())
    return {n.name for n in ast.walk(tree) if isinstance(n, ast.FunctionDef) and n.name.startswith("test_")}


def test_every_serial_file_and_test_exists():
    for name in SERIAL_FILES:
        assert _tests_in(name), f"{name}: no tests (conftest.py SERIAL_FILES)"
    for name, tests in SERIAL_TESTS.items():
        missing = tests - _tests_in(name)
        assert not missing, f"{name}: {sorted(missing)} not defined (conftest.py SERIAL_TESTS)"
