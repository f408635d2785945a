"""LAS and LAZ files through laspy (with the lazrs backend for LAZ).

The header is checked against the file size first (:mod:`pcl_rg.io._las_header`),
so that a damaged or hostile header fails fast instead of making laspy loop or
allocate; laspy is imported only when a LAS/LAZ file is read or written.
"""

from __future__ import annotations

import contextlib
import datetime
import math
import warnings
from collections.abc import Iterator
from typing import BinaryIO

import numpy as np

from .._caller import outside_stacklevel
from .._held_signals import HeldSignals, held_signals
from . import _las_extra_bytes as extra_bytes
from . import _las_waveforms as waveforms
from ._atomic import atomic_write
from ._las_header import LasRecord, check_las_header

__all__ = ["las_coordinate_name", "read", "write"]


def _laspy():
    try:
        import laspy
    except ImportError as error:  # pragma: no cover - depends on the environment
        raise ImportError(
            "reading and writing LAS/LAZ needs laspy with lazrs: pip install 'pcl_rg[las]'"
        ) from error
    return laspy


# Points decoded in the first step of a LAZ read; each later step doubles, up to the
# last. A header's point count is so trusted only as far as the data bear it out
# (LAZ sizes bound it only loosely), while large files still go in few big steps.
_LAZ_FIRST_STEP = 1 << 16
_LAZ_LARGEST_STEP = 1 << 22


# Points, fields, the laspy.LasHeader and the (E)VLRs as the file's headers give them.
LasContents = tuple[np.ndarray, dict[str, np.ndarray], object, tuple[LasRecord, ...]]


def read(path: str) -> LasContents:
    """Points, fields, the ``laspy.LasHeader`` and the file's own (E)VLR headers; any
    decoder failure as a ValueError."""
    try:
        return _decode_las(path)
    except OSError as error:
        if error.errno is not None:  # a real I/O error, not a decoder's complaint
            raise
        raise _bad_las(path, error) from None
    except ValueError as error:
        if str(error).startswith(("invalid LAS/LAZ file", "invalid LAS file")):
            raise
        raise _bad_las(path, error) from None
    except Exception as error:  # laspy, lazrs and NumPy raise many kinds on corrupt data
        raise _bad_las(path, error) from None
    except BaseException as error:
        # A Rust panic inside lazrs reaches Python as pyo3's PanicException, which
        # derives from BaseException so that `except Exception` lets it through: on a
        # damaged file it is the decoder's complaint all the same.
        if type(error).__name__ != "PanicException":
            raise
        raise _bad_las(path, error) from None


def _decode_las(path: str) -> LasContents:
    laspy = _laspy()
    with open(path, "rb") as stream:
        facts = check_las_header(path, stream)
        if facts.spare_records:
            warnings.warn(
                f"LAS file {path!r}: the header counts {facts.point_count} points, but the "
                f"file holds {'at least ' if facts.compressed else 'room for '}"
                f"{facts.spare_records} more records after them; only the counted points "
                "are read (is the header's point count damaged?)",
                stacklevel=outside_stacklevel(),
            )
        stream.seek(0)
        parallel = facts.parallel_decompression
        backend = laspy.LazBackend.LazrsParallel if parallel else laspy.LazBackend.Lazrs
        with laspy.open(stream, closefd=False, laz_backend=backend) as reader:
            header = reader.header
            extra_bytes.check_extra_bytes(path, header)
            extra_bytes.restore_no_data(header)
            chunks = []
            # Uncompressed: the size check made the count trustworthy, one step.
            step = _LAZ_FIRST_STEP if facts.compressed else max(facts.point_count, 1)
            while reader.points_read < facts.point_count:
                chunk = reader.read_points(min(step, facts.point_count - reader.points_read))
                if len(chunk) == 0:
                    break
                chunks.append(chunk.array)
                step = min(2 * step, _LAZ_LARGEST_STEP)
    read = sum(len(c) for c in chunks)
    if read != facts.point_count:
        raise ValueError(
            f"invalid LAS file {path!r}: header says {facts.point_count} points, "
            f"the file holds {read} (truncated?)"
        )
    dtype = header.point_format.dtype()
    array = np.concatenate(chunks) if chunks else np.zeros(0, dtype=dtype)
    record = laspy.ScaleAwarePointRecord(
        array, header.point_format, scales=header.scales, offsets=header.offsets
    )
    points = np.column_stack([np.asarray(record.x), np.asarray(record.y), np.asarray(record.z)])
    _warn_outside_box(path, points, header)
    fields = {}
    for dim in header.point_format.dimensions:
        if dim.name in ("X", "Y", "Z"):
            continue
        fields[dim.name] = np.array(record[dim.name])
    return points.astype(np.float64), fields, header, facts.records


