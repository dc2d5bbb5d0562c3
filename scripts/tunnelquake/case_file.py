"""Reading a case file with every problem said: what makes the file unreadable before its keys are
looked at (screen_case_file), then the case's validation (case.load_case), printed (load_or_report)."""
from __future__ import annotations

import sys
from pathlib import Path

from .case import Case, CaseError, load_case


def case_path(p: Path) -> Path:
    return p / "case.yaml" if p.is_dir() else p


#: The most YAML nodes a case file may stand for once its aliases are expanded (the example has
#: about 400; "billion laughs" files nest aliases to stand for billions).
MAX_EXPANDED_NODES = 100_000


def _expanded_nodes(node, memo: dict, visiting: set) -> int:
    """How many nodes `node` stands for with every alias expanded (an alias counts its whole
    target each time); a node that contains itself counts as too many."""
    key = id(node)
    if key in memo:
        return memo[key]
    if key in visiting:
        return MAX_EXPANDED_NODES + 1
    visiting.add(key)
    n = 1
    if isinstance(node.value, list):
        for item in node.value:
            for sub in (item if isinstance(item, tuple) else (item,)):
                n += _expanded_nodes(sub, memo, visiting)
                if n > MAX_EXPANDED_NODES:
                    break
    visiting.discard(key)
    memo[key] = n
    return n


def screen_case_file(path: Path) -> str | None:
    """What makes a case file unreadable before its keys are looked at: a folder under the case
    file's name, bytes that are not UTF-8, aliases that expand beyond MAX_EXPANDED_NODES. Returns
    the problem with its fix, or None."""
    import yaml

    if path.is_dir():
        return f"{path} is a folder, not a case file. Fix: give the case file itself, or the folder holding it"
    try:
        raw = path.read_bytes()
    except FileNotFoundError:
        return None  # said by load_case, with its fix
    except OSError as e:
        return f"{path} cannot be read ({e.strerror}). Fix: check its permissions"
    try:
        text = raw.decode("utf-8")
    except UnicodeDecodeError as e:
        line = raw.count(b"\n", 0, e.start) + 1
        column = e.start - (raw.rfind(b"\n", 0, e.start) + 1) + 1
        return (f"{path}: line {line}, column {column}: byte 0x{raw[e.start]:02x} is not UTF-8 text. Fix: save the "
                "case file as UTF-8")
    if "*" not in text:
        return None  # no alias: nothing can expand
    try:
        root = yaml.compose(text, Loader=yaml.SafeLoader)
    except yaml.YAMLError:
        return None  # a syntax error: said by load_case with its line
    if root is not None and _expanded_nodes(root, {}, set()) > MAX_EXPANDED_NODES:
        return (f"{path}: its YAML aliases (*name) expand to more than {MAX_EXPANDED_NODES:,} values, or refer to "
                "themselves. Fix: write the values out instead of nesting aliases")
    return None


def load_or_report(path: Path, variant: str | None = None) -> Case | None:
    """Load and validate a case (with `variant` laid over it, if given); on problems print them
    all (stderr) and return None."""
    path = Path(path)
    if path.is_dir() and path.suffix in (".yaml", ".yml") and not (path / "case.yaml").exists():
        problem = f"{path} is a folder, not a case file. Fix: give the case file itself, or the folder holding it"
    else:
        problem = screen_case_file(case_path(path))
    if problem is not None:
        print(f"error: {problem}", file=sys.stderr)
        return None
    try:
        case = load_case(case_path(path), variant)
    except CaseError as e:
        print(f"error: {e}", file=sys.stderr)
        return None
    for w in case.warnings:
        print(f"warning: {w}", file=sys.stderr)
    return case
