"""pcl_rg.batch and ``pcl-rg batch``: seamless tiles, faults, resuming, the engine.

Most tests share one local Dask cluster (two one-thread worker processes) through
`scheduler=`; the engine's own local cluster, a cluster of `dask scheduler` and
`dask worker` processes and a worker killed mid-run get tests of their own (Ctrl-C:
test_batch_interrupts.py).
"""

from __future__ import annotations

import contextlib
import inspect
import json
import os
import signal
import subprocess
import sys
import threading
import time
from pathlib import Path

import numpy as np
import pytest
from conftest import ISPRS_SAMPLES, run_pcl_rg, shared_data

import pcl_rg
from pcl_rg import batch
from pcl_rg.batch import _engine
from pcl_rg.batch._manifest import MANIFEST
from pcl_rg.datasets import load_isprs, synthetic_survey
from pcl_rg.io import read_points, write_points

PYTHON = sys.executable


def merged(paths):
    """The merged cloud of `paths`, in input order: what a single-process run sees."""
    return [read_points(p) for p in paths]


def outputs_of(report):
    return [read_points(t.output) for t in report.tiles]


def agreement(report, expected_classes):
    got = np.concatenate([c.classification for c in outputs_of(report)])
    return float((got == expected_classes).mean())


def ground_of_merged(paths, method, params=None):
    """What ``pcl-rg ground`` writes for the merged cloud: noise (7, 18) left as it was.

    With the lengths that batch.ground gives every tile (those of the survey's spacing)
    when `params` leaves them unset."""
    kind = pcl_rg.GridGroundParams if method == "grid" else pcl_rg.TinGroundParams
    params = (params or kind()).at_spacing(batch.survey_spacing(paths))
    clouds = merged(paths)
    points = np.concatenate([c.points for c in clouds])
    classes = np.concatenate([c.classification for c in clouds])
    work = np.isfinite(points).all(axis=1) & ~np.isin(classes, (7, 18))
    function = pcl_rg.grid_ground if method == "grid" else pcl_rg.tin_ground
    result = classes.copy()
    result[work] = np.where(function(points[work], params=params), 2, 1)
    return result


def quadrants(folder, sample, fmt="las"):
    """An ISPRS sample cut into four tiles at its middle (half-open), written as files."""
    points, _ = load_isprs(
        shared_data("isprs", f"{sample}-utm.pcd"), shared_data("isprs", f"{sample}-utm-ground.pcd")
    )
    mid = (points[:, :2].min(axis=0) + points[:, :2].max(axis=0)) / 2
    paths = []
    for east in (False, True):
        for north in (False, True):
            inside = ((points[:, 0] >= mid[0]) == east) & ((points[:, 1] >= mid[1]) == north)
            path = os.path.join(folder, f"{sample}_{int(north)}{int(east)}.{fmt}")
            write_points(path, points[inside], classification=np.ones(inside.sum(), np.uint8))
            paths.append(path)
    return paths


# ---------------------------------------------------------------- seamless results


@pytest.mark.parametrize("operation", [batch.ground, batch.denoise, batch.downsample])
def test_operations_declare_the_engine_keywords_as_the_engine_does(operation):
    # The three public operations spell the engine's keywords out for their users;
    # the engine (_run) is the one declaration they must match.
    engine = inspect.signature(batch._run).parameters
    public = inspect.signature(operation).parameters
    for name in batch._ENGINE_OPTIONS:
        assert name in public, name
        assert public[name].kind is inspect.Parameter.KEYWORD_ONLY, name
        assert public[name].annotation == engine[name].annotation, name
        assert public[name].default == inspect.signature(batch.ground).parameters[name].default
    assert [n for n in public if n in engine and n not in ("params", "method")] == [
        n for n in engine if n in public and n not in ("params", "method")
    ]


@pytest.mark.parametrize(("method", "target"), [("grid", 0.999), ("tin", 0.995)])
def test_ground_on_a_survey_matches_the_merged_run(survey, tmp_path, scheduler, method, target):
    report = batch.ground(survey.paths, tmp_path, method=method, scheduler=scheduler)
    assert [t.status for t in report.tiles] == ["done"] * len(survey.paths)
    assert agreement(report, ground_of_merged(survey.paths, method)) >= target


