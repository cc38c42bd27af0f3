"""Quantities: bare numbers, finiteness after the unit scaling, lengths from the command line."""

from __future__ import annotations

import pytest

from fabpanel import InputError
from fabpanel.units import as_written, format_like, length_option, parse_quantity


@pytest.mark.parametrize(
    "text, expected",
    [("1e308 mm", 1e308), ("0.5e3 mm", 500.0), ("1.0 m", 1000.0), (".5 cm", 5.0), ("10m", 10000.0)],
)
def test_numbers_and_units_are_split_right(text, expected):
    assert parse_quantity(text, "length") == pytest.approx(expected)
    assert parse_quantity("0.56 kN/m²", "pressure") == pytest.approx(0.56e-3)


@pytest.mark.parametrize("text", ["1e308 m", "1e306 km", "2e305 kN/mm2"])
def test_a_quantity_must_be_finite_after_the_scaling(text):
    dimension = "stress" if "kN" in text else "length"
    with pytest.raises(InputError) as caught:
        parse_quantity(text, dimension, "[panelize] panel_size")
    message = str(caught.value)
    if "km" in text:
        assert 'unit "km"' in message
    else:
        assert message == (
            f'[panelize] panel_size: "{text}" is too large: not a finite number '
            f"in {'MPa' if dimension == 'stress' else 'mm'}; write a realistic "
            f"{dimension}"
        )


@pytest.mark.parametrize("value", ["1.0", "1.2", " 1200 ", 1.2, 1200])
def test_a_bare_number_is_a_number_without_unit(value):
    # before: "1.0" split as 1. + unit "0" ("unit '0' is not a length unit")
    with pytest.raises(InputError, match="has no unit; units are explicit in a job") as caught:
        parse_quantity(value, "length", "[panelize] panel_size")
    written = str(value).strip()
    assert f'"{written} mm" or "{written} m"' in str(caught.value)


@pytest.mark.parametrize(
    "text, units, quantity",
    [
        ("1.0", "m", "1.0 m"),
        ("1.2", "m", "1.2 m"),
        ("1200", "mm", "1200 mm"),
        (" 120 ", "cm", "120 cm"),
    ],
)
def test_a_bare_length_option_is_read_in_the_input_units(text, units, quantity):
    got, note = length_option(text, units, "--panel-size")
    assert got == quantity
    assert note == f"--panel-size {text.strip()} has no unit: read as {quantity}, the input's units"
    assert parse_quantity(got, "length") > 0


@pytest.mark.parametrize("text", ["1.2 m", "1200mm", "120 cm"])
def test_a_length_option_with_its_unit_is_kept(text):
    assert length_option(text, "m") == (text, None)
    assert length_option(text, None) == (text, None)


def test_a_bare_length_option_without_input_units_asks_for_a_unit():
    with pytest.raises(InputError, match=r'--panel-size 1.2 has no unit .* "1.2 m"'):
        length_option("1.2", None)


@pytest.mark.parametrize(
    "text, fragment",
    [
        ("1.2 ft", 'unit "ft" in "1.2 ft" is not a length unit'),
        ("big", 'cannot read "big"'),
        ("nan", 'cannot read "nan"'),
        ("1e308 m", "too large"),
    ],
)
def test_a_wrong_length_option_names_the_option(text, fragment):
    with pytest.raises(InputError) as caught:
        length_option(text, "m", "--panel-size")
    assert str(caught.value).startswith("--panel-size: ") and fragment in str(caught.value)


def test_values_are_quoted_as_written_in_toml():
    assert as_written("5 m") == '"5 m"'
    assert as_written([float("nan"), 0]) == "[nan, 0]"
    assert as_written(True) == "true"
    assert format_like(1480.0, "1.5 m") == "1.48 m"
    assert format_like(0.0, "-2 kN/m2") == "0 kN/m2"
    assert format_like(1.0, 3) is None and format_like(1.0, "3 ft") is None
