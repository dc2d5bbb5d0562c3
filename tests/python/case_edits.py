"""A test's case text with edits, and `tunnelquake check` run on it (shared by the check tests)."""
from __future__ import annotations

from tunnelquake.cli import main


def edited(text: str, *edits: str) -> str:
    """`text` with each (old, new) pair of `edits` replaced once; each old must be in the text."""
    for old, new in zip(edits[::2], edits[1::2], strict=True):
        assert old in text, old
        text = text.replace(old, new, 1)
    return text


def check_edited(tmp_path, capsys, text: str, *edits: str) -> tuple[int, str, str]:
    """`tunnelquake check` on the edited text written as tmp_path/case.yaml: (exit code, stdout,
    stderr); a traceback fails the test."""
    p = tmp_path / "case.yaml"
    p.write_text(edited(text, *edits))
    rc = main(["check", str(p)])
    out = capsys.readouterr()
    assert "Traceback" not in out.out + out.err
    return rc, out.out, out.err


def with_time(text: str, **keys: str) -> str:
    """`text` with `keys` (e.g. end_time="0.02 s") set in its block `time:` section: each added as the
    section's first key, or replacing the section's own line of that key; without a `time:` section,
    a new one at the end."""
    lines = text.splitlines()
    try:
        at = next(i for i, ln in enumerate(lines) if ln.rstrip() == "time:")
    except StopIteration:
        return text.rstrip("\n") + "\ntime:\n" + "".join(f"  {k}: {v}\n" for k, v in keys.items())
    end = next((i for i in range(at + 1, len(lines)) if lines[i] and not lines[i].startswith((" ", "#"))), len(lines))
    section = [ln for ln in lines[at + 1:end] if not any(ln.startswith(f"  {k}:") for k in keys)]
    lines[at + 1:end] = [f"  {k}: {v}" for k, v in keys.items()] + section
    return "\n".join(lines) + "\n"
