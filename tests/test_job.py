"""Job-file validation: defaults, units, and one clear line per mistake."""

from __future__ import annotations

import tomllib
from pathlib import Path

import pytest

from fabpanel import InputError, Job
from fabpanel.units import parse_quantity

TEMPLATES = Path(__file__).resolve().parents[1] / "templates"


def test_defaults_are_complete_and_in_internal_units():
    job = Job.from_dict({})
    assert job.sandwich.sheet_thickness == 3.0
    assert job.cutting.plate_length == 3000.0 and job.cutting.plate_width == 1500.0
    assert job.material.E == pytest.approx(210_000.0)          # MPa
    assert job.material.density == pytest.approx(7.85e-6)      # kg/mm3
    assert job.loads.snow == pytest.approx(0.56e-3)            # N/mm2
    assert job.loads.buckling_knockdown == pytest.approx(1 / 6)


@pytest.mark.parametrize("text, dimension, expected", [
    ("3 mm", "length", 3.0), ("1.2 m", "length", 1200.0), ("30cm", "length", 300.0),
    ("0.56 kN/m2", "pressure", 0.56e-3), ("210 GPa", "stress", 210e3),
    ("7850 kg/m3", "density", 7.85e-6), ("2 min", "time", 120.0)])
def test_quantities_convert_to_internal_units(text, dimension, expected):
    assert parse_quantity(text, dimension) == pytest.approx(expected)


def test_round_trip_through_to_dict():
    job = Job.from_dict({"sandwich": {"rib_height": "0.2 m"}, "cutting": {"nest_time": "1 min"}})
    again = Job.from_dict(job.to_dict())
    assert again.sandwich.rib_height == 200.0 and again.cutting.nest_time == 60.0
    assert again.to_dict() == job.to_dict()


@pytest.mark.parametrize("data, fragment", [
    ({"sandwich": {"rib_heigth": "3 mm"}}, "unknown key [sandwich] rib_heigth; allowed here:"),
    ({"loads2": {}}, "unknown section [loads2]"),
    ({"sandwich": {"sheet_thickness": 3}}, "has no unit"),
    ({"sandwich": {"sheet_thickness": "3 ft"}}, "unit 'ft' is not a length unit; use one of"),
    ({"sandwich": {"sheet_thickness": "0 mm"}}, "[sandwich] sheet_thickness: '0 mm' is out of"),
    ({"cutting": {"plate_width": "-1500 mm"}}, "[cutting] plate_width"),
    ({"panelize": {"panel_size": "0 m"}}, "[panelize] panel_size"),
    ({"panelize": {"method": "voronoi"}}, "'voronoi' is not allowed"),
    ({"cutting": {"kerf": "5 mm", "part_spacing": "2 mm"}}, "at least the kerf"),
    ({"input": {"units": "inch"}}, "[input] units"),
])
def test_mistakes_give_one_line_naming_the_key(data, fragment):
    with pytest.raises(InputError) as caught:
        Job.from_dict(data, source="job.toml")
    message = str(caught.value)
    assert fragment in message
    assert message.startswith("job.toml: ")
    assert "\n" not in message


def test_bad_toml_names_the_file(tmp_path):
    path = tmp_path / "job.toml"
    path.write_text("[sandwich\nrib_height = 3")
    with pytest.raises(InputError, match="job.toml: not valid TOML"):
        Job.from_toml(path)


@pytest.mark.parametrize("template", sorted(p.name for p in TEMPLATES.glob("*.toml")))
def test_templates_are_valid_jobs(template):
    data = tomllib.loads((TEMPLATES / template).read_text())
    Job.from_dict(data)


def test_required_templates_exist():
    names = {p.stem for p in TEMPLATES.glob("*.toml")}
    assert {"sandwich-pavilion", "cladding", "barrel-vault"} <= names


def test_replace_returns_a_new_validated_job():
    job = Job.from_dict({})
    smaller = job.replace(panelize={"panel_size": "1 m"})
    assert smaller.panelize.panel_size == 1000.0 and job.panelize.panel_size == 1200.0
    with pytest.raises(InputError):
        job.replace(panelize={"panel_size": "big"})


def test_job_from_sections_like_the_toml():
    job = Job(input={"path": "vault.obj", "units": "m"}, sandwich={"rib_height": "200 mm"})
    assert job.sandwich.rib_height == 200.0 and job.input.units == "m"
    assert Job.from_dict(job.to_dict()).to_dict() == job.to_dict()
    with pytest.raises(InputError, match="rib_heigth"):
        Job(sandwich={"rib_heigth": "2 mm"})
    with pytest.raises(AttributeError):
        job.base_dir = Path("/")
