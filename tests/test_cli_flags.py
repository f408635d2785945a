"""The flag engine of the command line on its own (pcl_rg.cli._flags): a throwaway
params dataclass becomes flags and is parsed back. No files, no algorithms."""

from __future__ import annotations

import argparse
from dataclasses import dataclass

import pytest

from pcl_rg._params import check_fields, param, preset
from pcl_rg.cli._flags import (
    CliError,
    Parser,
    add_param_flags,
    add_preset_option,
    params_from_args,
)


@dataclass(frozen=True, kw_only=True, slots=True)
class Toy:
    leaf: tuple[float, float] = param(
        (1.0, 2.0), axes=2, above=0.0, unit="m", help="leaf edge, one value or x,y"
    )
    k: int = param(8, minimum=1, help="neighbours")
    smooth: bool = param(True, help="smooth the result")
    share: float = param(0.5, minimum=0.0, maximum=1.0, unit="%", help="share kept")

    def __post_init__(self) -> None:
        check_fields(self)

    @preset
    def loose(cls) -> Toy:
        return cls(k=3, smooth=False)


def parser() -> tuple[argparse.ArgumentParser, list]:
    p = Parser(prog="toy")
    add_preset_option(p, {"toy": Toy})
    flags = add_param_flags(p, "toy parameters", {"toy": Toy})
    return p, flags


def parse(*argv: str) -> Toy:
    p, flags = parser()
    return params_from_args(p.parse_args(argv), flags, "toy", Toy)


def test_one_flag_per_field_and_bool_pairs():
    p, flags = parser()
    assert [f.flag for f in flags] == ["--leaf", "--k", "--smooth", "--share"]
    options = {o for a in p._actions for o in a.option_strings}
    assert {"--leaf", "--k", "--smooth", "--no-smooth", "--share", "--preset"} <= options


def test_help_has_units_and_defaults():
    text = " ".join(parser()[0].format_help().split())
    assert "leaf edge, one value or x,y [m] (default: 1,2)" in text
    assert "neighbours (default: 8)" in text
    assert "share kept [%] (default: 0.5)" in text  # a % in help text is not a format
    assert "--preset NAME" in text and "(loose)" in text


def test_defaults_are_the_dataclass_defaults():
    assert parse() == Toy()


def test_per_axis_values():
    assert parse("--leaf", "3,4").leaf == (3.0, 4.0)
    assert parse("--leaf", "3").leaf == (3.0, 3.0)  # one value for every axis
    with pytest.raises(CliError, match="expected 1 or 2 comma-separated numbers, got 3"):
        parse("--leaf", "1,2,3")
    with pytest.raises(CliError, match="invalid number in 'x'"):
        parse("--leaf", "x")


def test_bool_flags():
    assert parse("--no-smooth").smooth is False
    assert parse("--smooth").smooth is True


def test_out_of_range_values_name_the_flag():
    with pytest.raises(CliError, match=r"^argument --k: k must be >= 1, got 0"):
        parse("--k", "0")
    with pytest.raises(CliError, match=r"^argument --share: share must be in \[0, 1\]"):
        parse("--share", "1.5")
    with pytest.raises(CliError, match="invalid integer: '2.5'"):
        parse("--k", "2.5")


def test_preset_is_the_base_and_flags_override_fields():
    assert parse("--preset", "loose") == Toy.loose()
    assert parse("--preset", "loose", "--k", "5") == Toy(k=5, smooth=False)
    with pytest.raises(CliError, match=r"unknown preset 'tight' .*\(valid: loose\)"):
        parse("--preset", "tight")
