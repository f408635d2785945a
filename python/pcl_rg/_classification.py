"""How the commands classify a file: ASPRS codes, noise, ground and voxel attributes.

One place for the rules a single-file command and a batch tile both apply, so a tile
of a survey comes out exactly as the single-file command would write it.
"""

from __future__ import annotations

import numpy as np

from .io import PointFile

__all__ = [
    "GROUND",
    "CATEGORY_ATTRIBUTES",
    "MEAN_ATTRIBUTES",
    "PACKED_COLOURS",
    "NEVER_CLASSIFIED",
    "NOISE",
    "NOISE_CLASSES",
    "UNCLASSIFIED",
    "WAVEFORM_ATTRIBUTES",
    "class_array",
    "existing_classes",
    "ground_classes",
    "is_category",
    "no_data_values",
    "noise_classes",
    "noise_mask",
    "not_class_codes",
    "usable_points",
    "valid_points",
    "voxel_attributes",
    "whole_numbers",
    "withheld_mask",
]

# ASPRS classes written by the commands.
UNCLASSIFIED = 1
GROUND = 2
NOISE = 7
NOISE_CLASSES = (7, 18)  # low noise, high noise (LAS 1.4)
NEVER_CLASSIFIED = 0


def valid_points(points: np.ndarray) -> np.ndarray:
    """Rows with finite coordinates (the others are skipped and reported)."""
    return np.isfinite(points).all(axis=1)


def withheld_mask(cloud: PointFile) -> np.ndarray:
    """LAS/LAZ points whose withheld flag is set: "not to be included in processing"
    (LAS 1.4, the classification flags), so left out like noise, keeping their class.
    Only LAS defines the flag: a field of that name in another format is data."""
    flag = cloud.fields.get("withheld") if cloud.format in ("las", "laz") else None
    if flag is None or np.ndim(flag) != 1:
        return np.zeros(len(cloud), bool)
    return np.asarray(flag) != 0


def usable_points(cloud: PointFile) -> np.ndarray:
    """Rows a command works on: finite coordinates and not withheld."""
    return valid_points(cloud.points) & ~withheld_mask(cloud)


def whole_numbers(codes: np.ndarray) -> np.ndarray:
    """Which values of a float column are finite whole numbers, the only class codes."""
    with np.errstate(invalid="ignore"):
        return np.isfinite(codes) & (codes == np.round(codes))


def not_class_codes(codes: np.ndarray, points: np.ndarray) -> str | None:
    """Why a float classification column is not class codes, or None when it is: ASPRS
    classes are whole numbers, and a NaN or 2.7 has no class to keep. Rows whose
    `points` are not finite (PCD's invalid points, NaN in every field) are skipped by
    every command and keep whatever they hold, so they are not checked."""
    if codes.dtype.kind != "f":
        return None
    bad = np.flatnonzero(~whole_numbers(codes) & valid_points(points))
    if not bad.size:
        return None
    rows = ", ".join(f"row {i}: {codes[i]:g}" for i in bad[:3])
    return f"{bad.size} value(s) are not whole numbers ({rows}{', ...' if bad.size > 3 else ''})"


def existing_classes(cloud: PointFile) -> np.ndarray | None:
    """The file's classification as class codes, None when it has none.

    Raises
    ------
    ValueError
        When a float classification holds values that are not whole numbers: what
        class such a point keeps is unknown, so no command guesses.
    """
    codes = cloud.classification
    if codes is None:
        return None
    codes = np.asarray(codes)
    if codes.ndim != 1 or codes.dtype.kind not in "iuf":
        return None
    problem = not_class_codes(codes, cloud.points)
    if problem:
        where = f"{cloud.path!r}: its" if cloud.path else "the"
        raise ValueError(
            f"{where} classification field is not class codes: {problem}; "
            "ASPRS classes are whole numbers from 0 to 255"
        )
    return codes


def class_array(cloud: PointFile, fill: int) -> np.ndarray:
    """A writable classification column: a copy of the file's, in its dtype (whole
    numbers in a float column stay exact), or `fill` as uint8."""
    codes = existing_classes(cloud)
    if codes is None:
        return np.full(len(cloud), fill, dtype=np.uint8)
    return codes.copy()


def noise_mask(codes: np.ndarray | None, n: int) -> np.ndarray:
    """Points already classified as noise (7 low, 18 high): left out, keeping their class."""
    if codes is None:
        return np.zeros(n, bool)
    return np.isin(codes, NOISE_CLASSES)


