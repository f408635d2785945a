"""The extra-bytes records' checks and repairs around laspy: names and scales that
laspy would read wrongly, and the "no data" values that it loses or trips over."""

from __future__ import annotations

import warnings
from collections.abc import Iterator

import numpy as np

from .._caller import outside_stacklevel


def _declaring_no_data(header) -> Iterator:
    """The records of `header`'s Extra Bytes VLR that declare a "no data" value."""
    for vlr in header.vlrs:
        for record in getattr(vlr, "extra_bytes_structs", ()):
            # Type 0 is untyped bytes: no value to compare with.
            if record.data_type != 0 and record.no_data is not None:
                yield record


def restore_no_data(header) -> None:
    """Give `header`'s extra-bytes dimensions the "no data" values that their Extra
    Bytes VLR declares. laspy reads them into that VLR only, and rebuilds the VLR from
    the dimensions when it writes: a file written back in its layout lost them, and
    its "no data" values then read as real ones."""
    declared = {record.format_name(): record.no_data for record in _declaring_no_data(header)}
    dimensions = header.point_format.dimensions
    for i, dim in enumerate(dimensions):
        if not dim.is_standard and dim.no_data is None and dim.name in declared:
            dimensions[i] = dim._replace(no_data=declared[dim.name])


def check_extra_bytes(path: str, header) -> None:
    """ValueError for an extra-bytes dimension whose scale is 0 or whose scale or offset
    is not finite: its values would all read as one number (0 for a scale of 0), and a
    write back would divide by that scale; or whose name laspy resolves to another
    field (x, y, z, a flag packed in a byte, an old laspy alias), whose values came
    back as that field's."""
    from laspy.point.record import PackedPointRecord
    from laspy.vlrs.known import ExtraBytesVlr

    for vlr in header.vlrs:
        if (vlr.user_id, vlr.record_id) == ("LASF_Spec", 4) and not isinstance(vlr, ExtraBytesVlr):
            # laspy keeps a record it cannot parse as raw bytes, and the points' extra
            # bytes then come as one unnamed field: say so rather than lose the names.
            raw = "ExtraBytes" in header.point_format.dimension_names
            warnings.warn(
                f"LAS file {path!r}: its Extra Bytes VLR ({len(vlr.record_data)} bytes) is "
                "not a whole number of 192-byte records; "
                + (
                    "the extra bytes of each point are read as one raw field, "
                    "'ExtraBytes', without their names and types"
                    if raw
                    else "it is ignored (the points have no extra bytes)"
                ),
                stacklevel=outside_stacklevel(),
            )
    taken = {"x", "y", "z", *laspy_aliases()}
    taken |= set(PackedPointRecord.zeros(0, header.point_format).sub_fields_dict)
    for dim in header.point_format.extra_dimensions:
        if dim.name in taken:
            raise ValueError(
                f"invalid LAS file {path!r}: extra bytes dimension {dim.name!r} has the name "
                "of a standard field, which laspy reads in its place"
            )
        for kind, values in (("scale", dim.scales), ("offset", dim.offsets)):
            if values is None:
                continue
            values = np.atleast_1d(np.asarray(values, dtype=np.float64))
            if not np.isfinite(values).all() or (kind == "scale" and (values == 0).any()):
                shown = values.tolist() if len(values) > 1 else values[0].item()
                raise ValueError(
                    f"invalid LAS file {path!r}: extra bytes dimension {dim.name!r} has "
                    f"{kind} {shown!r}; its values cannot be read back"
                )


def keep_min_max_computable(header, records) -> None:
    """Stop laspy from computing the minimum and maximum of an extra-bytes field that
    holds nothing but its "no data" value in some position (`records`: the raw point
    records to write): laspy 2.7 then takes the minimum of nothing and fails the write.
    The Extra Bytes VLR then states no minimum or maximum for it, as LAS allows."""
    n = len(records)
    for record in _declaring_no_data(header) if n else ():
        name = record.format_name()
        if name not in (records.dtype.names or ()):
            continue
        raw = np.asarray(records[name]).reshape(n, -1)
        if (raw == np.asarray(record.no_data)[: raw.shape[1]]).all(axis=0).any():
            record.options &= ~(record.MIN_BIT_MASK | record.MAX_BIT_MASK)


def laspy_aliases() -> dict[str, str]:
    """The old names laspy still reads as standard fields (return_num: return_number)."""
    from laspy.point.dims import OLD_LASPY_NAMES

    return OLD_LASPY_NAMES