def _warn_outside_box(path: str, points: np.ndarray, header) -> None:
    """Warn when points lie outside the header's box: a stale header, or a damaged LAZ
    file (a wrong chunk size or chunk table) whose decoder read on into garbage, which
    lands far off. A box all 0 (never filled in) is no box, and one rounded (to 0.01
    with a scale of 0.001, say) or a little stale passes: 1 % of its size, 1 cm and 1.5
    steps of the scale. (laspy swaps a negative scale's bounds.)"""
    low = np.minimum(header.mins, header.maxs)
    high = np.maximum(header.mins, header.maxs)
    if not low.any() and not high.any():
        return
    slack = 1.5 * np.abs(header.scales) + 0.01 * (high - low) + 0.01
    outside = ((points < low - slack) | (points > high + slack)).any(axis=1)
    if outside.any():
        warnings.warn(
            f"LAS file {path!r}: {int(outside.sum())} of {len(points)} points lie outside "
            f"the header's box ({low.tolist()} to {high.tolist()}): is the "
            "file damaged, or its header's box stale?",
            stacklevel=outside_stacklevel(),
        )


def _bad_las(path: str, error: BaseException) -> ValueError:
    detail = str(error) or type(error).__name__
    if detail.isdigit():  # laspy's UnknownExtraType(31): a bare "31" said nothing
        detail = f"{type(error).__name__} {detail} (a value the LAS format does not define)"
    elif isinstance(error, UnicodeDecodeError):
        what = "a name laspy reads as text (a VLR's user id, an extra bytes field's)"
        detail = f"{what} is not UTF-8: {detail}"
    elif "failed to fill whole buffer" in detail:  # lazrs's, of data that end too soon
        detail += " (the compressed points end before all are decoded: damaged or cut short)"
    return ValueError(f"invalid LAS/LAZ file {path!r}: {detail}")


def _new_las_header(laspy, xyz: np.ndarray, names: set[str]):
    point_format = 6
    if {"red", "green", "blue"} <= names:
        point_format = 8 if "nir" in names else 7
    header = laspy.LasHeader(version="1.4", point_format=point_format)
    if len(xyz):
        lower = np.floor(xyz.min(axis=0))
        extent = xyz.max(axis=0) - lower
    else:
        lower = np.zeros(3)
        extent = np.zeros(3)
    scale = np.full(3, 0.001)
    # Stored integers are int32: coarsen the scale by 10 until the extent fits.
    while np.any(extent / scale > 2**31 - 2):
        scale = np.where(extent / scale > 2**31 - 2, scale * 10, scale)
    header.offsets = lower
    header.scales = scale
    return header


def _check_scales_and_offsets(xyz: np.ndarray, header, new: bool) -> None:
    """ValueError unless every int32 stored with `header`'s scales and offsets reads
    back as a finite coordinate, as the reader demands (|scale| * 2**31 + |offset|
    within float64); `new`: the header was made for `xyz` by _new_las_header."""
    for i, axis in enumerate("xyz"):
        scale, offset = float(header.scales[i]), float(header.offsets[i])
        if scale != 0.0 and math.isfinite(abs(scale) * 2.0**31 + abs(offset)):
            continue
        span = ""
        if len(xyz):
            span = f" from {float(xyz[:, i].min())!r} to {float(xyz[:, i].max())!r}"
        hint = (
            "; coordinates within +-1e307 always fit, write PCD, PLY or XYZ for larger ones"
            if new
            else ""
        )
        raise ValueError(
            f"{axis} coordinates{span} cannot be written to LAS with scale {scale!r} and "
            f"offset {offset!r}: LAS stores a coordinate as an int32 times the scale plus "
            "the offset, and |scale| * 2**31 + |offset| must stay below the float64 "
            f"maximum 1.8e308{hint}"
        )


