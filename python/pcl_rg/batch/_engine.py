"""A batch run on Dask: plan the tiles, submit their tasks, follow them, clean up.

Dask does the scheduling, the placement on workers, the retries when a worker dies
and the transfers of the small results between tasks; this module only builds the
task graph and reports. Point data never travels through the scheduler: tasks get
paths and read their own input (and, memory-mapped, their neighbours' buffer rows
from the scratch folder, which is why the output folder must be on a file system
every worker sees).
"""

from __future__ import annotations

import contextlib
import dataclasses
import errno
import hashlib
import json
import os
import sys
import time
import warnings
from collections.abc import Sequence
from typing import Any

from .. import __version__
from .._caller import outside_stacklevel
from .._far_points import FarPointsWarning, far_points_message
from .._point_spacing import with_spacing_lengths
from ..io import Extent
from . import _denoise_tasks, _tasks
from ._cluster import dask_client
from ._headers import check_one_crs, survey_units
from ._manifest import Manifest, code_digest, file_signature
from ._origin import far_points_error
from ._plan import (
    Box,
    box_of,
    expand_inputs,
    neighbours,
    output_paths,
    survey_box,
    survey_spacing,
)
from ._scratch import remove_partial_outputs, scratch_folder

__all__ = ["BatchReport", "TileReport", "run"]


@dataclasses.dataclass
class TileReport:
    """What happened to one input file."""

    input: str
    output: str
    status: str  # "done", "skipped" (up to date) or "failed"
    points: int = 0
    seconds: float = 0.0
    error: str = ""
    no_buffer_from: list[str] = dataclasses.field(default_factory=list)
    """Input files that should have given this tile a buffer but could not be read."""
    details: dict[str, Any] = dataclasses.field(default_factory=dict)
    """The task's own figures (e.g. denoise: ``noise``, ``threshold``, ``buffer_used``, and
    ``far_points`` of its ``usable`` points, left out and flagged as noise)."""
    cannot_write: bool = False
    """Whether it failed writing its output or scratch files (a full disk, no
    permission) rather than on its data."""
    warnings: list[str] = dataclasses.field(default_factory=list)
    """The warnings its tasks raised (a damaged header's point count, ...), each as
    ``<input's file name>: <message>`` (or the message alone where it names the input's
    path), as they were re-emitted in this process."""


@dataclasses.dataclass
class BatchReport:
    """The result of a batch run: one :class:`TileReport` per input, in input order."""

    operation: str
    tiles: list[TileReport]
    seconds: float
    workers: int
    buffer: float
    dashboard: str | None = None
    parameters: dict[str, Any] = dataclasses.field(default_factory=dict)
    """The parameters every tile ran with, lengths left unset filled in from the
    survey's spacing (:func:`pcl_rg.batch.survey_spacing`)."""
    units: dict[str, Any] = dataclasses.field(default_factory=dict)
    """``metres_per_unit`` of x, y, z, by which the tiles were scaled for the work
    (their lengths are metres), and ``source``: where those units come from."""

    @property
    def failed(self) -> list[TileReport]:
        return [t for t in self.tiles if t.status == "failed"]

    @property
    def points(self) -> int:
        """Points of the tiles processed in this run (skipped tiles not counted)."""
        return sum(t.points for t in self.tiles if t.status == "done")

    @property
    def points_per_second(self) -> float:
        return self.points / self.seconds if self.seconds > 0 else 0.0

    def to_dict(self) -> dict[str, Any]:
        """Plain data (for JSON)."""
        result = dataclasses.asdict(self)
        result.update(
            points=self.points,
            points_per_second=self.points_per_second,
            failed=[t.input for t in self.failed],
        )
        return result


#: The box given to a tile without a finite point (it has no point to give or take).
NOWHERE = Box(0.0, 0.0, 0.0, 0.0)


def _dashboard(client: Any) -> str | None:
    """The dashboard's address; None without bokeh, which serves it."""
    try:
        import bokeh  # noqa: F401
    except ImportError:
        return None
    return getattr(client, "dashboard_link", None)


class _Progress:
    """A bar over tiles on stderr with the points per second, when asked for."""

    def __init__(self, total: int, enabled: bool, what: str) -> None:
        self.bar = None
        self.points = 0
        self.start = time.perf_counter()
        if enabled and total:
            try:
                from tqdm import tqdm
            except ImportError:  # the progress extra is not installed: no bar
                return
            self.bar = tqdm(total=total, desc=what, unit="tile", file=sys.stderr)

    def update(self, points: int) -> None:
        self.points += points
        if self.bar is not None:
            rate = self.points / max(time.perf_counter() - self.start, 1e-9)
            self.bar.set_postfix_str(f"{rate / 1e6:.2f} M points/s", refresh=False)
            self.bar.update(1)

    def close(self) -> None:
        if self.bar is not None:
            self.bar.close()


