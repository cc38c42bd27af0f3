"""Part and plate DXFs open in a real CAD program: LibreCAD prints them to PDF.

Needs ``librecad`` and ``pdftoppm`` (Debian packages librecad and poppler-utils; the test set-up
``bash .ci/setup --test`` installs them). LibreCAD runs headless on Qt's offscreen platform.
"""

from __future__ import annotations

import os
import shutil
import subprocess

import numpy as np
import pytest
from test_flat import cone_grid, cylinder_grid, rib, sheet

from fabpanel.data import Hole, Model
from fabpanel.flat import cut, nest, write_nests, write_parts
from fabpanel.job import Job

pytestmark = pytest.mark.skipif(
    shutil.which("librecad") is None or shutil.which("pdftoppm") is None,
    reason="LibreCAD or pdftoppm not installed (bash .ci/setup --test installs them)",
)


def print_with_librecad(dxf, folder):
    """Print a DXF with LibreCAD, rasterise the PDF; returns the share of inked pixels."""
    pdf = dxf.with_suffix(".pdf")  # LibreCAD 2.2 writes it beside the drawing
    env = {**os.environ, "QT_QPA_PLATFORM": "offscreen", "XDG_RUNTIME_DIR": str(folder)}
    subprocess.run(
        ["librecad", "dxf2pdf", "-a", str(dxf)],
        env=env,
        check=True,
        capture_output=True,
        timeout=120,
    )
    if not pdf.exists():
        return 0.0
    subprocess.run(
        ["pdftoppm", "-r", "40", "-gray", "-singlefile", str(pdf), str(dxf.with_suffix(""))],
        check=True,
        capture_output=True,
        timeout=60,
    )
    raw = dxf.with_suffix(".pgm").read_bytes()
    # binary PGM: header "P5\n<w> <h>\n<max>\n" then one byte per pixel
    header, width, height, maximum = raw.split(maxsplit=4)[:4]
    pixels = np.frombuffer(raw[-int(width) * int(height) :], dtype=np.uint8)
    assert header == b"P5" and int(maximum) == 255
    return float(np.mean(pixels < 200))


def test_librecad_prints_parts_and_plates(tmp_path):
    openings = (Hole((0.5, 0.2), 40.0, "access"), Hole((0.5, 0.8), 40.0, "access"))
    model = Model(
        parts=(sheet(cylinder_grid(), holes=openings), sheet(cone_grid(), "P002"), rib()),
        developed=None,
    )  # type: ignore[arg-type]
    job = Job.from_dict({})
    flat = cut(model, job)
    files = write_parts(flat, tmp_path / "parts")
    plates = write_nests(nest(flat, job), flat, tmp_path / "nests")
    drawings = [tmp_path / "parts" / name for name in files.values()]
    drawings += [tmp_path / "nests" / names[0] for names in plates.values()]
    for dxf in drawings:
        assert print_with_librecad(dxf, tmp_path) > 0.002, dxf.name


def test_an_empty_drawing_prints_no_ink(tmp_path):
    """The control: the ink measure does see a drawing without entities as blank."""
    import ezdxf

    empty = tmp_path / "empty.dxf"
    ezdxf.new().saveas(empty)
    assert print_with_librecad(empty, tmp_path) < 0.002