@pytest.mark.parametrize("sample", ISPRS_SAMPLES)
def test_ground_on_isprs_quadrants_matches_the_merged_run(sample, tmp_path, scheduler):
    paths = quadrants(tmp_path, sample)
    for method, target in (("grid", 0.999), ("tin", 0.995)):
        report = batch.ground(paths, tmp_path / method, method=method, scheduler=scheduler)
        assert not report.failed
        assert agreement(report, ground_of_merged(paths, method)) >= target, method


def test_a_buffer_of_zero_leaves_seams(survey, tmp_path, scheduler):
    # The buffer is what makes tiles agree: without it the grid filter disagrees more.
    expected = ground_of_merged(survey.paths, "grid")
    none = batch.ground(survey.paths, tmp_path / "0", buffer=0.0, scheduler=scheduler)
    full = batch.ground(survey.paths, tmp_path / "d", scheduler=scheduler)
    assert agreement(none, expected) < agreement(full, expected)


@pytest.mark.parametrize("sample", ["samp11", "samp52"])
def test_denoise_is_identical_to_the_merged_run(sample, tmp_path, scheduler):
    paths = quadrants(tmp_path, sample)
    params = pcl_rg.StatisticalOutlierRemovalParams(mean_k=12, std_mul=1.0)
    report = batch.denoise(paths, tmp_path / "out", params=params, scheduler=scheduler)
    points = np.concatenate([c.points for c in merged(paths)])
    expected = ~pcl_rg.statistical_outlier_removal(points, params=params)
    got = np.concatenate([c.classification for c in outputs_of(report)]) == 7
    assert expected.any() and np.array_equal(got, expected)


def test_a_buffer_far_beyond_the_survey_is_the_merged_run(small_survey, tmp_path, scheduler):
    # A buffer of 1e20 m overflowed int64 in the neighbour index, which then read only
    # its first column of cells: 18 labels differed from the merged run.
    params = pcl_rg.StatisticalOutlierRemovalParams(mean_k=12, std_mul=1.0)
    report = batch.denoise(
        small_survey.paths, tmp_path, params=params, buffer=1e20, scheduler=scheduler
    )
    points = np.concatenate([c.points for c in merged(small_survey.paths)])
    expected = ~pcl_rg.statistical_outlier_removal(points, params=params)
    got = np.concatenate([c.classification for c in outputs_of(report)]) == 7
    assert expected.any() and np.array_equal(got, expected)


def test_denoise_grows_a_buffer_that_is_too_small(small_survey, tmp_path, scheduler):
    params = pcl_rg.StatisticalOutlierRemovalParams(mean_k=30)
    report = batch.denoise(
        small_survey.paths, tmp_path, params=params, buffer=0.5, scheduler=scheduler
    )
    assert max(t.details["buffer_used"] for t in report.tiles) > 0.5
    points = np.concatenate([c.points for c in merged(small_survey.paths)])
    expected = ~pcl_rg.statistical_outlier_removal(points, params=params)
    got = np.concatenate([c.classification for c in outputs_of(report)]) == 7
    assert np.array_equal(got, expected)


def voxel_rows(clouds):
    """Centroids with their attributes as sorted rows, to compare sets of voxels."""
    rows = np.concatenate(
        [np.column_stack([c.points, c.fields["intensity"], c.classification]) for c in clouds]
    )
    return rows[np.lexsort(rows.T[::-1])]


@pytest.mark.parametrize("leaf", [1.0, 2.5])
def test_downsample_writes_the_voxels_of_the_merged_run_once(leaf, tmp_path, scheduler):
    source = synthetic_survey(tmp_path / "in", tiles=(3, 3), tile_size=40.0, seed=2, format="ply")
    params = pcl_rg.VoxelGridParams(leaf_size=leaf)
    report = batch.downsample(source.paths, tmp_path / "out", params=params, scheduler=scheduler)
    clouds = merged(source.paths)
    points = np.concatenate([c.points for c in clouds])
    grid = pcl_rg.voxel_grid(points, params=params)
    from pcl_rg._classification import voxel_attributes

    fields = {n: np.concatenate([c.fields[n] for c in clouds]) for n in clouds[0].fields}
    rows = np.arange(len(points))
    attributes = voxel_attributes(fields, rows, grid.voxel_of_point, grid.counts)
    expected = np.column_stack(
        [grid.centroids, attributes["intensity"], attributes["classification"]]
    )
    got = voxel_rows(outputs_of(report))
    assert got.shape == expected.shape
    np.testing.assert_allclose(got, expected[np.lexsort(expected.T[::-1])], rtol=0, atol=1e-9)


