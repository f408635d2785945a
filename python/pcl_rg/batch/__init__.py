"""Surveys of many tiles on Dask: buffered tiles, seamless results, resumable runs.

Each input file (LAS/LAZ, PCD, PLY or XYZ text) gives one output of the same name in the
output folder, written as the single-file command (``pcl-rg ground``, ``denoise``,
``downsample``) writes it: same format, every dimension kept. What differs is the
context: each tile is processed together with a buffer of the points of its
neighbours that lie within `buffer` metres of its box, so objects and terrain that
cross a tile's border are seen whole, and the result matches a run on the merged
cloud (measured in benchmarks/RESULTS.md, "Survey batches"). Buffer points are
context only and are never written: every point is written once, by its own file.

* **Engine.** Dask distributed: by default a local cluster of `workers` one-thread
  processes (the core count); `scheduler="tcp://host:8786"` runs on an existing
  cluster (its workers must see the input and output folders). Tasks get paths,
  not arrays; the scheduler only carries small results.
* **Buffers.** Tile boxes come from the LAS/LAZ headers without reading a point
  (other formats are read once for it). The default buffer is the method's reach,
  :func:`default_buffer`. Grids are anchored in world coordinates, so tiles share
  one lattice.
* **Denoise** is exact: the mean and deviation of SOR are global, so the tiles'
  distances are reduced once and one threshold applies to all; a tile's buffer
  grows wherever a point's neighbours might lie beyond it.
* **Downsample** is exact: a voxel crossing tiles is written once, by the lowest
  numbered tile with a point in it (inputs in the order given, folders and globs
  sorted).
* **Faults.** A worker that dies is replaced and its tasks rerun (outputs are
  written atomically, so the result is as a clean run's). A file that cannot be
  read is reported as failed; its neighbours finish without its buffer and say
  so. Rerunning skips tiles whose outputs are complete and whose inputs,
  neighbours and parameters are unchanged (``.pcl_rg-batch.json`` in the output
  folder). Ctrl-C stops the cluster and leaves no partial file.
"""

from __future__ import annotations

import os
from collections.abc import Callable, Sequence
from typing import Any

from .._grid_ground import GridGroundParams
from .._statistical_outlier_removal import StatisticalOutlierRemovalParams
from .._tin_ground import TinGroundParams
from .._voxel_grid import VoxelGridParams
from ..io._crs import GIVEN_UNITS
from . import _engine, _plan, _tasks
from ._engine import BatchReport, TileReport

__all__ = [
    "BatchReport",
    "TileReport",
    "default_buffer",
    "denoise",
    "downsample",
    "ground",
    "survey_spacing",
]

#: Starting buffer of denoise, metres; it grows per tile wherever it is too small.
DENOISE_START_BUFFER = 10.0

Inputs = Sequence[str | os.PathLike[str]] | str | os.PathLike[str]


# The most local worker processes per core that `workers` may ask for.
_MOST_WORKERS_PER_CORE = 8


def survey_spacing(inputs: Inputs) -> float:
    """The point spacing :func:`ground` gives the unset lengths of its parameters.

    Parameters
    ----------
    inputs : path, folder or sequence of paths
        The tiles, as :func:`ground` takes them.

    Returns
    -------
    float
        In the tiles' x, y unit (metres unless their coordinate system says
        otherwise; :func:`ground` scales it to metres with the points):
        ``sqrt(sum of the tiles' XY box areas / their number of points)``
        from the files' headers (NaN for a survey without points or area; 1 m is
        then used). Every tile runs with the lengths of this one spacing, so the
        tiles agree; a single call of :func:`pcl_rg.tin_ground` on the merged
        cloud measures :func:`pcl_rg.point_spacing` instead, which differs a
        little: pass ``params.at_spacing(survey_spacing(inputs))`` to it to
        compare. A tile whose own header spacing is more than twice the
        median tile's is left out: its box is mostly empty, as when a stray
        point lies a tile's width away or farther, and one bad point must not
        set the lengths of every tile.

    Examples
    --------
    >>> import tempfile
    >>> from pcl_rg import batch, datasets
    >>> with tempfile.TemporaryDirectory() as folder:
    ...     survey = datasets.synthetic_survey(folder, tiles=(1, 2), tile_size=50.0)
    ...     spacing = batch.survey_spacing(survey.paths)
    >>> 0.4 < spacing < 0.55  # 4 points per m^2 and a few more on walls and crowns
    True
    """
    from ..io import read_extent
    from ._plan import survey_spacing as spacing_of

    paths = _plan.expand_inputs(inputs)  # type: ignore[arg-type]
    extents = [read_extent(path) for path in paths]
    return spacing_of([e for e in extents if e.points and e.xmax >= e.xmin])


