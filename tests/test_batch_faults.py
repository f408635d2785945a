"""Batch runs against damaged or misleading tiles and a damaged output folder: header
boxes unlike their points, tiles in two coordinate systems, failed reruns, the record
of finished tiles; and the parameters a run reports."""

from __future__ import annotations

import contextlib
import json
import os
import resource
import shutil
import threading
import warnings
from pathlib import Path

import numpy as np
import pytest
from conftest import run_pcl_rg
from test_batch import corrupt_points
from test_batch_strays import assert_denoise_is_the_merged_run

import pcl_rg
from pcl_rg import batch
from pcl_rg.batch._manifest import MANIFEST
from pcl_rg.batch._plan import expand_inputs
from pcl_rg.datasets import synthetic_survey
from pcl_rg.io import read_points


def shift_header_min_xy(path, by):
    """Move a LAS/LAZ header's min x and min y by `by` metres, leaving the points alone
    (the header is stored uncompressed in LAZ too: doubles at bytes 187 and 203)."""
    data = bytearray(Path(path).read_bytes())
    for offset in (187, 203):
        value = np.frombuffer(bytes(data[offset : offset + 8]), "<f8")[0] + by
        data[offset : offset + 8] = np.float64(value).tobytes()
    Path(path).write_bytes(bytes(data))


@pytest.mark.parametrize("by", [-2000.0, 10.0, 0.02])  # far too wide, too small, a bit small
# The reader warns of points outside a header's box too small for them (pcl_rg.io).
@pytest.mark.filterwarnings("ignore:LAS file .* lie outside the header's box:UserWarning")
def test_a_header_box_unlike_its_points_fails_its_tile(by, tmp_path, scheduler):
    # The run's plan (neighbours, the survey's spacing) comes from the headers: a box
    # that lies must not pass silently.
    source = synthetic_survey(tmp_path / "in", tiles=(1, 2), tile_size=40.0, seed=4)
    bad = source.paths[0]
    batch.ground(source.paths, tmp_path / "out", scheduler=scheduler)  # an earlier output
    shift_header_min_xy(bad, by)
    report = batch.ground(source.paths, tmp_path / "out", scheduler=scheduler)
    assert [t.input for t in report.failed] == [bad]
    assert "header's bounding box" in report.failed[0].error
    assert [t.status for t in report.tiles] == ["failed", "done"]
    assert not os.path.exists(report.failed[0].output)  # that output is gone


def test_a_header_box_rounded_outwards_passes(tmp_path, scheduler):
    # Some writers round the bounds outwards: harmless to the plan, so not refused.
    source = synthetic_survey(tmp_path / "in", tiles=(1, 2), tile_size=40.0, seed=4)
    shift_header_min_xy(source.paths[0], -0.3)
    report = batch.ground(source.paths, tmp_path / "out", scheduler=scheduler)
    assert [t.status for t in report.tiles] == ["done", "done"]


def add_crs_record(path, wkt):
    import laspy

    las = laspy.read(path)  # in place of any record it has
    las.vlrs = [v for v in las.vlrs if v.user_id != "LASF_Projection"]
    las.vlrs.append(laspy.VLR("LASF_Projection", 2112, "wkt", wkt.encode() + b"\0"))
    las.write(path)


UTM_32N_WKT1 = (
    'PROJCS["WGS 84 / UTM zone 32N",GEOGCS["WGS 84",DATUM["WGS_1984",SPHEROID["WGS 84",'
    '6378137,298.257223563,AUTHORITY["EPSG","7030"]],AUTHORITY["EPSG","6326"]],'
    'AUTHORITY["EPSG","4326"]],PROJECTION["Transverse_Mercator"],UNIT["metre",1],'
    'AUTHORITY["EPSG","32632"]]'
)
UTM_32N_WKT2 = (
    'PROJCRS["WGS 84 / UTM zone 32N",BASEGEOGCRS["WGS 84",ID["EPSG",4326]],ID["EPSG",32632]]'
)