def las_coordinate_name(key: str) -> bool:
    """Whether field `key` would be taken for a coordinate in a LAS file: laspy's
    dimensions X, Y and Z are the stored integers, x, y and z the scaled ones."""
    return key.strip().lower() in ("x", "y", "z")


def write(
    path: str,
    xyz: np.ndarray,
    columns: dict[str, np.ndarray],
    template,
    compress: bool,
    source: str = "",
) -> None:
    """write_points for LAS/LAZ: the layout of `template` (a LasHeader), if any.

    laspy's and lazrs's refusals of a header come back as ValueError naming
    `path` and `source` (where the template came from).
    """
    try:
        _write_las(path, xyz, columns, template, compress)
    except (OSError, ValueError, TypeError):
        raise
    except Exception as error:  # laspy or lazrs refusing the template's header
        raise ValueError(f"cannot write {path!r}{source}: {error}") from None


def _write_las(
    path: str, xyz: np.ndarray, columns: dict[str, np.ndarray], template, compress: bool
) -> None:
    import copy

    laspy = _laspy()
    finite = np.isfinite(xyz).all(axis=1)
    if not finite.all():
        raise ValueError(
            f"points has {int((~finite).sum())} row(s) with NaN or Inf coordinates, which "
            "LAS cannot store; drop them or write PCD, PLY or XYZ"
        )
    if template is not None:
        header = copy.deepcopy(template)
        if (header.version.major, header.version.minor) == (1, 0):
            # laspy reads LAS 1.0 but writes 1.1 and later only. 1.2 has 1.0's point
            # formats (0 and 1) and header fields, with what 1.0 kept reserved.
            header.version = laspy.header.Version(1, 2)
        # A COPC file is LAZ with an octree index of its points in a "copc" VLR and
        # EVLR. laspy writes no COPC, and the index would not describe these points:
        # the output is plain LAS/LAZ (it failed after the work, even as .las).
        lists = laspy.vlrs.vlrlist.VLRList
        header.vlrs = lists(v for v in header.vlrs if v.user_id != "copc")
        if header.evlrs is not None:
            header.evlrs = lists(v for v in header.evlrs if v.user_id != "copc")
        waveforms.drop_uncarried_waveforms(path, header)
    else:
        with np.errstate(over="ignore", invalid="ignore"):  # checked right after
            header = _new_las_header(laspy, xyz, set(columns))
    _check_scales_and_offsets(xyz, header, template is None)
    # The header describes this file: the program that wrote it, and when (a template's
    # named another program and its day). The system identifier, the hardware that
    # acquired the points, is kept.
    from .. import __version__

    header.generating_software = f"pcl_rg {__version__}"
    header.creation_date = datetime.datetime.now(datetime.timezone.utc).date()
    standard = {d.name: d for d in header.point_format.dimensions}
    new_dims = []
    for key, array in columns.items():
        if las_coordinate_name(key):
            raise ValueError(
                f"fields[{key!r}]: LAS names its coordinates X, Y and Z in any case, so no "
                "field can have that name; rename it, or write PLY, PCD or XYZ"
            )
        if key in standard:
            continue
        if key in extra_bytes.laspy_aliases():  # (laspy would read them as others)
            raise ValueError(f"fields[{key!r}]: laspy reads this name as another; rename it")
        array = np.asarray(array)
        base = np.dtype(np.uint8) if array.dtype == np.bool_ else array.dtype
        if base.kind == "f" and base.itemsize < 4:
            base = np.dtype(np.float32)
        if array.ndim == 2 and array.shape[1] not in (1, 2, 3):
            raise ValueError(
                f"fields[{key!r}] has {array.shape[1]} values per point; LAS extra bytes "
                "hold 1, 2 or 3"
            )
        if len(key.encode("utf-8")) > 32:  # the extra-bytes record's name field
            raise ValueError(
                f"fields[{key!r}]: a LAS extra-bytes name holds at most 32 bytes, this one "
                f"{len(key.encode('utf-8'))}; rename the field, or write PLY or PCD"
            )
        kind = base.newbyteorder("<").str.lstrip("<|=")
        type_str = kind if array.ndim == 1 or array.shape[1] == 1 else f"{array.shape[1]}{kind}"
        new_dims.append(laspy.ExtraBytesParams(name=key, type=type_str))
    if new_dims:
        try:
            header.add_extra_dims(new_dims)
        except Exception as error:
            raise ValueError(
                f"cannot add extra-bytes dimensions to the LAS header: {error}"
            ) from None
        standard = {d.name: d for d in header.point_format.dimensions}

    n = len(xyz)
    record = laspy.ScaleAwarePointRecord.zeros(n, header=header)
    scales = np.asarray(header.scales, dtype=np.float64)
    offsets = np.asarray(header.offsets, dtype=np.float64)
    for i, axis in enumerate("XYZ"):
        with np.errstate(over="ignore"):  # inf is beyond int32 all the same
            stored = np.round((xyz[:, i] - offsets[i]) / scales[i])
        if n and (stored.min() < -(2**31) or stored.max() > 2**31 - 1):
            raise ValueError(
                f"{'xyz'[i]} coordinates from {xyz[:, i].min()} to {xyz[:, i].max()} do not fit "
                f"LAS int32 storage with scale {scales[i]} and offset {offsets[i]}"
            )
        record[axis] = stored.astype(np.int32)
    for key, array in columns.items():
        dim = standard[key]
        values = np.asarray(array)
        if values.dtype == np.bool_:
            values = values.astype(np.uint8)
        if values.ndim == 2 and values.shape[1] == 1:
            values = values[:, 0]
        if n and dim.kind != laspy.DimensionKind.FloatingPoint and not dim.is_scaled:
            if values.dtype.kind == "f":
                if not np.array_equal(values, np.round(values)):
                    raise ValueError(
                        f"fields[{key!r}] holds fractional values but LAS stores {key} as integers"
                    )
            low, high = values.min(), values.max()
            lowest, highest = _integer_range(dim)
            if low < lowest or high > highest:
                raise ValueError(
                    f"fields[{key!r}] has values from {low} to {high}, outside the range "
                    f"[{lowest}, {highest}] of LAS point format {header.point_format.id}"
                )
            values = values.astype(np.int64)
        if dim.is_scaled:
            scale = 1.0 if dim.scales is None else np.asarray(dim.scales, np.float64)
            offset = 0.0 if dim.offsets is None else np.asarray(dim.offsets, np.float64)
        if dim.kind == laspy.DimensionKind.FloatingPoint and dim.is_scaled:
            # laspy rounds the stored value of a scaled dimension to a whole number, as
            # integers need: a float one (some programs flag theirs with scale 1) would
            # lose its fractions. Stored as (value - offset) / scale, unrounded.
            record.array[key] = (values - offset) / scale
            continue
        if dim.is_scaled and values.ndim == 2:
            # laspy's range check of a scaled dimension of several values compares the
            # largest of them with each value's own limit: values of different scales
            # (or offsets) were refused. Stored per value, as laspy stores one.
            with np.errstate(over="ignore", invalid="ignore"):
                stored = np.round((values - offset) / scale)
            limits = np.iinfo(record.array.dtype.fields[key][0].base)
            if n and not (np.isfinite(stored).all() and limits.min <= stored.min()
                          and stored.max() <= limits.max):  # fmt: skip
                raise ValueError(
                    f"fields[{key!r}] cannot be stored in LAS: its values do not fit "
                    f"{limits.dtype} after its scales {scale} and offsets {offset}"
                )
            record.array[key] = stored
            continue
        try:
            record[key] = values
        except (OverflowError, ValueError) as error:
            raise ValueError(f"fields[{key!r}] cannot be stored in LAS: {error}") from None
    las = laspy.LasData(header=header, points=record)
    if compress and header.point_format.id in (9, 10) and n:
        channels = np.asarray(record["scanner_channel"])
        if (channels != channels[0]).any():
            # lazrs 0.8 compresses such points with wrong wave packet fields (offset,
            # size, return point location, x_t, y_t, z_t) and reports no error.
            raise ValueError(
                f"LAZ cannot hold point format {header.point_format.id} with more than one "
                "scanner channel here: the LAZ compressor (lazrs) corrupts their wave packet "
                "fields; write LAS (.las) instead"
            )

    def write_data(stream: BinaryIO) -> None:
        recorder = _RecordingStream(stream)
        with recorder.interrupts_recorded():
            _stream_las(laspy, recorder, las, compress)

    atomic_write(path, write_data)


