"""Which files a batch reads and writes, when links and damaged records are about: an
input under two names, outputs that are one file, and the record of finished tiles."""

from __future__ import annotations

import json
import os
from pathlib import Path

import numpy as np
import pytest

from pcl_rg import batch
from pcl_rg.batch._manifest import MANIFEST, Manifest
from pcl_rg.batch._plan import expand_inputs, output_paths
from pcl_rg.io import write_points


def tiles(folder, count: int = 2) -> list[str]:
    folder.mkdir()
    paths = []
    for i in range(count):
        paths.append(str(folder / f"tile_{i}.las"))
        write_points(paths[-1], np.random.default_rng(i).uniform(0, 10, (50, 3)) + [10 * i, 0, 0])
    return paths


def test_a_hard_link_to_an_input_counts_once(tmp_path):
    # Inputs were told apart by their resolved path: a hard link in the folder made
    # every point of its tile count twice (denoise took each point's copy for its
    # nearest neighbour).
    first, second = tiles(tmp_path / "in")
    os.link(first, tmp_path / "in" / "tile_0_copy.las")
    os.symlink(second, tmp_path / "in" / "tile_1_link.las")
    assert expand_inputs(tmp_path / "in") == [first, second]


def test_two_outputs_that_are_one_file_are_refused(tmp_path):
    # out/tile_1.las a link to out/tile_0.las: both tiles wrote to one file, and one
    # tile's points were written nowhere, with every tile reported done.
    paths = tiles(tmp_path / "in")
    (tmp_path / "out").mkdir()
    (tmp_path / "out" / "tile_1.las").symlink_to(tmp_path / "out" / "tile_0.las")
    with pytest.raises(ValueError, match="are one file"):
        output_paths(paths, tmp_path / "out")  # before tile_0.las exists
    (tmp_path / "out" / "tile_0.las").write_bytes(b"an earlier output")
    with pytest.raises(ValueError, match="are one file"):
        output_paths(paths, tmp_path / "out")


def test_a_link_in_place_of_the_record_is_refused_before_any_work(tmp_path):
    # The record was written through the link: the tile it led to was replaced by JSON.
    paths = tiles(tmp_path / "in")
    original = Path(paths[0]).read_bytes()
    (tmp_path / "out").mkdir()
    (tmp_path / "out" / MANIFEST).symlink_to(paths[0])
    with pytest.raises(ValueError, match="is not a file: the batch keeps its record"):
        batch.ground(paths, tmp_path / "out", workers=1, progress=False)
    assert Path(paths[0]).read_bytes() == original
    assert sorted(os.listdir(tmp_path / "out")) == [MANIFEST]


@pytest.mark.parametrize("text", ["[" * 100_000 + "]" * 100_000, '{"a": ', "[1, 2]"])
def test_a_damaged_record_redoes_every_tile(tmp_path, text):
    # JSON nested 100,000 deep raised RecursionError, which aborted the run.
    (tmp_path / MANIFEST).write_text(text)
    assert Manifest(str(tmp_path)).entries == {}
    Manifest(str(tmp_path)).clear()
    assert json.loads((tmp_path / MANIFEST).read_text()) == {}


@pytest.mark.parametrize(
    ("make", "refusal"),
    [
        # The tile failed at its write (no writer replaces a FIFO), and the batch then
        # removed the FIFO as "its earlier output".
        (os.mkfifo, "is not a regular file"),
        # The tile was read and classified, then failed at its write with "stale: Is a
        # directory", the folder taken for its earlier output.
        (os.mkdir, "is a folder, not a file"),
    ],
)
def test_a_fifo_or_folder_in_an_outputs_place_is_refused_and_kept(tmp_path, make, refusal):
    paths = tiles(tmp_path / "in")
    (tmp_path / "out").mkdir()
    make(tmp_path / "out" / "tile_0.las")
    with pytest.raises(ValueError, match=refusal):
        output_paths(paths, tmp_path / "out")
    with pytest.raises(ValueError, match=refusal):
        batch.ground(paths, tmp_path / "out", workers=1, progress=False)
    assert (tmp_path / "out" / "tile_0.las").exists()


def test_xyz_text_with_a_byte_order_mark_is_a_tile(tmp_path):
    # read_points reads it; the folder's look at .txt files took the mark for a word.
    (tmp_path / "in").mkdir()
    rows = "".join(f"{i} {i % 7} 1.5\n" for i in range(20))
    (tmp_path / "in" / "a.txt").write_bytes(b"\xef\xbb\xbf" + rows.encode())
    (tmp_path / "in" / "b.txt").write_bytes(b"\xef\xbb\xbf# x y z\n" + rows.encode())
    assert [os.path.basename(p) for p in expand_inputs(tmp_path / "in")] == ["a.txt", "b.txt"]
