"""Helpers of the command-line tests (test_cli*.py): run pcl_rg.cli.main in-process
and read its output."""

from __future__ import annotations

import json
import os
import re
from pathlib import Path

import pcl_rg.cli as cli


def run(capsys, *argv: object) -> tuple[int, str, str]:
    code = cli.main([os.fspath(a) if isinstance(a, Path) else str(a) for a in argv])
    captured = capsys.readouterr()
    return code, captured.out, captured.err


def run_json(capsys, *argv: object) -> dict:
    code, out, err = run(capsys, *argv, "--json", "-q")
    assert code == 0, err
    assert err == ""
    return json.loads(out)


# The lines of a stage that ran past the spinner's delay (a loaded machine): not errors.
SPINNER_LINE = re.compile(
    r"pcl-rg: .*( \.\.\.|: (done in|failed after|interrupted after) [\d.]+ s)"
)


def assert_one_error_line(err: str, *fragments: str) -> None:
    lines = [line for line in err.splitlines() if not SPINNER_LINE.fullmatch(line)]
    assert len(lines) == 1, err
    assert lines[0].startswith("pcl-rg: error: "), err
    assert "Traceback" not in err
    for fragment in fragments:
        assert fragment in lines[0], lines[0]