def test_tiles_in_two_coordinate_systems_are_refused(tmp_path, scheduler):
    source = synthetic_survey(tmp_path / "in", tiles=(1, 2), tile_size=40.0, seed=4)
    # One system written two ways (WKT 1, WKT 2) is one system.
    add_crs_record(source.paths[0], UTM_32N_WKT1)
    add_crs_record(source.paths[1], UTM_32N_WKT2)
    report = batch.ground(source.paths, tmp_path / "a", scheduler=scheduler)
    assert {t.status for t in report.tiles} == {"done"}
    add_crs_record(source.paths[1], UTM_32N_WKT2.replace("32632", "32633"))
    with pytest.raises(ValueError, match="EPSG:32632 and .* in EPSG:32633"):
        batch.ground(source.paths, tmp_path / "b", scheduler=scheduler)
    assert not os.path.exists(tmp_path / "b")  # not even the folder the run made


def test_a_tile_that_cannot_be_written_exits_1_and_leaves_no_folder(tmp_path):
    # A full disk was exit status 2, bad input, where one file's command exits with 1,
    # and "wrote DIR" was said of a folder that got nothing. A file-size limit stands
    # in for the full disk: Python ignores SIGXFSZ, so a write past it fails (EFBIG).
    source = synthetic_survey(tmp_path / "in", tiles=(1, 2), tile_size=40.0, seed=4)

    def small_files() -> None:
        resource.setrlimit(resource.RLIMIT_FSIZE, (20_000, 20_000))

    argv = ["batch", "ground", *source.paths, "--out", tmp_path / "out", "--workers", "1"]
    result = run_pcl_rg(*argv, preexec_fn=small_files)
    assert result.returncode == 1, result.stderr
    assert "2 of 2 tiles failed" in result.stderr and "cannot write" in result.stderr
    assert "wrote" not in result.stdout
    assert not (tmp_path / "out").exists()  # the run made it, and nothing is in it
    report = batch.ground(source.paths, tmp_path / "fine", workers=1)
    assert not report.failed and not any(t.cannot_write for t in report.tiles)


def test_an_empty_output_path_is_refused(tmp_path, monkeypatch):
    monkeypatch.chdir(tmp_path)
    source = synthetic_survey(tmp_path / "in", tiles=(1, 1), tile_size=40.0, seed=4)
    with pytest.raises(ValueError, match="out is an empty path"):
        batch.ground(source.paths, "")
    assert os.listdir(tmp_path) == ["in"]


@pytest.mark.parametrize("damage", ["header", "points"])  # found at stage 0, at stage 1
def test_a_failed_rerun_removes_the_tiles_earlier_output(damage, tmp_path, scheduler):
    source = synthetic_survey(tmp_path / "in", tiles=(1, 2), tile_size=40.0, seed=4)
    out = tmp_path / "out"
    first = batch.ground(source.paths, out, scheduler=scheduler)
    assert os.path.exists(first.tiles[0].output)
    if damage == "header":  # the input is damaged since
        Path(source.paths[0]).write_bytes(Path(source.paths[0]).read_bytes()[:3000])
    else:
        corrupt_points(source.paths[0])
    again = batch.ground(source.paths, out, scheduler=scheduler)
    assert [t.input for t in again.failed] == [source.paths[0]]
    assert "earlier output" in again.failed[0].error
    # No output left that does not come from its current input, nor a record of one.
    assert not os.path.exists(again.tiles[0].output)
    manifest = json.loads((out / MANIFEST).read_text())
    assert os.path.basename(source.paths[0]) not in manifest
    # Its neighbour ran without its buffer: done, and not recorded, so redone next time.
    assert again.tiles[1].status == "done" and again.tiles[1].no_buffer_from


def test_a_run_without_resuming_forgets_the_record_on_disk(tmp_path, scheduler):
    source = synthetic_survey(tmp_path / "in", tiles=(1, 2), tile_size=40.0, seed=4)
    out = tmp_path / "out"
    batch.ground(source.paths, out, scheduler=scheduler)
    corrupt_points(source.paths[0])
    batch.ground(source.paths, out, resume=False, scheduler=scheduler)
    assert os.path.basename(source.paths[0]) not in json.loads((out / MANIFEST).read_text())


