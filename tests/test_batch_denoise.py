"""Batch denoise measures what one run over the merged survey measures: the neighbour
distances in that run's float32 frame, so the same threshold up to the order of the
sums (test_batch_strays.py has the surveys with far points)."""

from __future__ import annotations

import math

import numpy as np
from test_batch_strays import assert_denoise_is_the_merged_run

import pcl_rg
from pcl_rg import batch
from pcl_rg.datasets import synthetic_survey
from pcl_rg.io import read_points


def test_denoise_threshold_is_the_merged_runs(tmp_path, scheduler):
    # Each tile's distances came from a float32 frame at the origin of its own cloud and
    # buffer: they differed from the merged run's in their last bits, and the threshold
    # by 1e-8 of itself here, which judged the points that close to it otherwise (2 of
    # 670,000 at 4 points per m^2). The sums of the tiles' distances add up in another
    # order than the merged run's: the threshold agrees to rounding of those sums.
    source = synthetic_survey(tmp_path / "in", tiles=(2, 2), tile_size=200.0, density=1.0, seed=8)
    params = pcl_rg.StatisticalOutlierRemovalParams(mean_k=10, std_mul=0.0)
    report = batch.denoise(source.paths, tmp_path / "out", params=params, scheduler=scheduler)
    merged = np.concatenate([read_points(p).points for p in source.paths])
    with pcl_rg.collect_diagnostics() as diagnostics:
        pcl_rg.statistical_outlier_removal(merged, params=params)
    expected = diagnostics["statistical_outlier_removal"]["threshold"]
    thresholds = {t.details["threshold"] for t in report.tiles}
    assert len(thresholds) == 1
    assert math.isclose(thresholds.pop(), expected, rel_tol=1e-13, abs_tol=0.0)
    assert_denoise_is_the_merged_run(source.paths, report, params)