def noise_classes(cloud: PointFile, valid: np.ndarray, outlier: np.ndarray) -> np.ndarray:
    """The classification after outlier removal: outliers 7, other points keep their class.

    A file without classes gets 1 (0 for points with NaN coordinates); a point of an
    earlier run's noise class that is now an inlier becomes 1 again.
    """
    classes = class_array(cloud, UNCLASSIFIED)
    if existing_classes(cloud) is None:
        classes[~valid] = NEVER_CLASSIFIED
    classes[outlier] = NOISE
    classes[valid & ~outlier & (classes == NOISE)] = UNCLASSIFIED
    return classes


def ground_classes(
    cloud: PointFile, work: np.ndarray, ground: np.ndarray, keep_classes: bool = False
) -> np.ndarray:
    """The classification after ground filtering: 2 ground, 1 other filtered points.

    `work` marks the points that were filtered (valid and not noise) and `ground` holds
    the filter's answer for them; every other point keeps its class (0 when the file
    had none). With `keep_classes`, a filtered point that is not ground keeps its class
    too (a vendor's buildings, vegetation, water), unless that class was ground (2) or
    says it was never classified or unclassified (0, 1): it becomes 1.
    """
    classes = class_array(cloud, NEVER_CLASSIFIED)
    labels = np.where(ground, GROUND, UNCLASSIFIED)
    if keep_classes:
        current = classes[work]
        kept = ~ground & ~np.isin(current, (NEVER_CLASSIFIED, UNCLASSIFIED, GROUND))
        labels = np.where(kept, current, labels)
    classes[work] = labels
    return classes


#: Attributes averaged over a voxel's points (rounded for integer types); every
#: other integer attribute (class, return numbers, flags, ids) is the first point's.
MEAN_ATTRIBUTES = ("intensity", "red", "green", "blue", "nir", "gps_time")


#: Codes and ids, never averaged even when a file stores them as floats (CloudCompare's
#: PLY and PCD classes, mOSD's float labels): the first point's, as their integer kin.
CATEGORY_ATTRIBUTES = ("classification", "label", "return_number", "number_of_returns")


#: LAS's waveform descriptor of a return (point formats 4, 5, 9, 10): which packet, where
#: it is, and where the return lies on it. The seven describe one pulse together, so a
#: voxel takes all of them from its first point; averaged, x_t, y_t, z_t and the return's
#: location described no pulse, beside the first point's packet offset. The point itself
#: moves to the centroid, so the return's place on the pulse (its position plus location
#: times (x_t, y_t, z_t)) is the first point's, up to a leaf size away.
WAVEFORM_ATTRIBUTES = (
    "wavepacket_index",
    "wavepacket_offset",
    "wavepacket_size",
    "return_point_wave_location",
    "x_t",
    "y_t",
    "z_t",
)


def is_category(name: str) -> bool:
    """Whether a field holds codes or ids (CATEGORY_ATTRIBUTES, ``id``, ``*_id``)."""
    key = name.lower()
    return key in CATEGORY_ATTRIBUTES or key == "id" or key.endswith("_id")


def _first_point_of_voxel(name: str) -> bool:
    """Whether a voxel takes the field from its first point: codes, ids and the
    waveform descriptor, whatever their type."""
    return is_category(name) or name.lower() in WAVEFORM_ATTRIBUTES


#: PCL's packed colours: four bytes per point (blue, green, red, alpha or 0) stored in a
#: float32 (``rgb``) or a uint32 (``rgba``); averaged byte by byte, never as one number.
PACKED_COLOURS = ("rgb", "rgba")


def _first_rows(rows: np.ndarray, voxel: np.ndarray, m: int) -> np.ndarray:
    """The least of `rows` in each of `m` voxels (row 0 for a voxel without any)."""
    first = np.full(m, np.iinfo(np.int64).max, dtype=np.int64)
    np.minimum.at(first, voxel, rows)
    return np.where(first == np.iinfo(np.int64).max, 0, first)


def no_data_values(cloud: PointFile) -> dict[str, np.ndarray]:
    """The "no data" value of each LAS extra-bytes field that declares one, per value
    of the field (shape (count,)), as read (its scale and offset applied, in laspy's
    arithmetic); {} for other formats. An unscaled field's keeps laspy's type: a 64-bit
    integer's, in float64, would also match the values next to it."""
    if cloud.format not in ("las", "laz") or cloud.header is None:
        return {}
    values = {}
    for dim in cloud.header.point_format.extra_dimensions:
        if dim.no_data is not None:
            value = np.asarray(dim.no_data)
            if dim.scales is None and dim.offsets is None:
                values[dim.name] = value
                continue
            value = value.astype(np.float64)
            if dim.scales is not None:
                value = value * np.asarray(dim.scales, np.float64)
            if dim.offsets is not None:
                value = value + np.asarray(dim.offsets, np.float64)
            values[dim.name] = value
    return values