def _discard(manifest: Manifest, output: str) -> str:
    """Forget a failed tile's output and remove an earlier run's file of it, so that the
    folder holds no output that does not come from its current input; what to add to
    the tile's error."""
    manifest.forget(output)
    if not os.path.isfile(output):  # none, or what no run of ours wrote (a FIFO): kept
        return ""
    try:
        os.unlink(output)
    except OSError as error:
        return f" (its earlier output {os.path.basename(output)!r} is stale: {error.strerror})"
    return f" (its earlier output {os.path.basename(output)!r} was removed)"


def _warn(report: TileReport, result: dict[str, Any]) -> None:
    """Re-emit, here, the warnings a task of the tile caught (in a worker they would reach
    only the worker's stderr, in Python's format), each once per tile, named by it (a
    message that already names the tile's path, as the readers' do, is left as it is)."""
    for category, message in result.get("warnings", ()):
        named = report.input in message
        line = message if named else f"{os.path.basename(report.input)}: {message}"
        if line not in report.warnings:
            report.warnings.append(line)
            warnings.warn(line, category, stacklevel=outside_stacklevel())


def _plain(value: Any) -> Any:
    """`value` as it comes back from JSON, for comparing with the manifest."""
    return json.loads(json.dumps(value, default=str))


def run(
    job_template: _tasks.Job,
    inputs: Sequence[str | os.PathLike[str]],
    out: str | os.PathLike[str],
    *,
    workers: int | None,
    scheduler: str | None,
    progress: bool,
    resume: bool,
    on_dashboard: Any = None,
) -> BatchReport:
    """Run one operation over every input; see :func:`pcl_rg.batch.ground`."""
    start = time.perf_counter()
    paths = expand_inputs(inputs)
    if not os.fspath(out):  # "" is the working folder to os.path: an unset variable?
        raise ValueError("out is an empty path: give the output folder")
    folder = os.path.abspath(os.fspath(out))
    if os.path.exists(folder) and not os.path.isdir(folder):
        raise NotADirectoryError(errno.ENOTDIR, "--out must be a folder, not a file", folder)
    outputs = output_paths(paths, folder)  # refused name clashes leave no folder behind
    os.makedirs(os.path.dirname(folder), exist_ok=True)
    try:  # made here or not, decided by the one call that makes it
        os.mkdir(folder)
        made = True
    except FileExistsError:
        made = False
    reports = [TileReport(p, o, "failed") for p, o in zip(paths, outputs, strict=True)]
    manifest = Manifest(folder)
    if not resume:
        manifest.clear()
    parameters = _plain(dataclasses.asdict(job_template.params))
    units: dict[str, Any] = {}
    dashboard = None
    try:
        # The scratch folder outlives the workers that write into it.
        with scratch_folder(folder) as scratch, dask_client(workers, scheduler) as client:
            job = dataclasses.replace(job_template, scratch=scratch)
            dashboard = _dashboard(client)
            if on_dashboard and dashboard:
                on_dashboard(dashboard)
            n_workers = len(client.scheduler_info().get("workers", {}))
            futures: list[Any] = []
            try:
                parameters, units = _run_on(
                    client, job, paths, outputs, reports, manifest, parameters, progress, futures
                )
            except BaseException:
                client.cancel(futures, force=True)
                raise
    finally:
        remove_partial_outputs([*outputs, manifest.path])
        if made:  # a run that wrote nothing (refused, interrupted, every tile failed)
            with contextlib.suppress(OSError):  # leaves no folder it made: only if empty
                os.rmdir(folder)
    return BatchReport(
        job_template.operation,
        reports,
        time.perf_counter() - start,
        n_workers,
        job_template.buffer,
        dashboard,
        parameters,
        units,
    )