def test_a_folder_in_place_of_the_manifest_is_refused(tmp_path, survey):
    (tmp_path / "out" / MANIFEST).mkdir(parents=True)
    with pytest.raises(ValueError, match="is not a file"):
        batch.ground(survey.paths[:2], tmp_path / "out")


def test_the_report_gives_the_parameters_the_tiles_ran_with(tmp_path, scheduler):
    source = synthetic_survey(tmp_path / "in", tiles=(1, 2), tile_size=40.0, seed=4)
    report = batch.ground(source.paths, tmp_path / "out", scheduler=scheduler)
    used = pcl_rg.GridGroundParams().at_spacing(batch.survey_spacing(source.paths))
    assert report.parameters["cell_size"] == list(used.cell_size)  # not None, as given
    options = ["--out", tmp_path / "c", "--scheduler", scheduler, "--json"]
    result = run_pcl_rg("batch", "ground", *source.paths, *options, timeout=300)
    assert json.loads(result.stdout)["parameters"]["cell_size"] == list(used.cell_size)


# ---------------------------------------------------------------- inputs that are no tile


def test_a_fifo_named_as_a_tile_is_refused_or_skipped_before_any_work(tmp_path):
    # Opening a FIFO blocks until a writer comes: its worker would wait for ever.
    source = synthetic_survey(tmp_path / "in", tiles=(1, 2), tile_size=40.0, seed=4)
    os.mkfifo(tmp_path / "in" / "pipe.laz")
    with pytest.raises(ValueError, match=r"pipe\.laz' is not a regular file"):
        batch.ground([tmp_path / "in" / "pipe.laz", *source.paths], tmp_path / "out")
    assert not (tmp_path / "out").exists()
    for listed in (tmp_path / "in", str(tmp_path / "in" / "*.laz")):  # a folder, a glob
        with pytest.warns(UserWarning, match=r"skipped .*pipe\.laz': not a regular file"):
            assert expand_inputs([listed]) == source.paths


def test_a_fifo_in_a_folder_is_one_warning_line_and_the_tiles_run(tmp_path, scheduler):
    source = synthetic_survey(tmp_path / "in", tiles=(1, 2), tile_size=40.0, seed=4)
    os.mkfifo(tmp_path / "in" / "pipe.laz")
    options = ["--out", tmp_path / "out", "--scheduler", scheduler, "-q"]
    result = run_pcl_rg("batch", "ground", tmp_path / "in", *options, timeout=120)
    assert result.returncode == 0, result.stderr
    assert result.stderr.splitlines() == [
        f"pcl-rg: warning: skipped {str(tmp_path / 'in' / 'pipe.laz')!r}: not a regular file "
        "(a folder, FIFO, device or broken link)"
    ]
    assert sorted(os.listdir(tmp_path / "out")) == [MANIFEST, *map(os.path.basename, source.paths)]


def test_notes_in_a_tile_folder_are_no_tile(tmp_path):
    synthetic_survey(tmp_path, tiles=(1, 1), tile_size=40.0, seed=4)
    (tmp_path / "README.txt").write_text("Survey notes, do not process\n1 2 3\n")
    (tmp_path / "counted.txt").write_text("// from a scanner\n2\n1.0 2 3 40\n1 2 3.5 41\n")
    pcl_rg.io.write_points(tmp_path / "empty.txt", np.zeros((0, 3)))  # "# x y z", no row
    (tmp_path / "comma.txt").write_text("1,2,3\n")  # not what the XYZ reader reads
    (tmp_path / "two.txt").write_text("1 2\n")
    names = [os.path.basename(p) for p in expand_inputs([tmp_path])]
    assert names == ["counted.txt", "empty.txt", "tile_0_0.laz"]
    assert [os.path.basename(p) for p in expand_inputs([tmp_path / "*.txt"])] == names[:2]
    # Named, a file is a tile whatever it holds: its read fails, for it alone.
    assert expand_inputs([tmp_path / "README.txt"]) == [str(tmp_path / "README.txt")]