# ---------------------------------------------------------------- runs and faults


def test_rerun_skips_what_is_up_to_date_and_redoes_what_changed(
    survey, tmp_path, scheduler, monkeypatch
):
    import shutil

    inputs = tmp_path / "in"
    shutil.copytree(os.path.dirname(survey.paths[0]), inputs)
    out = tmp_path / "out"
    first = batch.ground(inputs, out, scheduler=scheduler)
    assert {t.status for t in first.tiles} == {"done"}
    again = batch.ground(inputs, out, scheduler=scheduler)
    assert {t.status for t in again.tiles} == {"skipped"}
    # A changed input redoes its tile and every tile it gave a buffer to.
    changed = again.tiles[0].input  # a corner: its buffer reaches 9 of the 25 tiles
    cloud = read_points(changed)
    write_points(changed, cloud.points[:-1], cloud.take(np.arange(len(cloud) - 1)).fields)
    third = batch.ground(inputs, out, scheduler=scheduler)
    redone = {os.path.basename(t.input) for t in third.tiles if t.status == "done"}
    assert os.path.basename(changed) in redone and 1 < len(redone) < len(third.tiles)
    # A changed output (or parameter) is redone too.
    os.unlink(third.tiles[0].output)
    params = pcl_rg.GridGroundParams(slope=0.35)
    fourth = batch.ground(inputs, out, params=params, scheduler=scheduler)
    assert {t.status for t in fourth.tiles} == {"done"}
    assert json.loads((out / MANIFEST).read_text())
    # Another build of the same version (a development build) redoes every tile.
    monkeypatch.setattr(_engine, "code_digest", lambda: "another build")
    fifth = batch.ground(inputs, out, params=params, scheduler=scheduler)
    assert {t.status for t in fifth.tiles} == {"done"}


def corrupt_points(path):
    """Damage the point data of a LAZ file, keeping its size and header."""
    data = bytearray(Path(path).read_bytes())
    start = len(data) // 3
    data[start : start + 4096] = np.random.default_rng(0).bytes(4096)
    Path(path).write_bytes(bytes(data))


def test_a_corrupt_tile_fails_alone_and_its_neighbours_say_so(tmp_path, scheduler):
    source = synthetic_survey(tmp_path / "in", tiles=(3, 3), tile_size=60.0, seed=5)
    bad = source.paths[4]  # the middle tile: every other tile borders it
    corrupt_points(bad)
    report = batch.ground(source.paths, tmp_path / "out", scheduler=scheduler)
    assert [t.input for t in report.failed] == [bad]
    assert "LAZ" in report.failed[0].error or "LAS" in report.failed[0].error
    for tile in report.tiles:
        if tile.input != bad:
            assert tile.status == "done" and os.path.basename(bad) in tile.no_buffer_from
    assert not os.path.exists(report.failed[0].output)
    options = ["--out", tmp_path / "c", "--scheduler", scheduler, "--json"]
    result = run_pcl_rg("batch", "ground", *source.paths, *options, timeout=300)
    assert result.returncode == 2, result.stderr
    assert os.path.basename(bad) in result.stderr
    assert json.loads(result.stdout)["failed"] == [bad]


