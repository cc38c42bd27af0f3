"""Job-file validation: defaults, units, and one clear line per mistake."""

from __future__ import annotations

import tomllib
from pathlib import Path

import pytest

from fabpanel import InputError, Job
from fabpanel.units import parse_quantity

ROOT = Path(__file__).resolve().parents[1]
TEMPLATES = ROOT / "fabpanel" / "templates"
#: every job file the repository ships: none may be refused by the rules
JOB_FILES = sorted(
    {
        path
        for pattern in ("examples", "templates", "fabpanel/templates", "fabpanel/examples")
        for path in ROOT.glob(f"{pattern}/*.toml")
    }
)
NAN, INF = float("nan"), float("inf")


def test_defaults_are_complete_and_in_internal_units():
    job = Job.from_dict({})
    assert job.sandwich.sheet_thickness == 3.0
    assert job.cutting.plate_length == 3000.0 and job.cutting.plate_width == 1500.0
    assert job.material.E == pytest.approx(210_000.0)  # MPa
    assert job.material.density == pytest.approx(7.85e-6)  # kg/mm3
    assert job.loads.snow == pytest.approx(0.56e-3)  # N/mm2
    assert job.loads.buckling_knockdown == pytest.approx(1 / 6)


@pytest.mark.parametrize(
    "text, dimension, expected",
    [
        ("3 mm", "length", 3.0),
        ("1.2 m", "length", 1200.0),
        ("30cm", "length", 300.0),
        ("0.56 kN/m2", "pressure", 0.56e-3),
        ("210 GPa", "stress", 210e3),
        ("7850 kg/m3", "density", 7.85e-6),
        ("2 min", "time", 120.0),
    ],
)
def test_quantities_convert_to_internal_units(text, dimension, expected):
    assert parse_quantity(text, dimension) == pytest.approx(expected)


def test_round_trip_through_to_dict():
    job = Job.from_dict({"sandwich": {"rib_height": "0.2 m"}, "cutting": {"nest_time": "1 min"}})
    again = Job.from_dict(job.to_dict())
    assert again.sandwich.rib_height == 200.0 and again.cutting.nest_time == 60.0
    assert again.to_dict() == job.to_dict()


@pytest.mark.parametrize(
    "data, fragment",
    [
        (
            {"sandwich": {"rib_heigth": "3 mm"}},
            "unknown key [sandwich] rib_heigth (did you mean rib_height?); allowed here:",
        ),
        ({"sandwich": {"zzz": "3 mm"}}, "unknown key [sandwich] zzz; allowed here:"),
        ({"panelise": {}}, "unknown section [panelise] (did you mean panelize?)"),
        ({"loads2": {}}, "unknown section [loads2]"),
        ({"sandwich": {"sheet_thickness": 3}}, "has no unit"),
        ({"sandwich": {"sheet_thickness": "3 ft"}}, 'unit "ft" in "3 ft" is not a length unit'),
        ({"sandwich": {"sheet_thickness": "0 mm"}}, '[sandwich] sheet_thickness: "0 mm" is out of'),
        ({"cutting": {"plate_width": "-1500 mm"}}, "[cutting] plate_width"),
        ({"panelize": {"panel_size": "0 m"}}, "[panelize] panel_size"),
        ({"panelize": {"method": "voronoi"}}, '"voronoi" is not allowed'),
        ({"cutting": {"kerf": "5 mm", "part_spacing": "2 mm"}}, "at least the kerf"),
        ({"input": {"units": "inch"}}, "[input] units"),
    ],
)
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


def _refused(data: dict) -> str:
    """The one-line message of a refused job."""
    with pytest.raises(InputError) as caught:
        Job.from_dict(data, source="job.toml")
    message = str(caught.value)
    assert message.startswith("job.toml: ") and "\n" not in message
    return message


