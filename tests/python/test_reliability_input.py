"""Case files that cannot be read as YAML text: `check` (and every subcommand, through the same
loader) names the file, the problem and the fix, exits 1, and raises no traceback."""
from __future__ import annotations

import time

from tunnelquake.cli import main


def test_folder_named_case_yaml_is_said_to_be_a_folder(tmp_path, capsys):
    (tmp_path / "case.yaml").mkdir()
    for given in (tmp_path, tmp_path / "case.yaml"):
        assert main(["check", str(given)]) == 1
        err = capsys.readouterr().err
        assert (f"error: {tmp_path / 'case.yaml'} is a folder, not a case file. Fix: give the case file itself, "
                "or the folder holding it") in err


def test_non_utf8_case_file_names_the_line_column_and_byte(tmp_path, capsys):
    p = tmp_path / "case.yaml"
    p.write_bytes(b"name: tunnel\ndescription: caf\xe9 au lait\n")
    assert main(["check", str(p)]) == 1
    err = capsys.readouterr().err
    assert f"error: {p}: line 2, column 17: byte 0xe9 is not UTF-8 text. Fix: save the case file as UTF-8" in err


def test_yaml_alias_bomb_is_refused_at_once(tmp_path, capsys):
    """Nine levels of nine aliases stand for 9^9 (387 million) strings; refused before any
    expansion, in well under a second."""
    lines = ['a0: &a0 ["x","x","x","x","x","x","x","x","x"]']
    lines += [f"a{k}: &a{k} [{','.join([f'*a{k - 1}'] * 9)}]" for k in range(1, 9)]
    p = tmp_path / "case.yaml"
    p.write_text("\n".join(lines) + "\n")
    t0 = time.monotonic()
    assert main(["check", str(p)]) == 1
    assert time.monotonic() - t0 < 5.0
    err = capsys.readouterr().err
    assert (f"error: {p}: its YAML aliases (*name) expand to more than 100,000 values, or refer to themselves. "
            "Fix: write the values out instead of nesting aliases") in err


def test_self_referring_yaml_alias_is_refused(tmp_path, capsys):
    p = tmp_path / "case.yaml"
    p.write_text("loop: &loop [1, *loop]\n")
    assert main(["check", str(p)]) == 1
    assert "expand to more than 100,000 values, or refer to themselves" in capsys.readouterr().err


def _example_with(tmp_path, old: str, new: str):
    """The example case copied into tmp_path with one line changed (its record path made absolute,
    so that it resolves as in the example)."""
    from pathlib import Path

    root = Path(__file__).resolve().parents[2]
    text = (root / "cases" / "paper_tunnel" / "case.yaml").read_text()
    text = text.replace("file: ../../../shared", f"file: {root.parent / 'shared'}")
    assert old in text
    p = tmp_path / "case.yaml"
    p.write_text(text.replace(old, new, 1))
    return p


def test_output_directory_outside_the_case_folder_is_refused_unless_allowed(tmp_path, capsys):
    p = _example_with(tmp_path, "directory: results", "directory: ../../elsewhere")
    assert main(["check", str(p)]) == 1
    err = capsys.readouterr().err
    outside = (tmp_path / "../../elsewhere").resolve()
    assert f"output.directory = '../../elsewhere': resolves to {outside}, outside the case file's folder {tmp_path}" in err
    assert "set output.allow_outside: true to write there on purpose" in err
    p = _example_with(tmp_path, "directory: results", "directory: /tmp/elsewhere\n  allow_outside: true")
    assert main(["check", str(p)]) == 0
    p = _example_with(tmp_path, "directory: results", "directory: sub/results")
    assert main(["check", str(p)]) == 0


def test_error_on_a_non_record_file_does_not_echo_its_lines(tmp_path, capsys):
    """A ground_motion.file that is not a record (here a file holding a secret) is refused with its
    line and field, never with the text of that line."""
    secret = tmp_path / "secret.txt"
    secret.write_text("password hunter2hash\n" * 6)
    for fmt in ("at2", "two_column"):
        p = _example_with(tmp_path, "source: file\n", f"source: file\n  format: {fmt}\n  units: g\n")
        text = p.read_text()
        import re

        p.write_text(re.sub(r"file: .*\.AT2", f"file: {secret}", text))
        assert main(["check", str(p)]) == 1
        err = capsys.readouterr().err
        assert f"{secret}:" in err and "is this" in err, err
        assert "hunter2" not in err and "password" not in err, err
