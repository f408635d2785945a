"""``--keep-classes`` / ``keep_classes=True``: the ground filter's non-ground points
keep a vendor's classes (buildings, vegetation, water) instead of becoming 1."""

from __future__ import annotations

import json

import laspy
import numpy as np
from conftest import run_pcl_rg
from test_batch import outputs_of
from units_files import write_las

from pcl_rg import batch
from pcl_rg.datasets import synthetic_scene, synthetic_survey
from pcl_rg.io import read_points

VENDOR = np.array([0, 1, 2, 3, 5, 6, 7, 9], np.uint8)  # 7: noise, left out of the work


def classify_randomly(path, seed):
    las = laspy.read(path)
    las.classification = np.random.default_rng(seed).choice(VENDOR, len(las.points))
    las.write(path)


def check_kept(before, plain, kept):
    """`kept` is `plain` where ground; elsewhere the vendor's class, 0/1/2 made 1."""
    ground = plain == 2
    np.testing.assert_array_equal(kept[ground], 2)
    other = ~ground & (before != 7)
    expected = np.where(np.isin(before[other], (0, 1, 2)), 1, before[other])
    np.testing.assert_array_equal(kept[other], expected)
    np.testing.assert_array_equal(kept[before == 7], 7)
    assert (plain[other] == 1).all() and (expected != 1).any()  # the option changes it


def test_the_command_keeps_the_vendors_classes(tmp_path):
    points = synthetic_scene(seed=4, size=100.0, density=2).points
    write_las(tmp_path / "in.las", points)
    classify_randomly(tmp_path / "in.las", 0)
    before = read_points(tmp_path / "in.las").classification
    assert run_pcl_rg("ground", tmp_path / "in.las", tmp_path / "plain.las").returncode == 0
    result = run_pcl_rg(
        "ground", tmp_path / "in.las", tmp_path / "kept.las", "--keep-classes", "--json"
    )
    assert result.returncode == 0, result.stderr
    assert json.loads(result.stdout)["keep_classes"] is True
    plain = read_points(tmp_path / "plain.las").classification
    check_kept(before, plain, read_points(tmp_path / "kept.las").classification)


def test_batch_keeps_the_vendors_classes_and_a_rerun_redoes_the_tiles(tmp_path, scheduler):
    source = synthetic_survey(tmp_path / "in", tiles=(1, 2), tile_size=60.0, seed=8)
    for k, path in enumerate(source.paths):
        classify_randomly(path, k)
    before = np.concatenate([read_points(p).classification for p in source.paths])
    out = tmp_path / "out"
    plain = batch.ground(source.paths, out, scheduler=scheduler)
    plain_classes = np.concatenate([c.classification for c in outputs_of(plain)])
    kept = batch.ground(source.paths, out, keep_classes=True, scheduler=scheduler)
    assert [t.status for t in kept.tiles] == ["done", "done"]  # not "up to date"
    check_kept(before, plain_classes, np.concatenate([c.classification for c in outputs_of(kept)]))