def test_a_failed_tile_leaves_the_others_recorded_and_a_rerun_redoes_only_it(tmp_path, scheduler):
    source = synthetic_survey(tmp_path / "in", tiles=(1, 3), tile_size=40.0, seed=4)
    broken, whole = source.paths[2], Path(source.paths[2]).read_bytes()
    Path(broken).write_bytes(whole[:3000])  # a header that cannot be read: no box
    out = tmp_path / "out"
    first = batch.ground(source.paths, out, scheduler=scheduler)
    assert [t.status for t in first.tiles] == ["done", "done", "failed"]
    assert first.tiles[1].no_buffer_from == ["tile_0_2.laz"]
    assert sorted(json.loads((out / MANIFEST).read_text())) == ["tile_0_0.laz", "tile_0_1.laz"]
    again = batch.ground(source.paths, out, scheduler=scheduler)
    assert [t.status for t in again.tiles] == ["skipped", "skipped", "failed"]
    # Readable again: it may be anybody's neighbour, so every tile is redone (its
    # neighbour now with its buffer) and recorded.
    Path(broken).write_bytes(whole)
    mended = batch.ground(source.paths, out, scheduler=scheduler)
    assert [t.status for t in mended.tiles] == ["done", "done", "done"]
    assert mended.tiles[1].no_buffer_from == [] and mended.tiles[1].details["buffer_points"] > 0
    assert len(json.loads((out / MANIFEST).read_text())) == 3


def test_a_tile_whose_denoise_distances_failed_leaves_no_tile_recorded(tmp_path, monkeypatch):
    # A passing failure of one tile's distances (its worker killed: KilledWorker) left
    # the others written with a threshold without its distances, and recorded as done:
    # the rerun skipped them and redid that tile with the survey's threshold, so the
    # survey held two thresholds. In this process, to make that one task fail.
    from distributed import LocalCluster

    from pcl_rg.batch import _denoise_tasks, _tasks

    source = synthetic_survey(tmp_path / "in", tiles=(1, 3), tile_size=40.0, seed=4)
    measure = _denoise_tasks.denoise_distances

    def killed(job, tile, *rest):
        if tile.index == 1:
            return _tasks.guarded(lambda: (_ for _ in ()).throw(MemoryError("out of memory")))
        return measure(job, tile, *rest)

    params = pcl_rg.StatisticalOutlierRemovalParams(mean_k=12, std_mul=0.5)
    with LocalCluster(
        n_workers=1, threads_per_worker=1, processes=False, dashboard_address=":0"
    ) as cluster:
        monkeypatch.setattr(_denoise_tasks, "denoise_distances", killed)
        address = cluster.scheduler_address
        first = batch.denoise(source.paths, tmp_path / "out", params=params, scheduler=address)
        assert [t.status for t in first.tiles] == ["done", "failed", "done"]
        assert "out of memory" in first.tiles[1].error
        monkeypatch.setattr(_denoise_tasks, "denoise_distances", measure)
        again = batch.denoise(source.paths, tmp_path / "out", params=params, scheduler=address)
    assert [t.status for t in again.tiles] == ["done"] * 3
    assert_denoise_is_the_merged_run(source.paths, again, params)


# ---------------------------------------------------------------- warnings of the workers


def shorten_point_count(path, by):
    """Make a LAS 1.4 file's header count `by` points fewer than it holds; the new count."""
    data = bytearray(Path(path).read_bytes())
    count = int.from_bytes(data[247:255], "little") - by
    data[247:255] = count.to_bytes(8, "little")
    Path(path).write_bytes(bytes(data))
    return count


def damaged_las_survey(folder):
    """Two LAS tiles, the first with 5 points more than its header counts: its reads warn
    (naming the tile by its path, so the warning is not prefixed with its name again)."""
    source = synthetic_survey(folder / "laz", tiles=(1, 2), tile_size=40.0, seed=4)
    paths = [str(folder / os.path.basename(p).replace(".laz", ".las")) for p in source.paths]
    for laz, las in zip(source.paths, paths, strict=True):
        cloud = read_points(laz)
        pcl_rg.io.write_points(las, cloud.points, cloud.fields, template=cloud)
    count = shorten_point_count(paths[0], 5)
    line = (
        f"LAS file {paths[0]!r}: the header counts {count} points, but the "
        "file holds room for 5 more records after them; only the counted points are read "
        "(is the header's point count damaged?)"
    )
    return paths, line