@pytest.mark.parametrize("path", JOB_FILES, ids=lambda path: str(path.relative_to(ROOT)))
def test_every_job_file_of_the_repo_loads(path):
    assert Job.from_toml(path).to_dict() == Job.from_dict(Job.from_toml(path).to_dict()).to_dict()


def test_repo_ships_job_files():
    assert len(JOB_FILES) >= 5


def test_serialised_defaults_keep_their_units():
    data = Job.from_dict({}).to_dict()
    assert data["panelize"]["panel_size"] == "1200 mm"
    assert data["sandwich"]["bolts"] == {
        "diameter": "13 mm",
        "spacing": "250 mm",
        "edge_distance": "60 mm",
        "access_sheet": "bottom",
        "tool": "ring-spanner",
        "tool_swing": 30.0,
        "fit": "normal",
        "grade": "8.8",
    }
    assert data["sandwich"]["welds"] == {"snipe": "15 mm", "erection_gap": "0 mm"}
    assert data["cutting"]["hole_tolerance"] == "0.5 mm"
    assert data["material"]["E"] == "210000 MPa"
    assert data["material"]["fu"] == "360 MPa"
    assert data["material"]["density"] == "7.85e-06 kg/mm3"
    assert data["loads"]["snow"] == "0.00056 N/mm2"
    assert data["structure"]["timeout"] == "1800 s"
    assert data["cutting"]["nest_time"] == "0 s"


@pytest.mark.parametrize(
    "data, fragment",
    [
        ({"panelize": {"panel_size": "1e308 m"}}, '[panelize] panel_size: "1e308 m" is too large'),
        (
            {"cutting": {"plate_length": "1e307 m"}},
            '[cutting] plate_length: "1e307 m" is too large',
        ),
        ({"loads": {"wind_direction": [NAN, 0.0]}}, "[loads] wind_direction: [nan, 0.0] holds nan"),
        ({"loads": {"wind_direction": [0.0, INF]}}, "[loads] wind_direction: [0.0, inf] holds nan"),
        (
            {"panelize": {"singular_points": [[0.0, 0.0, 1.0], [1.0, NAN, 2.0]]}},
            "[panelize] singular_points: item 2, [1.0, nan, 2.0] holds nan or inf",
        ),
        ({"material": {"nu": NAN}}, "[material] nu: nan is not a finite number"),
        ({"loads": {"gamma_g": INF}}, "[loads] gamma_g: inf is not a finite number"),
        ({"loads": {"deflection_limit": INF}}, "[loads] deflection_limit: inf is not a finite"),
        ({"panelize": {"corner_angle": NAN}}, "[panelize] corner_angle: nan is not a finite"),
        ({"develop": {"fairness": INF}}, "[develop] fairness: inf is not a finite number"),
        ({"cutting": {"min_plasma_hole": NAN}}, "[cutting] min_plasma_hole: nan is not a finite"),
    ],
)
def test_values_that_are_not_finite_are_refused(data, fragment):
    assert fragment in _refused(data)


def test_toml_nan_and_inf_are_refused(tmp_path):
    path = tmp_path / "job.toml"
    path.write_text("[loads]\nwind_direction = [nan, 0]\n")
    with pytest.raises(InputError, match=r"job.toml: \[loads\] wind_direction: \[nan, 0\]"):
        Job.from_toml(path)
    path.write_text("[loads]\ngamma_q = inf\n")
    with pytest.raises(InputError, match=r"\[loads\] gamma_q: inf is not a finite number"):
        Job.from_toml(path)


@pytest.mark.parametrize("direction", [[0, 0], [0.0, 0.0], [1e-12, -1e-12]])
def test_a_wind_direction_without_direction_is_refused(direction):
    message = _refused({"loads": {"wind_direction": direction}})
    assert "[loads] wind_direction: [" in message and "has no horizontal direction" in message
    assert "[1.0, 0.0]" in message  # the fix


def test_any_horizontal_wind_direction_is_kept():
    job = Job.from_dict({"loads": {"wind_direction": [0.0, -3.0]}})
    assert job.loads.wind_direction == (0.0, -3.0)


