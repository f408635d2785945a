"""The README's examples run as written: its Python blocks in one namespace, and the
command lines of its "Command line" and "Processing a survey" blocks, each in a fresh
interpreter, on files made to the names they use. A user copies these first, so an
argument renamed or a file name that the commands do not chain is caught here."""

from __future__ import annotations

import re
import shlex
from pathlib import Path

import laspy
import numpy as np
from conftest import run_pcl_rg, shared_data

from pcl_rg import datasets
from pcl_rg.io import write_points

REPOSITORY = Path(__file__).resolve().parents[1]
README = (REPOSITORY / "README.md").read_text(encoding="utf-8")


def _blocks(language: str, after: str = "") -> list[str]:
    """The fenced blocks of `language`, from the heading `after` on (all if empty)."""
    start = README.index(after) if after else 0
    return re.findall(rf"^```{language}\n(.*?)^```$", README[start:], re.S | re.M)


def _command_lines(heading: str) -> list[list[str]]:
    """The `pcl-rg` lines of the first sh block below `heading`, comments dropped."""
    block = _blocks("sh", heading)[0]
    lines = [shlex.split(line, comments=True) for line in block.splitlines()]
    return [words[1:] for words in lines if words and words[0] == "pcl-rg"]


def test_the_python_examples_run(monkeypatch) -> None:
    code = "\n".join(_blocks("python"))
    for relative in re.findall(r"\"\.\./shared/data/([^\"]+)\"", code):
        shared_data(*relative.split("/"))  # a clear failure when the data is missing
    monkeypatch.chdir(REPOSITORY)  # where the examples' ../shared/data paths start
    namespace: dict = {}
    exec(compile(code, "README.md", "exec"), namespace)
    # The keys that the diagnostics example names in its comment are there.
    named = re.findall(r"'(\w+)': \.\.\.", code)
    assert named and set(named) <= set(namespace["diagnostics"]["tin_ground"])


def test_the_command_lines_run(tmp_path, scene_las) -> None:
    # The files the lines start from; the others are made by the lines before them.
    scene = laspy.read(scene_las)
    scene.write(tmp_path / "tile.laz")
    scene.write(tmp_path / "reference.laz")  # its classes are the truth
    frame = datasets.load_mosd(shared_data("mosd", "learn0.pcd")).points
    for name in ("scan.ply", "scene.pcd", "scan.pcd"):
        write_points(tmp_path / name, frame)
    lines = _command_lines("## Command line")
    assert [words[0] for words in lines][:3] == ["info", "denoise", "ground"]
    for words in lines:
        result = run_pcl_rg(*words, cwd=tmp_path)
        assert result.returncode == 0, f"pcl-rg {shlex.join(words)}:\n{result.stderr}"
    # The chain of the airborne lines wrote what it says: ground 2, other 1, noise 7.
    written = laspy.read(tmp_path / "ground.laz").classification
    assert set(np.unique(written)) <= {1, 2, 7} and np.any(written == 2)
    assert (tmp_path / "top.png").stat().st_size > 0


def test_the_survey_lines_run(tmp_path) -> None:
    datasets.synthetic_survey(tmp_path / "tiles", tiles=(2, 2), tile_size=60.0)
    lines = _command_lines("## Processing a survey")
    remote = [words for words in lines if "--scheduler" in words]
    # The line for a running cluster needs its head node (test_batch.py runs --scheduler
    # against a scheduler of its own); every other line runs here.
    assert len(remote) == 1 and len(lines) > 1
    for words in lines:
        if words in remote:
            continue
        result = run_pcl_rg(*words, cwd=tmp_path)
        assert result.returncode == 0, f"pcl-rg {shlex.join(words)}:\n{result.stderr}"
        out = Path(tmp_path, words[words.index("--out") + 1])
        assert sorted(p.name for p in out.glob("*.la[sz]")) == [
            p.name for p in sorted((tmp_path / "tiles").glob("*.laz"))
        ], shlex.join(words)