def voxel_attributes(
    fields: dict[str, np.ndarray],
    rows: np.ndarray,
    voxel: np.ndarray,
    counts: np.ndarray,
    carried: dict[str, np.ndarray] | None = None,
    no_data: dict[str, np.ndarray] | None = None,
) -> dict[str, np.ndarray]:
    """Per-voxel attributes: mean of float fields and MEAN_ATTRIBUTES, channel means of
    PACKED_COLOURS, else (and for codes, ids and WAVEFORM_ATTRIBUTES) the first point's.

    `carried`, if given, marks per field the rows of `fields` that carry it (a batch's
    buffer from tiles of another point format holds zeros for what they lack): each
    voxel's value then comes from its points that carry the field alone. `no_data`
    (no_data_values) leaves a field's "no data" values out of its means: a voxel with
    no other value gets "no data" (its average with real values was a number that
    means nothing); a field taken from the first point takes it from the first point
    with data.
    """
    no_data = no_data or {}
    m = len(counts)
    everyone = (rows, voxel, counts, _first_rows(rows, voxel, m))
    out = {}
    for name, values in fields.items():
        values = np.asarray(values)
        rows, voxel, counts, first = everyone
        if carried is not None and not carried[name][rows].all():
            keep = carried[name][rows]
            rows, voxel = rows[keep], voxel[keep]
            # A voxel none of whose points carries the field gets 0 (a category, row
            # 0's): never one a caller keeps, since its own points carry every field.
            counts = np.maximum(np.bincount(voxel, minlength=m), 1)
            first = _first_rows(rows, voxel, m)
        if _first_point_of_voxel(name):
            out[name] = _first_with_data(values, rows, voxel, first, no_data.get(name))
        elif name in PACKED_COLOURS and values.ndim == 1 and values.dtype.itemsize == 4:
            channels = np.ascontiguousarray(values[rows]).view(np.uint8).reshape(len(rows), 4)
            sums = np.stack(
                [np.bincount(voxel, weights=channels[:, j], minlength=m) for j in range(4)],
                axis=1,
            )
            mean = np.round(sums / counts[:, None]).astype(np.uint8)
            out[name] = np.ascontiguousarray(mean).view(values.dtype).reshape(m)
        elif values.dtype.kind == "f" or (name in MEAN_ATTRIBUTES and values.dtype.kind in "iu"):
            width = int(np.prod(values.shape[1:]))  # 1 for a column; stays valid at N = 0
            flat = values[rows].reshape(len(rows), width).astype(np.float64)
            if name in no_data and len(no_data[name]) == width:
                mean = _mean_with_no_data(flat, voxel, m, no_data[name])
            else:
                sums = np.stack(
                    [np.bincount(voxel, weights=flat[:, j], minlength=m) for j in range(width)],
                    axis=1,
                )
                mean = sums / counts[:, None]
            if values.dtype.kind in "iu":
                mean = np.round(mean)
            out[name] = mean.reshape((m,) + values.shape[1:]).astype(values.dtype)
        else:
            out[name] = _first_with_data(values, rows, voxel, first, no_data.get(name))
    return out


def _first_with_data(
    values: np.ndarray,
    rows: np.ndarray,
    voxel: np.ndarray,
    first: np.ndarray,
    missing: np.ndarray | None,
) -> np.ndarray:
    """Per voxel, the value of its first point; where a column declares a "no data"
    value (`missing`, one per column) and the first point holds it, that column's value
    of the voxel's first point that holds another, or "no data" where none does."""
    chosen = values[first]
    width = int(np.prod(values.shape[1:]))
    if missing is None or len(missing) != width or not len(rows):
        return chosen
    m = len(first)
    flat = values.reshape(len(values), width)
    out = chosen.reshape(m, width)
    for j in range(width):
        column = flat[rows, j]
        real = ~(np.isnan(column) if np.isnan(missing[j]) else column == missing[j])
        has = np.bincount(voxel[real], minlength=m) > 0
        out[:, j] = np.where(has, flat[_first_rows(rows[real], voxel[real], m), j], out[:, j])
    return out.reshape(chosen.shape)


def _mean_with_no_data(
    flat: np.ndarray, voxel: np.ndarray, m: int, missing: np.ndarray
) -> np.ndarray:
    """Per voxel and column, the mean of the values that are not `missing` (that
    column's "no data"), or `missing` where the voxel has none."""
    mean = np.empty((m, flat.shape[1]))
    for j in range(flat.shape[1]):
        # NaN can be the "no data" too, and equals nothing.
        real = ~(np.isnan(flat[:, j]) if np.isnan(missing[j]) else flat[:, j] == missing[j])
        sums = np.bincount(voxel[real], weights=flat[real, j], minlength=m)
        counts = np.bincount(voxel[real], minlength=m)
        mean[:, j] = np.where(counts > 0, sums / np.maximum(counts, 1), missing[j])
    return mean
