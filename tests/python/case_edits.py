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
