"""LAS waveform data packets on writing: which EVLR holds them, and a template's claim
of packets that the written file does not carry."""

from __future__ import annotations

import warnings

from .._caller import outside_stacklevel


def is_waveform_record(vlr) -> bool:
    """The EVLR of a LAS 1.4 file's waveform data packets."""
    return vlr.user_id == "LASF_Spec" and vlr.record_id == 65535


def claims_packets_in_file(header) -> bool:
    """Whether `header` says its waveform packets are in the file (the internal flag,
    or an offset to them)."""
    internal = header.global_encoding.waveform_data_packets_internal
    return internal or header.start_of_waveform_data_packet_record != 0


def drop_uncarried_waveforms(path: str, header) -> None:
    """Clear a template's claim of waveform packets stored in the file when the packets
    are not among the EVLRs written (LAS 1.3 keeps them after the points, where laspy
    does not read them): the header's offset would point at other bytes. A warning says
    that they are dropped. Packets in an external .wdp file are the reader's business.
    """
    carried = header.evlrs is not None and any(is_waveform_record(v) for v in header.evlrs)
    if header.version.minor < 3 or carried:
        return
    if claims_packets_in_file(header):
        header.global_encoding.waveform_data_packets_internal = False
        header.start_of_waveform_data_packet_record = 0
        warnings.warn(
            f"{path}: the waveform data packets stored in the source LAS file are not "
            "written (only LAS 1.4's waveform EVLR is carried over); the points keep "
            "their wave packet fields, and the header says the file holds no packets",
            UserWarning,
            stacklevel=outside_stacklevel(),
        )


def waveform_record_start(evlrs, first: int) -> int | None:
    """Where the waveform EVLR begins in a file whose EVLRs begin at `first`: each
    EVLR is a 60-byte header and its data, in order."""
    position = first
    for vlr in evlrs:
        if is_waveform_record(vlr):
            return position
        position += 60 + len(vlr.record_data_bytes())
    return None