def _run_on(
    client: Any,
    job: _tasks.Job,
    paths: list[str],
    outputs: list[str],
    reports: list[TileReport],
    manifest: Manifest,
    parameters: Any,
    progress: bool,
    futures: list[Any],
) -> tuple[Any, dict[str, Any]]:
    """The stages of a run: (the parameters the tiles ran with, the survey's units)."""
    from distributed import as_completed

    reading = client.map(_tasks.tile_extent, paths, pure=False)
    futures += reading
    # One result at a time: an interrupt inside client.gather left its per-future waits
    # to fail when the client closed, and asyncio printed each ("Task exception was never
    # retrieved ... AllExit") after pcl-rg's one-line message.
    extents = [future.result() for future in reading]
    check_one_crs(paths, extents)
    scale, where = survey_units(paths, extents, job.units)
    units = {"metres_per_unit": list(scale), "source": where}
    if scale != job.scale:  # every length is metres: the tiles' units from here on
        job = dataclasses.replace(job, scale=scale, buffer=job.buffer / scale[0])
    boxes: list[Box | None] = []
    for i, (report, extent) in enumerate(zip(reports, extents, strict=True)):
        _warn(report, extent)
        if not extent["ok"]:
            report.error = extent["error"] + _discard(manifest, outputs[i])
            boxes.append(None)
            continue
        e = Extent(*extent["extent"])
        finite = all(v == v for v in (e.xmin, e.ymin, e.xmax, e.ymax))
        boxes.append(box_of(e) if finite and e.points else None)
        report.points = e.points
    readable = [i for i, e in enumerate(extents) if e["ok"]]
    if job.operation == "ground":
        # Lengths that follow the point spacing: one spacing for the whole survey, so that
        # every tile runs with the same parameters (a tile's own would differ a little).
        in_survey = [Extent(*extents[i]["extent"]) for i in readable if boxes[i]]
        params = with_spacing_lengths(job.params, lambda: survey_spacing(in_survey) * job.scale[0])
        if params != job.params:
            job = dataclasses.replace(job, params=params)
            parameters = _plain(dataclasses.asdict(job.params))
    # Denoising's statistics are global: every tile is context for every other.
    near = (
        [[j for j in readable if j != i and boxes[j]] for i in range(len(paths))]
        if job.operation == "denoise"
        else neighbours(boxes, job.buffer)
    )
    unreadable = [os.path.basename(paths[i]) for i, e in enumerate(extents) if not e["ok"]]
    tiles = [_tasks.Tile(i, paths[i], outputs[i], boxes[i] or NOWHERE) for i in range(len(paths))]

    # What each output is computed from, taken once before any work (an input edited
    # during the run must not be recorded as the one its output came from).
    signatures = {i: file_signature(paths[i]) for i in readable}
    if job.operation == "denoise":
        # Global statistics: every output depends on every readable input, in order.
        survey = hashlib.sha256(json.dumps([signatures[i] for i in readable]).encode())
        contexts = {i: survey.hexdigest() for i in readable}
    else:
        # The neighbours with their positions: downsample's voxel ownership follows
        # the input order, so a reordering must redo the tiles.
        contexts = {i: [[j, signatures[j]] for j in near[i] if j in signatures] for i in readable}
    expected = {
        i: _plain(
            {
                "operation": job.operation,
                "method": job.method,
                "keep_classes": job.keep_classes,
                "parameters": parameters,
                "buffer": job.buffer,
                "metres_per_unit": job.scale,
                "version": __version__,
                "build": code_digest(),
                "position": i,
                "input": signatures[i],
                "context": contexts[i],
                "unreadable": unreadable,
            }
        )
        for i in readable
    }

    todo = []
    for i in readable:
        if manifest.done(outputs[i], expected[i]):
            reports[i].status = "skipped"
        else:
            todo.append(i)
    if job.operation == "denoise" and todo:
        # The threshold needs every tile's distances, also those of tiles skipped.
        needed = list(readable)
    else:
        needed = sorted(set(todo) | {j for i in todo for j in near[i]})
    cached = {i: client.submit(_tasks.cache_tile, job, tiles[i], pure=False) for i in needed}
    futures += cached.values()
    known: dict[int, dict[str, Any]] = {}

    def stage1(j: int) -> dict[str, Any]:  # each stage-1 outcome fetched once
        if j not in known:
            known[j] = _outcome(cached[j])
            _warn(reports[j], known[j])
        return known[j]

    bar = _Progress(len(todo), progress, f"{job.operation} ({len(todo)} tiles)")
    try:
        # A denoise threshold that lacks a tile's distances (it failed) is not the
        # survey's: the tiles written with it are redone next time, as their own
        # neighbours' are.
        measured_all = True
        if job.operation == "denoise":
            stage, measured_all = _denoise(
                client, job, tiles, boxes, near, todo, cached, futures, reports
            )
        else:
            stage = {}
            task = _tasks.ground_tile if job.operation == "ground" else _tasks.downsample_tile
            for i in todo:
                ready = [cached[i]] + [cached[j] for j in near[i]]
                context = [tiles[j] for j in near[i]]
                stage[client.submit(task, job, tiles[i], context, ready, pure=False)] = i
            futures += stage.keys()
        for future in as_completed(list(stage)):
            i = stage[future]
            result = _outcome(future)
            report = reports[i]
            stage1(i)  # its warnings first
            _warn(report, result)
            if result["ok"] and result.get("far_points"):  # written: say how many were far
                outcome = "classified as noise (7), outside the mean and deviation"
                line = far_points_message(
                    "denoise", result["far_points"], result["usable"], outcome, "the survey's"
                )
                _warn(report, {"warnings": [(FarPointsWarning, line)]})
            report.details = {
                k: v for k, v in result.items() if k not in ("ok", "error", "warnings")
            }
            report.seconds = result.get("seconds", 0.0)
            # Stage 2 ran after every neighbour's stage 1: their outcomes are known.
            short = [j for j in near[i] if j in cached and not stage1(j)["ok"]]
            if result["ok"]:
                report.status, report.error = "done", ""
                report.points = result.get("points", report.points)
                if short or not measured_all:  # a neighbour's decode failed, maybe
                    manifest.forget(outputs[i])  # for a passing reason: redo it next time
                else:
                    # Files unreadable from the start (no box: anybody's neighbour)
                    # are among `expected`: one that becomes readable redoes the tile.
                    manifest.record(outputs[i], expected[i])
            else:
                report.status = "failed"
                report.error = result["error"] + _discard(manifest, outputs[i])
                report.cannot_write = result.get("cannot_write", False)
            bar.update(report.points)
    finally:
        bar.close()
    outcomes = {i: stage1(i) for i in cached}
    for i, result in outcomes.items():
        if result["ok"] or reports[i].status == "failed":
            continue  # a tile of the work reported its failure above, with its note
        # A tile skipped as done, read only as a buffer, that now fails to decode: its
        # output cannot be vouched for any more.
        reports[i].status = "failed"
        reports[i].error = result["error"] + _discard(manifest, outputs[i])
        reports[i].cannot_write = result.get("cannot_write", False)
    for i, report in enumerate(reports):
        missing = [j for j in near[i] if j in outcomes and not outcomes[j]["ok"]]
        report.no_buffer_from = [os.path.basename(paths[j]) for j in missing] + unreadable
    return parameters, units