def _stream_las(laspy, recorder: _RecordingStream, las, compress: bool) -> None:
    """The header, points and EVLRs of `las` through `recorder`."""
    try:
        # The header's text fields (system identifier, VLR descriptions, ...) are
        # ASCII by the specification, but files in the wild hold other bytes, which
        # laspy reads as they are: a template's are written back as they came, and
        # a character that ASCII cannot encode becomes "?" ("replace"), rather than
        # the whole write failing on a descriptive field.
        extra_bytes.keep_min_max_computable(las.header, las.points.array)
        with laspy.LasWriter(
            recorder, las.header, do_compress=compress, closefd=False, encoding_errors="replace"
        ) as writer:
            writer.write_points(las.points)
            if las.header.version.minor >= 4 and las.evlrs is not None:
                writer.write_evlrs(_LenientTexts(las.evlrs))
                # The waveform packets moved with their EVLR: the header points at it
                # (written by close(), which writes the header again).
                start = waveforms.waveform_record_start(
                    las.evlrs, writer.header.start_of_first_evlr
                )
                # Only where the template said its packets were in the file: with the
                # external flag, a non-zero offset would contradict it.
                if start is not None and waveforms.claims_packets_in_file(las.header):
                    writer.header.start_of_waveform_data_packet_record = start
    except Exception:
        # lazrs turns an exception of the stream (e.g. ENOSPC) into its own
        # LazrsError; surface the original.
        if recorder.error is not None:
            raise recorder.error from None
        raise
    if recorder.error is not None:
        raise recorder.error