def default_buffer(operation: str, params: Any) -> float:
    """The buffer, in metres, that `operation` with `params` uses by default.

    * ground, grid: 3 x the larger block side. A block's seed depends on the size of
      its component, and growth runs across blocks; at 3 blocks at most 0.004 % of
      the labels (one point of samp52, in quadrants) differ from the merged run's
      on any ISPRS sample or the synthetic survey (benchmarks/studies/batch_seams.py).
    * ground, tin: 2 x ``max_building_size``. Seeds come from openings of that
      window, and the TIN reaches across a building's width.
    * denoise: 10 m to start with. It grows until every point's k nearest
      neighbours lie inside, so the result does not depend on it.
    * downsample: one leaf (the larger of x and y). That holds every point of
      every voxel that a tile touches.

    Examples
    --------
    >>> from pcl_rg import GridGroundParams, TinGroundParams
    >>> from pcl_rg.batch import default_buffer
    >>> default_buffer("ground", GridGroundParams()), default_buffer("ground", TinGroundParams())
    (90.0, 80.0)
    """
    if isinstance(params, GridGroundParams):
        return 3.0 * max(params.block_size)
    if isinstance(params, TinGroundParams):
        return 2.0 * params.max_building_size
    if isinstance(params, StatisticalOutlierRemovalParams):
        return DENOISE_START_BUFFER
    if isinstance(params, VoxelGridParams):
        return float(max(params.leaf_size[:2]))
    raise TypeError(f"no batch operation takes {type(params).__name__} ({operation})")


#: The keywords every operation passes on to the engine unchanged.
_ENGINE_OPTIONS = ("buffer", "units", "workers", "scheduler", "progress", "resume", "on_dashboard")


def _engine_options(arguments: dict[str, Any]) -> dict[str, Any]:
    """The engine's keywords out of an operation's ``locals()``."""
    return {name: arguments[name] for name in _ENGINE_OPTIONS}


def _run(
    operation: str,
    params: Any,
    inputs: Inputs,
    out: str | os.PathLike[str],
    *,
    method: str = "grid",
    keep_classes: bool = False,
    buffer: float | None,
    units: str | None,
    workers: int | None,
    scheduler: str | None,
    progress: bool,
    resume: bool,
    on_dashboard: Callable[[str], None] | None = None,
) -> BatchReport:
    if buffer is None:
        buffer = default_buffer(operation, params)
    buffer = float(buffer)
    if not buffer >= 0.0 or buffer == float("inf"):
        raise ValueError(f"buffer must be a finite number >= 0, got {buffer}")
    if isinstance(params, VoxelGridParams) and buffer < max(params.leaf_size[:2]):
        # A thinner buffer would let two tiles each write part of a shared voxel.
        raise ValueError(
            f"buffer must be >= the leaf size ({max(params.leaf_size[:2]):g} m) for "
            f"downsample, got {buffer:g}"
        )
    if workers is not None and (isinstance(workers, bool) or not isinstance(workers, int)):
        raise TypeError(f"workers must be an integer, got {workers!r}")
    if workers is not None and workers < 1:
        raise ValueError(f"workers must be >= 1, got {workers}")
    # Local processes on this machine: far more than its cores only queue for them, and
    # a million of them exhausted memory before the first one started.
    cores = os.cpu_count() or 1
    most = max(_MOST_WORKERS_PER_CORE * cores, 64)
    if workers is not None and workers > most:
        raise ValueError(
            f"workers must be <= {most} (local processes on this machine of {cores} cores), "
            f"got {workers}"
        )
    if isinstance(inputs, (str, os.PathLike)):
        inputs = [inputs]
    if units is not None and units not in GIVEN_UNITS:
        raise ValueError(f"units must be one of {sorted(GIVEN_UNITS)}, got {units!r}")
    job = _tasks.Job(
        operation,
        params,
        buffer,
        scratch="",
        method=method,
        keep_classes=bool(keep_classes),
        units=units,
    )
    return _engine.run(
        job,
        inputs,
        out,
        workers=workers,
        scheduler=scheduler,
        progress=progress,
        resume=resume,
        on_dashboard=on_dashboard,
    )