@pytest.mark.parametrize("operation", ["ground", "denoise", "downsample"])
@pytest.mark.parametrize("workers", ["processes", "threads"])
def test_a_tiles_warning_reaches_the_caller_once_named_by_its_tile(
    operation, workers, tmp_path, scheduler
):
    paths, line = damaged_las_survey(tmp_path)
    options = {"params": pcl_rg.VoxelGridParams(leaf_size=2.0)} if operation == "downsample" else {}
    run = getattr(batch, operation)
    with contextlib.ExitStack() as stack:
        if workers == "threads":  # in this process: two tasks at a time on its threads
            from distributed import LocalCluster

            cluster = stack.enter_context(
                LocalCluster(
                    n_workers=1, threads_per_worker=2, processes=False, dashboard_address=":0"
                )
            )
            address = cluster.scheduler_address
        else:
            address = scheduler
        with warnings.catch_warnings(record=True) as caught:
            warnings.simplefilter("always")
            report = run(paths, tmp_path / "out", scheduler=address, **options)
    assert [t.status for t in report.tiles] == ["done", "done"]
    assert [str(w.message) for w in caught] == [line]
    assert caught[0].category is UserWarning and caught[0].filename == __file__
    assert [t.warnings for t in report.tiles] == [[line], []]


def test_a_warning_that_does_not_name_its_tile_is_prefixed_with_the_tiles_name():
    from pcl_rg.batch._engine import TileReport, _warn

    report = TileReport(input="/survey/north.laz", output="/out/north.laz", status="done")
    caught_warnings = [(UserWarning, "few points"), (UserWarning, "/survey/north.laz: odd")]
    with warnings.catch_warnings(record=True) as caught:
        warnings.simplefilter("always")
        _warn(report, {"warnings": caught_warnings * 2})  # each once per tile
    assert report.warnings == ["north.laz: few points", "/survey/north.laz: odd"]
    assert [str(w.message) for w in caught] == report.warnings


def test_a_tiles_warning_is_one_pcl_rg_line_on_the_commands_stderr(tmp_path):
    # The engine's own local cluster: its worker processes share the command's stderr.
    paths, line = damaged_las_survey(tmp_path)
    options = ["--out", tmp_path / "out", "--workers", "1", "-q"]
    result = run_pcl_rg("batch", "ground", *paths, *options, timeout=300)
    assert result.returncode == 0, result.stderr
    assert result.stderr.splitlines() == [f"pcl-rg: warning: {line}"]


# ---------------------------------------------------------------- links


def test_outputs_are_named_after_the_links_listed(tmp_path, scheduler):
    source = synthetic_survey(tmp_path / "tiles", tiles=(1, 2), tile_size=40.0, seed=4)
    (tmp_path / "other").mkdir()
    shutil.copy(source.paths[1], tmp_path / "other" / "tile_0_0.laz")  # a name twice
    (tmp_path / "links").mkdir()
    os.symlink(source.paths[0], tmp_path / "links" / "north.laz")
    os.symlink(tmp_path / "other" / "tile_0_0.laz", tmp_path / "links" / "south.laz")
    report = batch.ground(tmp_path / "links", tmp_path / "out", scheduler=scheduler)
    assert [t.input for t in report.tiles] == [
        str(tmp_path / "links" / "north.laz"),
        str(tmp_path / "links" / "south.laz"),
    ]
    assert [os.path.basename(t.output) for t in report.tiles] == ["north.laz", "south.laz"]
    assert [t.status for t in report.tiles] == ["done", "done"]
    # A file listed again under its target's name counts once, under its first name.
    both = batch.ground(
        [tmp_path / "links", source.paths[0]], tmp_path / "out", scheduler=scheduler
    )
    assert [t.status for t in both.tiles] == ["skipped", "skipped"]
    # An output that is another input, through a link, is refused before any work.
    (tmp_path / "out2").mkdir()
    os.symlink(source.paths[1], tmp_path / "out2" / "north.laz")
    with pytest.raises(ValueError, match=r"north\.laz' is the input .*tile_0_1\.laz'"):
        batch.ground([tmp_path / "links" / "north.laz", source.paths[1]], tmp_path / "out2")