class _LenientTexts:
    """A list of EVLRs written with the header's "replace" for their text fields.

    laspy's LasWriter.write_evlrs writes them with strict ASCII, whatever the writer
    was given; this wrapper is the one place that passes the writer's choice on.
    """

    def __init__(self, vlrs) -> None:
        self._vlrs = vlrs

    def __len__(self) -> int:
        return len(self._vlrs)

    def write_to(self, stream: BinaryIO, as_extended: bool = False, **_: object) -> int:
        return self._vlrs.write_to(stream, as_extended=as_extended, encoding_errors="replace")


def _integer_range(dim) -> tuple[int, int]:
    """The values an integer or bit-field LAS dimension can store.

    laspy's own dim.min/max fail for a dimension of several values per point, such as
    extra bytes of 3 x int16 or the 4 x uint8 it makes of undocumented extra bytes (a
    sub-array dtype, kind 'V'); each value has the range of the element type.
    """
    type_str = dim.type_str()
    if type_str is None:  # a bit field
        return int(dim.min), int(dim.max)
    info = np.iinfo(np.dtype(type_str).base)
    return int(info.min), int(info.max)


class _RecordingStream:
    """A binary stream that remembers the first exception its write() raised."""

    def __init__(self, stream: BinaryIO) -> None:
        self._stream = stream
        self.error: BaseException | None = None
        self._held = HeldSignals()  # a signal's handler, held back to the next write

    def write(self, data) -> int:
        try:
            self._held.run_pending()
            return self._stream.write(data)
        except BaseException as error:
            if self.error is None:
                self.error = error
            raise

    @contextlib.contextmanager
    def interrupts_recorded(self) -> Iterator[None]:
        """Ctrl-C (SIGINT) or SIGTERM while lazrs writes, as an exception of the write.

        Python raises KeyboardInterrupt at whatever Python code runs next, and when that
        is a call lazrs makes (this stream's write, before its try), lazrs reports its
        own "failed to call write" and the interrupt is lost. So, in the main thread
        with Python's own SIGINT handler in place, the signal only sets a flag here: the
        next write raises KeyboardInterrupt, recorded like any error of the stream, and
        an interrupt after the last write is raised at the end. A SIGTERM handler set
        in Python (pcl-rg's raises like Ctrl-C) is held back and run the same way.
        """
        with held_signals() as self._held:
            yield
        self._held.run_pending()

    def __getattr__(self, name: str):
        return getattr(self._stream, name)