def test_bad_arguments_fail_before_any_work(tmp_path, survey):
    with pytest.raises(ValueError, match="no such file"):
        batch.ground([tmp_path / "missing.laz"], tmp_path / "out")
    with pytest.raises(ValueError, match="matches no point file"):
        batch.ground([str(tmp_path / "*.laz")], tmp_path / "out")
    with pytest.raises(ValueError, match="is the input itself"):
        batch.ground(survey.paths, os.path.dirname(survey.paths[0]))
    with pytest.raises(ValueError, match="buffer must be"):
        batch.ground(survey.paths, tmp_path / "out", buffer=-1.0)
    with pytest.raises(ValueError, match="method must be"):
        batch.ground(survey.paths, tmp_path / "out", method="pmf")
    with pytest.raises(TypeError, match="GridGroundParams"):
        batch.ground(survey.paths, tmp_path / "out", params=pcl_rg.TinGroundParams())
    with pytest.raises(ValueError, match="workers must be"):
        batch.ground(survey.paths, tmp_path / "out", workers=0)
    with pytest.raises(ValueError, match="workers must be <="):  # ran out of memory
        batch.ground(survey.paths, tmp_path / "out", workers=1_000_000)


def test_same_file_names_from_two_folders_are_refused(tmp_path, survey):
    import shutil

    for name in ("a", "b"):
        shutil.copytree(os.path.dirname(survey.paths[0]), tmp_path / name)
    with pytest.raises(ValueError, match="same file name"):
        batch.ground([tmp_path / "a", tmp_path / "b"], tmp_path / "out")
    assert not (tmp_path / "out").exists()  # refused before the folder is made


def test_an_out_that_is_a_file_is_refused_as_such(tmp_path, survey):
    (tmp_path / "afile").write_text("notes")
    result = run_pcl_rg("batch", "ground", *survey.paths[:1], "--out", tmp_path / "afile")
    assert result.returncode == 2
    assert "--out must be a folder, not a file" in result.stderr
    assert (tmp_path / "afile").read_text() == "notes"


def test_the_embedded_local_cluster_and_the_command_line(tmp_path):
    source = synthetic_survey(tmp_path / "in", tiles=(2, 2), tile_size=50.0, seed=3)
    options = ["--workers", "2", "--method", "tin", "--preset", "isprs", "--json"]
    result = run_pcl_rg(
        "batch", "ground", tmp_path / "in", "--out", tmp_path / "out", *options, timeout=300
    )
    assert result.returncode == 0, result.stderr
    summary = json.loads(result.stdout)
    assert summary["workers"] == 2 and summary["operation"] == "ground"
    assert [t["status"] for t in summary["tiles"]] == ["done"] * 4
    expected = ground_of_merged(source.paths, "tin")
    got = np.concatenate([read_points(t["output"]).classification for t in summary["tiles"]])
    assert (got == expected).mean() >= 0.995
    for path, tile in zip(source.paths, summary["tiles"], strict=True):
        original, written = read_points(path), read_points(tile["output"])
        assert written.format == original.format == "laz"
        np.testing.assert_array_equal(written.points, original.points)
        assert set(written.fields) == set(original.fields)
        np.testing.assert_array_equal(written.fields["intensity"], original.fields["intensity"])


def test_a_cluster_of_dask_scheduler_and_dask_worker_processes(tmp_path, small_survey, scheduler):
    dask = os.path.join(os.path.dirname(PYTHON), "dask")
    port_file = tmp_path / "scheduler.json"
    env = dict(os.environ, PYTHONWARNINGS="ignore")
    procs = [
        subprocess.Popen(
            [
                dask,
                "scheduler",
                "--port",
                "0",
                "--no-dashboard",
                "--scheduler-file",
                str(port_file),
            ],
            stdout=subprocess.DEVNULL,
            stderr=subprocess.DEVNULL,
            env=env,
        )
    ]
    try:
        # The scheduler writes its file in place: it may exist and be empty or half
        # written for a moment.
        deadline = time.time() + 60
        address = None
        while address is None:
            assert time.time() < deadline, "the scheduler wrote no scheduler file"
            time.sleep(0.2)
            with contextlib.suppress(FileNotFoundError, json.JSONDecodeError):
                address = json.loads(port_file.read_text())["address"]
        for _ in range(2):
            procs.append(
                subprocess.Popen(
                    [dask, "worker", address, "--nthreads", "1", "--no-dashboard"],
                    stdout=subprocess.DEVNULL,
                    stderr=subprocess.DEVNULL,
                    env=env,
                )
            )
        from distributed import Client

        with Client(address) as client:
            client.wait_for_workers(2, timeout=60)
        report = batch.ground(small_survey.paths, tmp_path / "out", scheduler=address)
        assert report.workers == 2 and not report.failed
        local = batch.ground(small_survey.paths, tmp_path / "local", scheduler=scheduler)
        for a, b in zip(outputs_of(report), outputs_of(local), strict=True):
            np.testing.assert_array_equal(a.classification, b.classification)
    finally:
        for proc in reversed(procs):
            proc.terminate()
        for proc in procs:
            proc.wait(timeout=30)