@pytest.mark.parametrize(
    "data, fragments",
    [
        # sheets and plates thin against the rib height (at most half of it)
        (
            {"sandwich": {"sheet_thickness": "500 mm"}},
            [
                '[sandwich] sheet_thickness: "500 mm" against [sandwich] rib_height 150 mm (the default)',
                "at most 75 mm",
                "rib_height of at least 1000 mm",
            ],
        ),
        (
            {"sandwich": {"bottom_sheet_thickness": "0.1 m"}},
            ['[sandwich] bottom_sheet_thickness: "0.1 m"', "rib_height of at least 0.2 m"],
        ),
        (
            {"sandwich": {"rib_height": "5 mm"}},  # only the rib height written
            ['[sandwich] rib_height: "5 mm" against [sandwich] sheet_thickness 3 mm (the default)'],
        ),
        ({"sandwich": {"rib_thickness": "10 cm"}}, ['[sandwich] rib_thickness: "10 cm"']),
        (
            {"sandwich": {"stiffener_thickness": "80 mm"}},
            ['[sandwich] stiffener_thickness: "80 mm"'],
        ),
        # the bolt hole at mid-height: 1.2 d0 to both sheets (EN 1993-1-8 Table 3.3)
        (
            {"sandwich": {"bolts": {"diameter": "500 mm"}}},
            [
                '[sandwich.bolts] diameter: "500 mm" against [sandwich] rib_height',
                "EN 1993-1-8",
                "rib_height of at least 1200 mm",
            ],
        ),
        (
            {"sandwich": {"rib_height": "30 mm"}},
            [
                '[sandwich] rib_height: "30 mm" against [sandwich.bolts] diameter 13 mm (the default)',
                "rib_height of at least 31.2 mm",
            ],
        ),
        # a bolt oversized for the ribs it clamps (hole at most 6 rib thicknesses)
        (
            {"sandwich": {"rib_thickness": "2 mm"}},
            [
                '[sandwich] rib_thickness: "2 mm" against [sandwich.bolts] diameter',
                "holes of at most 12 mm",
            ],
        ),
        # EN 1993-1-8 Table 3.3 minima: e >= 1.2 d0, p >= 2.4 d0
        (
            {"sandwich": {"bolts": {"edge_distance": "1.5 cm"}}},
            ['[sandwich.bolts] edge_distance: "1.5 cm"', "at least 1.56 cm"],
        ),
        (
            {"sandwich": {"bolts": {"spacing": "30 mm"}}},
            ['[sandwich.bolts] spacing: "30 mm"', "at least 31.2 mm"],
        ),
        # the tool must grip two thirds of the hex
        (
            {"sandwich": {"bolts": {"tool_head_thickness": "4 mm"}}},
            ['[sandwich.bolts] tool_head_thickness: "4 mm"', "at least 67%"],
        ),
        # a hole no standard bolt fits
        (
            {"sandwich": {"bolts": {"diameter": "8 mm", "spacing": "30 mm"}}},
            ['[sandwich.bolts] diameter: "8 mm"', "no standard bolt"],
        ),
        # the stiffener between the ribs' inner faces
        (
            {"sandwich": {"stiffener_offset": "16 mm"}},
            ['[sandwich] stiffener_offset: "16 mm" against [sandwich] rib_thickness 8 mm'],
        ),
        # parts onto the plate
        (
            {"sandwich": {"rib_height": "5 m"}},
            [
                '[sandwich] rib_height: "5 m" against [cutting] plate_width 1500 mm (the default)',
                "1480 mm across",
                "at most 1.48 m",
            ],
        ),
        (
            {"cutting": {"plate_width": "100 mm"}},
            ['[cutting] plate_width: "100 mm" against [sandwich] rib_height 150 mm (the default)'],
        ),
        (
            {
                "cutting": {"plate_length": "1 m", "plate_width": "3 m"},
                "sandwich": {"rib_height": "1 m"},
            },
            ['[sandwich] rib_height: "1 m" against [cutting] plate_length "1 m"'],
        ),
        (
            {"sandwich": {"stiffener_offset": "2 m"}, "panelize": {"panel_size": "5 m"}},
            ['[sandwich] stiffener_offset: "2 m" against [cutting] plate_length 3000 mm'],
        ),
        (
            {"sandwich": {"stiffener_offset": "1.2 m"}},
            ['[sandwich] stiffener_offset: "1.2 m" against [panelize] panel_size 1200 mm'],
        ),
        (
            {"cutting": {"plate_margin": "0.75 m"}},
            ['[cutting] plate_margin: "0.75 m" against [cutting] plate_width', "less than 0.75 m"],
        ),
    ],
)
def test_a_sandwich_that_cannot_be_built_is_refused(data, fragments):
    message = _refused(data)
    for fragment in fragments:
        assert fragment in message