def test_the_warnings_of_tasks_on_two_threads_stay_apart():
    # warnings.catch_warnings is one state per process: a task that ends while another
    # runs would restore it under the other's feet, and the other's warning be lost.
    from pcl_rg.batch._caught import caught

    lists = {}
    first_in, second_in, first_done = (threading.Event() for _ in range(3))

    def first():
        with caught() as lists["first"]:
            first_in.set()
            second_in.wait()
            warnings.warn("one", UserWarning, stacklevel=1)
        first_done.set()

    def second():
        first_in.wait()
        with caught() as lists["second"]:
            second_in.set()
            first_done.wait()  # the first task ended while this one runs
            warnings.warn("two", RuntimeWarning, stacklevel=1)

    threads = [threading.Thread(target=f) for f in (second, first)]
    with warnings.catch_warnings(record=True) as outside:
        warnings.simplefilter("always")
        for thread in threads:
            thread.start()
        for thread in threads:
            thread.join()
        warnings.warn("three", UserWarning, stacklevel=1)  # after the tasks: as before them
    assert lists == {"first": [(UserWarning, "one")], "second": [(RuntimeWarning, "two")]}
    assert [str(w.message) for w in outside] == ["three"]


def test_what_killed_runs_left_in_the_output_folder_is_removed(tmp_path, scheduler):
    # SIGKILL, the OOM killer or a power cut skip every clean-up: the next run removes
    # their temporary files (also of names over 64 bytes, which atomic_write shortens)
    # and scratch folders, but not a scratch folder whose run still holds its lock.
    import fcntl

    from pcl_rg.batch._scratch import SCRATCH_LOCK, SCRATCH_PREFIX
    from pcl_rg.io._atomic import partial_files

    source = synthetic_survey(tmp_path / "in", tiles=(1, 2), tile_size=40.0, seed=4)
    long_name = "survey_2024_block_a_flightline_0042_classified_denoised_tile_0_0_epsg32632.laz"
    tiles = [shutil.copy(source.paths[0], tmp_path / long_name), source.paths[1]]
    out = tmp_path / "out"
    out.mkdir()
    strays = [
        out / f".{long_name[:64]}.4242.0123abcd.tmp",
        out / f".{Path(tiles[1]).name}.4242.0123abcd.tmp",
        out / f".{MANIFEST}.4242.0123abcd.tmp",
    ]
    for stray in strays:
        stray.write_bytes(b"half a file")
    assert sorted(map(str, strays[:1])) == partial_files(str(out / long_name))

    def scratch(name, age, lock=True):
        folder = out / (SCRATCH_PREFIX + name)
        (folder / "0").mkdir(parents=True)
        (folder / "0" / "points.npy").write_bytes(b"x" * 100)
        if lock:
            (folder / SCRATCH_LOCK).touch()
        os.utime(folder, (os.path.getmtime(folder) - age,) * 2)
        return folder

    killed, unlocked = scratch("0" * 16, 600), scratch("1" * 16, 600, lock=False)
    live, young = scratch("2" * 16, 600), scratch("3" * 16, 0)
    with open(live / SCRATCH_LOCK, "r+") as lock:
        fcntl.flock(lock, fcntl.LOCK_EX)
        report = batch.ground(tiles, out, scheduler=scheduler)
    assert [t.status for t in report.tiles] == ["done", "done"]
    assert not [s for s in strays if s.exists()]
    assert (killed.exists(), unlocked.exists(), live.exists(), young.exists()) == (
        False,
        False,
        True,
        True,
    )