def ground(
    inputs: Inputs,
    out: str | os.PathLike[str],
    *,
    method: str = "grid",
    params: GridGroundParams | TinGroundParams | None = None,
    keep_classes: bool = False,
    buffer: float | None = None,
    units: str | None = None,
    workers: int | None = None,
    scheduler: str | None = None,
    progress: bool = False,
    resume: bool = True,
    on_dashboard: Callable[[str], None] | None = None,
) -> BatchReport:
    """Classify the ground of every tile of a survey: class 2 ground, 1 other.

    Parameters
    ----------
    inputs : path, or sequence of paths, folders and globs
        LAS/LAZ, PCD, PLY or XYZ text files; a folder stands for its point files.
    out : path
        Output folder (created); each input gives ``out/<its file name>``.
    method : {"grid", "tin"}
        :func:`pcl_rg.grid_ground` or :func:`pcl_rg.tin_ground`.
    params : GridGroundParams or TinGroundParams, optional
        The method's parameters (default: its defaults).
    keep_classes : bool
        Non-ground points keep their class (a vendor's buildings, vegetation,
        water) instead of becoming 1; those of class 0, 1 or 2 become 1.
    buffer : float, optional
        Metres of neighbouring points each tile sees (default
        :func:`default_buffer`).
    units : {"m", "ft", "us-ft"}, optional
        Units of the tiles' x, y and z. Default: what the LAS/LAZ tiles'
        coordinate systems state (they must agree; longitude and latitude are
        refused), else metres. Every length is in metres: the points are scaled
        to metres for the work, and written back in their own units.
    workers : int, optional
        Processes of the local cluster (default: the core count; at most
        ``max(8 x cores, 64)``).
    scheduler : str, optional
        Address of a running Dask scheduler to use instead of a local cluster.
    progress : bool
        Show a progress bar over tiles on stderr.
    resume : bool
        Skip the tiles whose outputs are complete and up to date (default True).
    on_dashboard : callable, optional
        Called with the Dask dashboard's address, when there is one.

    Returns
    -------
    BatchReport
        One :class:`TileReport` per input: status, points, time, errors and the
        files that could not give a buffer.

    Raises
    ------
    ValueError
        No inputs, two inputs with one file name, an output that is an input, an
        input named that is no regular file (a FIFO), a bad buffer or method.

    Warns
    -----
    UserWarning
        For a folder's or glob's entry named like a point file that is no regular
        file (skipped); and each warning a tile's task raised, as
        ``<input's file name>: <message>`` (also in ``TileReport.warnings``).

    Notes
    -----
    A tile is filtered together with the points of its neighbours within
    `buffer` of its box (noise points of classes 7 and 18, NaN points and LAS
    points flagged withheld left out, as ``pcl-rg ground`` leaves them out); only
    its own points are written.

    Examples
    --------
    >>> import tempfile, os
    >>> from pcl_rg import batch, datasets
    >>> with tempfile.TemporaryDirectory() as folder:
    ...     survey = datasets.synthetic_survey(os.path.join(folder, "in"), tiles=(2, 2),
    ...                                        tile_size=60.0)
    ...     report = batch.ground(survey.paths, os.path.join(folder, "out"), workers=1)
    >>> [t.status for t in report.tiles]
    ['done', 'done', 'done', 'done']
    """
    if method not in _tasks.GROUND_METHODS:
        raise ValueError(f"method must be one of {sorted(_tasks.GROUND_METHODS)}, got {method!r}")
    kind = GridGroundParams if method == "grid" else TinGroundParams
    if params is None:
        params = kind()
    if not isinstance(params, kind):
        raise TypeError(f"params must be a {kind.__name__} for method {method!r}")
    return _run(
        "ground",
        params,
        inputs,
        out,
        method=method,
        keep_classes=keep_classes,
        **_engine_options(locals()),
    )