def test_a_killed_worker_is_replaced_and_the_outputs_are_those_of_a_clean_run(tmp_path, survey):
    from distributed import Client, LocalCluster

    clean = batch.ground(survey.paths, tmp_path / "clean", method="tin", workers=1)
    with LocalCluster(n_workers=2, threads_per_worker=1, dashboard_address=":0") as cluster:
        with Client(cluster) as client:
            pids = client.run(os.getpid)
            outcome = {}
            run = threading.Thread(
                target=lambda: outcome.update(
                    report=batch.ground(
                        survey.paths,
                        tmp_path / "killed",
                        method="tin",
                        scheduler=cluster.scheduler_address,
                    )
                )
            )
            run.start()
            killed = None
            deadline = time.time() + 120
            while killed is None and time.time() < deadline:
                for worker, keys in client.processing().items():
                    if any("ground_tile" in str(k) for k in keys):
                        killed = pids[worker]
                        os.kill(killed, signal.SIGKILL)
                        break
                time.sleep(0.01)
            run.join(timeout=300)
            assert killed is not None, "no ground task was seen running"
            assert killed not in client.run(os.getpid).values()  # replaced by the nanny
    report = outcome["report"]
    assert not report.failed
    for a, b in zip(outputs_of(report), outputs_of(clean), strict=True):
        np.testing.assert_array_equal(a.classification, b.classification)
    assert not [n for n in os.listdir(tmp_path / "killed") if n.endswith(".tmp")]


def test_hostile_headers_among_the_tiles_fail_fast_and_alone(tmp_path, scheduler):
    import shutil

    source = synthetic_survey(tmp_path / "in", tiles=(1, 2), tile_size=40.0, seed=4)
    fuzz = [shared_data("fuzz", n) for n in ("bad-version.las", "vlr-count-hang.laz")]
    for path in fuzz:
        shutil.copy(path, tmp_path / "in")
    start = time.perf_counter()
    report = batch.ground(tmp_path / "in", tmp_path / "out", scheduler=scheduler)
    assert time.perf_counter() - start < 60
    failed = sorted(os.path.basename(t.input) for t in report.failed)
    assert failed == sorted(p.name for p in fuzz)
    done = [t for t in report.tiles if t.status == "done"]
    assert len(done) == 2
    # A file whose header cannot be read has no known box: every tile reports it.
    for tile in done:
        assert set(tile.no_buffer_from) == set(failed)
    written = sorted(n for n in os.listdir(tmp_path / "out") if not n.startswith("."))
    assert written == sorted(os.path.basename(p) for p in source.paths)
    # The tiles done are recorded, unreadable files named: while those stay unreadable,
    # a rerun skips them and redoes only the failed (test_batch_faults.py: once one is
    # readable, the tiles are redone).
    again = batch.ground(tmp_path / "in", tmp_path / "out", scheduler=scheduler)
    assert sorted(t.status for t in again.tiles) == ["failed", "failed", "skipped", "skipped"]


