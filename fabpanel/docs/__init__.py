"""The shop documents: schedules (``docs/*.csv``), the key plan (``docs/keyplan.pdf``), the
assembly drawings (``docs/drawings.pdf``) and the assembly as IFC (``model/assembly.ifc``),
made from the run's manifest and model.

``write_docs`` is called by the pipeline after the cut stage, and by ``fabpanel docs
OUTPUT_DIR`` on a finished output folder (the solids then come from ``model/assembly.step``).
"""

from __future__ import annotations

import csv
from collections.abc import Mapping
from pathlib import Path

from ..raster import PYPLOT
from .bolts import joint_bolts
from .drawings import write_drawings
from .ifc import solid_geometries, write_ifc
from .keyplan import write_keyplan
from .panels import panel_schedule
from .schedules import Schedule, fastener_schedule, rolling_schedule, weld_schedule
from .source import DocSource

__all__ = ["DocSource", "Schedule", "docs_from_folder", "schedules", "write_docs"]


def schedules(source: DocSource) -> list[Schedule]:
    """The four schedules, in the order the report shows them."""
    return [
        panel_schedule(source),
        rolling_schedule(source),
        fastener_schedule(source),
        weld_schedule(source),
    ]


def write_schedule(schedule: Schedule, folder: Path) -> Path:
    path = folder / schedule.name
    with path.open("w", newline="") as handle:
        writer = csv.writer(handle)
        writer.writerow(schedule.header)
        writer.writerows(schedule.rows)
    return path


def write_docs(
    source: DocSource,
    folder: str | Path,
    breps: Mapping[str, bytes] | None,
    workers: int = 1,
    geometry: Mapping[str, object] | None = None,
) -> list[Path]:
    """Write the documents of ``source`` under the output ``folder`` (``docs/`` and, when the
    parts' solids ``breps`` are given, the drawings and ``model/assembly.ifc``); the files
    written. ``geometry``: the parts' exchange geometry when the model write already made it
    (:func:`~fabpanel.docs.ifc.solid_geometries`), else it is made here."""
    folder = Path(folder)
    (folder / "docs").mkdir(exist_ok=True)
    written = [write_schedule(s, folder / "docs") for s in schedules(source)]
    with PYPLOT:
        written.append(write_keyplan(source, folder / "docs" / "keyplan.pdf"))
    if breps is not None:
        if geometry is None:
            geometry = solid_geometries(
                [(p.id, breps[p.id], p.thickness, p.kind) for p in source.parts if p.id in breps],
                workers,
            )
        (folder / "model").mkdir(exist_ok=True)
        # the IFC first: it runs in this process alone, the drawings' views in the workers,
        # which in the write stage are still busy with the other files
        ifc = write_ifc(source, geometry, joint_bolts(source), folder / "model" / "assembly.ifc")
        written.append(write_drawings(source, breps, folder / "docs" / "drawings.pdf", workers))
        written.append(ifc)
    return written


def docs_from_folder(folder: str | Path, workers: int = 1) -> list[Path]:
    """Make the documents again from a finished output folder (its manifest and
    ``model/assembly.step``; without the STEP, the IFC is left out). They are written into a
    staging folder inside it first and moved into place only when all are made, so a failed or
    stopped run leaves the folder as it was."""
    import os
    import shutil

    from ..errors import InputError
    from ..model import occ
    from ..model.export import read_step_parts
    from ..outdir import STAGING_MARK, is_fabpanel_output

    folder = Path(folder)
    if not is_fabpanel_output(folder):
        raise InputError(
            f"{folder} is not a fabpanel output folder (no manifest.json written by fabpanel); "
            "give the folder a run wrote"
        )
    source = DocSource.from_folder(folder)
    step = folder / "model" / "assembly.step"
    breps = None
    if step.is_file():
        shapes = read_step_parts(step)
        breps = {name: occ.to_brep(shape) for name, shape in shapes.items()}
        missing = [p.id for p in source.parts if p.id not in breps]
        if missing:
            raise InputError(
                f"{step}: {len(missing)} parts of the manifest are not in the STEP file "
                f"(first {missing[0]}); run the job again to write both"
            )
    staging = folder / f".docs.partial-{os.getpid()}"
    staging.mkdir()
    (staging / STAGING_MARK).write_text(str(os.getpid()))
    try:
        made = write_docs(source, staging, breps, workers)
        placed = []
        for path in made:
            target = folder / path.relative_to(staging)
            target.parent.mkdir(exist_ok=True)
            os.replace(path, target)
            placed.append(target)
        return placed
    finally:
        shutil.rmtree(staging, ignore_errors=True)