def denoise(
    inputs: Inputs,
    out: str | os.PathLike[str],
    *,
    params: StatisticalOutlierRemovalParams | None = None,
    buffer: float | None = None,
    units: str | None = None,
    workers: int | None = None,
    scheduler: str | None = None,
    progress: bool = False,
    resume: bool = True,
    on_dashboard: Callable[[str], None] | None = None,
) -> BatchReport:
    """Classify statistical outliers of every tile as noise (7), as on the merged cloud.

    Parameters and result as :func:`ground`, with the parameters of
    :func:`pcl_rg.statistical_outlier_removal`. The mean neighbour distances are
    computed per tile with a buffer that grows until they are exact, the global
    mean and deviation once over all tiles, then one threshold for every tile.
    Points beyond float32's reach of the survey's local origin (a record at
    (0, 0, 0) in a UTM survey) are outliers left out of the mean and deviation, as
    in the merged run; up to 1 % of the survey's points may be that far, and more
    fail the tiles that hold them, as the merged run refuses them. The origin is
    the merged run's, found from each tile's sorted coordinates, so the far points
    are the merged run's, and a tile made mostly of bad records keeps its real
    points.

    Examples
    --------
    >>> import tempfile, os
    >>> from pcl_rg import batch, datasets
    >>> with tempfile.TemporaryDirectory() as folder:
    ...     survey = datasets.synthetic_survey(os.path.join(folder, "in"), tiles=(1, 2),
    ...                                        tile_size=60.0)
    ...     report = batch.denoise(survey.paths, os.path.join(folder, "out"), workers=1)
    >>> report.failed
    []
    """
    params = params if params is not None else StatisticalOutlierRemovalParams()
    if not isinstance(params, StatisticalOutlierRemovalParams):
        raise TypeError("params must be a StatisticalOutlierRemovalParams")
    return _run("denoise", params, inputs, out, **_engine_options(locals()))


def downsample(
    inputs: Inputs,
    out: str | os.PathLike[str],
    *,
    params: VoxelGridParams,
    buffer: float | None = None,
    units: str | None = None,
    workers: int | None = None,
    scheduler: str | None = None,
    progress: bool = False,
    resume: bool = True,
    on_dashboard: Callable[[str], None] | None = None,
) -> BatchReport:
    """Replace the points of each voxel by their centroid, tile by tile, seamlessly.

    Parameters and result as :func:`ground`, with the parameters of
    :func:`pcl_rg.voxel_grid` (`params` is required: the leaf size depends on
    the data). The voxels written are those of the merged cloud, each once.

    Examples
    --------
    >>> import tempfile, os
    >>> from pcl_rg import VoxelGridParams, batch, datasets
    >>> with tempfile.TemporaryDirectory() as folder:
    ...     survey = datasets.synthetic_survey(os.path.join(folder, "in"), tiles=(1, 2),
    ...                                        tile_size=60.0)
    ...     report = batch.downsample(survey.paths, os.path.join(folder, "out"),
    ...                               params=VoxelGridParams(leaf_size=2.0), workers=1)
    >>> report.failed
    []
    """
    if not isinstance(params, VoxelGridParams):
        raise TypeError("params must be a VoxelGridParams")
    return _run("downsample", params, inputs, out, **_engine_options(locals()))