@pytest.mark.parametrize("operation", ["ground", "denoise", "downsample"])
def test_empty_and_nan_tiles_come_out_like_their_inputs(operation, tmp_path, scheduler):
    source = synthetic_survey(tmp_path / "in", tiles=(1, 2), tile_size=40.0, seed=1, format="pcd")
    write_points(tmp_path / "in" / "empty.las", np.empty((0, 3)))
    holes = read_points(source.paths[0]).points + [100.0, 0.0, 0.0]
    holes[::7] = np.nan  # an organized PCD's invalid points
    write_points(tmp_path / "in" / "holes.pcd", holes)
    options = {"params": pcl_rg.VoxelGridParams(leaf_size=1.0)} if operation == "downsample" else {}
    report = getattr(batch, operation)(
        tmp_path / "in", tmp_path / "out", scheduler=scheduler, **options
    )
    assert [t.status for t in report.tiles] == ["done"] * 4, [t.error for t in report.tiles]
    outputs = {os.path.basename(t.output): read_points(t.output) for t in report.tiles}
    assert len(outputs["empty.las"]) == 0 and outputs["empty.las"].format == "las"
    if operation != "downsample":
        written = outputs["holes.pcd"].points
        assert written.shape == holes.shape and np.isnan(written[::7]).all()


def test_a_resumed_denoise_uses_every_tile_for_its_threshold(small_survey, tmp_path, scheduler):
    # Redoing one tile must not compute the global mean and deviation from it alone.
    params = pcl_rg.StatisticalOutlierRemovalParams(mean_k=8)
    first = batch.denoise(small_survey.paths, tmp_path, params=params, scheduler=scheduler)
    os.unlink(first.tiles[3].output)
    again = batch.denoise(small_survey.paths, tmp_path, params=params, scheduler=scheduler)
    assert [t.status for t in again.tiles].count("done") == 1
    assert again.tiles[3].details["threshold"] == first.tiles[3].details["threshold"]
    points = np.concatenate([c.points for c in merged(small_survey.paths)])
    expected = ~pcl_rg.statistical_outlier_removal(points, params=params)
    got = np.concatenate([c.classification for c in outputs_of(again)]) == 7
    assert np.array_equal(got, expected)


def test_denoise_grows_the_buffer_of_a_tile_with_too_few_points(tmp_path, scheduler):
    source = synthetic_survey(tmp_path / "in", tiles=(1, 1), tile_size=40.0, seed=6)
    few = read_points(source.paths[0]).points[:5] + [0.0, 80.0, 0.0]  # 40 m beyond it
    write_points(tmp_path / "in" / "few.las", few)
    params = pcl_rg.StatisticalOutlierRemovalParams(mean_k=10)
    report = batch.denoise(tmp_path / "in", tmp_path / "out", params=params, scheduler=scheduler)
    assert not report.failed, [t.error for t in report.tiles]
    points = np.concatenate([c.points for c in merged([t.input for t in report.tiles])])
    expected = ~pcl_rg.statistical_outlier_removal(points, params=params)
    got = np.concatenate([c.classification for c in outputs_of(report)]) == 7
    assert np.array_equal(got, expected)


def test_reordered_inputs_redo_downsample_tiles(tmp_path, scheduler):
    # Which tile writes a shared voxel follows the input order: a new order redoes all.
    source = synthetic_survey(tmp_path / "in", tiles=(1, 3), tile_size=30.0, seed=8)
    params = pcl_rg.VoxelGridParams(leaf_size=3.0)
    out = tmp_path / "out"
    forward = batch.downsample(source.paths, out, params=params, scheduler=scheduler)
    backward = batch.downsample(source.paths[::-1], out, params=params, scheduler=scheduler)
    assert {t.status for t in backward.tiles} == {"done"}
    points = np.concatenate([c.points for c in merged(source.paths[::-1])])
    voxels = len(pcl_rg.voxel_grid(points, params=params).counts)
    assert sum(len(c) for c in outputs_of(backward)) == voxels
    assert sum(len(c) for c in outputs_of(forward)) == voxels
    with pytest.raises(ValueError, match="leaf size"):
        batch.downsample(source.paths, out, params=params, buffer=1.0)


def test_a_damaged_manifest_redoes_the_tiles(survey, tmp_path, scheduler):
    out = tmp_path / "out"
    batch.ground(survey.paths[:2], out, scheduler=scheduler)
    (out / MANIFEST).write_text(json.dumps({os.path.basename(survey.paths[0]): 1}))
    report = batch.ground(survey.paths[:2], out, scheduler=scheduler)
    assert {t.status for t in report.tiles} == {"done"}