def test_the_rules_keep_sensible_sandwiches():
    job = Job.from_dict(
        {
            "sandwich": {
                "sheet_thickness": "4 mm",
                "rib_height": "100 mm",
                "rib_thickness": "6 mm",
                "stiffener_offset": "100 mm",
                "bolts": {
                    "diameter": "18 mm",
                    "spacing": "200 mm",
                    "edge_distance": "40 mm",
                    "tool": "socket",
                },
            }
        }
    )
    assert job.sandwich.rib_height == 100.0
    # the stiffener offset is checked against panel_size only where panel_size sizes the panels
    Job.from_dict(
        {"sandwich": {"stiffener_offset": "1.3 m"}, "panelize": {"grid_u": 3, "grid_v": 3}}
    )
    # no access openings: the tool does not matter
    Job.from_dict({"sandwich": {"bolts": {"access_sheet": "none", "tool_head_thickness": "1 mm"}}})


def test_cladding_has_no_rib_or_bolt_rules():
    job = Job.from_dict(
        {
            "sandwich": {
                "buildup": "cladding",
                "rib_height": "5 m",
                "sheet_thickness": "10 mm",
                "bolts": {"diameter": "500 mm"},
            }
        }
    )
    assert job.sandwich.total_depth == 10.0


def test_rules_name_the_users_unit_when_given():
    message = _refused({"sandwich": {"rib_height": "0.02 m", "bolts": {"diameter": "10 mm"}}})
    assert message.startswith(
        'job.toml: [sandwich.bolts] diameter: "10 mm" against [sandwich] rib_height "0.02 m"'
    )
    assert "rib_height of at least 0.024 m" in message


@pytest.mark.parametrize(
    "data, fragment",
    [
        (
            {"cutting": {"plate_width": "-1.5 m"}},
            '[cutting] plate_width: "-1.5 m" is out of range; it must be > 0 m',
        ),
        ({"structure": {"support_band": "-2 cm"}}, '"-2 cm" is out of range; it must be >= 0 cm'),
        (
            {"loads": {"snow": "-1 kN/m2"}},
            '[loads] snow: "-1 kN/m2" is out of range; it must be >= 0 kN/m2',
        ),
        (
            {"panelize": {"corner_angle": 200}},
            "[panelize] corner_angle: 200 is out of range; it must be < 180",
        ),
        ({"material": {"nu": True}}, "[material] nu: true holds a yes/no value"),
    ],
)
def test_range_errors_quote_the_value_and_limit_in_its_unit(data, fragment):
    assert fragment in _refused(data)


@pytest.mark.parametrize("text", ["1.2", "1200", "1.0"])
def test_a_bare_number_for_a_length_in_the_job_is_refused(text):
    message = _refused({"panelize": {"panel_size": text}})
    assert f'[panelize] panel_size: the length "{text}" has no unit' in message
    assert f'"{text} m"' in message  # a fix with a unit