def _outcome(future: Any) -> dict[str, Any]:
    """A task's result; a task that raised (e.g. its worker died again and again,
    ``KilledWorker``) as a failed result, so one tile cannot abort the run."""
    try:
        return future.result()
    except Exception as error:  # noqa: BLE001 - reported per tile, never swallowed
        return {"ok": False, "error": f"{type(error).__name__}: {error}"}


def _denoise(
    client: Any,
    job: _tasks.Job,
    tiles: list[_tasks.Tile],
    boxes: list[Box | None],
    near: list[list[int]],
    todo: list[int],
    cached: dict[int, Any],
    futures: list[Any],
    reports: list[TileReport],
) -> tuple[dict[Any, int], bool]:
    """Distances per tile, one global threshold, then the writes (stages 2 and 3); and
    whether every tile read had its distances measured (the threshold the survey's)."""
    stage1 = {i: _outcome(f) for i, f in cached.items()}
    for i, result in stage1.items():
        _warn(reports[i], result)
    read = [i for i in cached if stage1[i]["ok"]]
    survey = survey_box([boxes[i] for i in read]) or NOWHERE
    # The merged run's float32 origin, from which every tile decides its far points.
    origin_future = client.submit(
        _denoise_tasks.survey_origin, job, [tiles[i] for i in read], pure=False
    )
    futures.append(origin_future)
    found = _outcome(origin_future)
    distances = {}
    for i in read if found["ok"] else []:
        others = [tiles[j] for j in near[i] if stage1.get(j, {}).get("ok")]
        distances[i] = client.submit(
            _denoise_tasks.denoise_distances,
            job,
            tiles[i],
            survey,
            found["origin"],
            others,
            pure=False,
        )
    futures += distances.values()
    sums = (
        {i: _outcome(f) for i, f in distances.items()}
        if found["ok"]
        else dict.fromkeys(read, found)
    )
    for i, result in sums.items():
        _warn(reports[i], result)
    # Over the usable points of every tile read: those whose distances failed count too.
    far = sum(s["far"] for s in sums.values() if s["ok"])
    too_many_far = far_points_error(far, sum(stage1[i]["usable"] for i in read))
    if too_many_far:  # the tiles that hold them fail, as the merged run would
        for i, result in sums.items():
            if result["ok"] and result["far"]:
                sums[i] = {"ok": False, "error": f"ValueError: {too_many_far}"}
    good = [s for s in sums.values() if s["ok"]]
    threshold = _denoise_tasks.sor_threshold(good, job.params.std_mul) if good else float("nan")
    stage: dict[Any, int] = {}
    for i in todo:
        if i in sums and sums[i]["ok"]:
            future = client.submit(
                _denoise_tasks.denoise_write, job, tiles[i], threshold, sums[i], pure=False
            )
        else:
            failure = sums.get(i) or stage1[i]
            future = client.submit(_tasks.passed_on, failure, pure=False)
        stage[future] = i
    futures += stage.keys()
    return stage, len(good) == len(read)
