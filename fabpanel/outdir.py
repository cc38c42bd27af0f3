"""The output folder: which targets a run may write, its staging folder, and the swap into place.

fabpanel never deletes or overwrites anything it did not create. A run writes into a hidden
staging folder beside the target (``.<name>.partial-<pid>``, marked by a file of ours) and
renames it into place only when the whole run has succeeded. A target is refused (exit 2) when

- it is the working folder or one of its ancestors (replacing it would delete the user's files);
- it is, or contains, a file the run reads (the design surface, the job file, a user layout);
- it exists and is not a folder, or is a folder with files that is not a fabpanel output folder
  (no ``manifest.json`` written by fabpanel);
- it is a fabpanel output folder and ``force`` is not set.

Staging folders of processes that died without cleaning up (SIGKILL, power loss) are swept on
the next run into the same target; folders of live processes are left alone.
"""

from __future__ import annotations

import json
import os
import shutil
from collections.abc import Iterable
from pathlib import Path

from .errors import InputError

#: file inside a staging folder that marks it as fabpanel's (holds the owner's process id)
STAGING_MARK = ".fabpanel-partial"


def is_fabpanel_output(folder: Path) -> bool:
    """True when ``folder`` holds a ``manifest.json`` written by fabpanel."""
    manifest = folder / "manifest.json"
    if not manifest.is_file():
        return False
    try:
        data = json.loads(manifest.read_text(encoding="utf-8"))
    except (OSError, ValueError):
        return False
    return isinstance(data, dict) and "fabpanel" in data and "stages_run" in data


def check_target(target: Path, inputs: Iterable[Path], force: bool) -> None:
    """Refuse (:class:`InputError`) a target the run must not write; see the module docstring.

    target : the resolved output folder. inputs : files the run reads (resolved or not).
    """
    cwd = Path.cwd().resolve()
    if target == cwd or target in cwd.parents:
        what = "the working folder" if target == cwd else "an ancestor of the working folder"
        raise InputError(
            f"output folder {target} is {what}; replacing it would delete your "
            f"files: choose a new folder, e.g. --out {cwd / 'fabpanel-out'}"
        )
    for path in inputs:
        path = Path(path).resolve()
        if path == target:
            raise InputError(
                f"output folder {target} is {path.name}, a file this run reads; "
                f"choose another output folder"
            )
        if target in path.parents:
            raise InputError(
                f"output folder {target} contains {path.name}, which this run "
                f"reads; choose an output folder that holds none of the inputs"
            )
    if not target.exists() and not target.is_symlink():
        return
    if not target.is_dir() or target.is_symlink():
        raise InputError(
            f"output path {target} exists and is not a folder; choose another with --out"
        )
    if not any(target.iterdir()):
        return
    if not is_fabpanel_output(target):
        raise InputError(
            f"output folder {target} exists and is not a fabpanel output folder "
            f"(no manifest.json of fabpanel); fabpanel replaces only its own "
            f"output: choose another folder with --out"
        )
    if not force:
        raise InputError(
            f"output folder {target} holds an earlier fabpanel run; pass --force "
            f"to replace it or choose another with --out"
        )


def _pid_alive(pid: int) -> bool:
    try:
        os.kill(pid, 0)
    except ProcessLookupError:
        return False
    except PermissionError:
        return True  # someone else's live process
    return True


def _owner_pid(folder: Path, tag: str) -> int | None:
    suffix = folder.name.rpartition(f".{tag}-")[2]
    return int(suffix) if suffix.isdigit() else None


def sweep_stale(target: Path) -> list[Path]:
    """Remove the staging and replaced folders that dead fabpanel runs left beside ``target``.

    Only folders named as fabpanel names them, whose owner process is gone, and which carry
    fabpanel's mark (staging) or manifest (a replaced output) are removed. Returns them.
    """
    removed: list[Path] = []
    parent = target.parent
    if not parent.is_dir():
        return removed
    for tag in ("partial", "old"):
        for folder in parent.glob(f".{target.name}.{tag}-*"):
            pid = _owner_pid(folder, tag)
            if pid is None or _pid_alive(pid) or not folder.is_dir() or folder.is_symlink():
                continue
            ours = (
                (folder / STAGING_MARK).is_file()
                if tag == "partial"
                else is_fabpanel_output(folder)
            )
            if ours:
                shutil.rmtree(folder, ignore_errors=True)
                removed.append(folder)
    return removed


def make_staging(target: Path) -> Path:
    """A new, marked staging folder beside ``target`` for this process."""
    staging = target.parent / f".{target.name}.partial-{os.getpid()}"
    if staging.exists():
        if not (staging / STAGING_MARK).is_file():
            raise InputError(
                f"{staging} exists and is not fabpanel's; remove it or choose another output folder"
            )
        shutil.rmtree(staging)
    try:
        staging.mkdir(parents=True)
        (staging / STAGING_MARK).write_text(str(os.getpid()))
    except OSError as exc:  # a parent that is a file, a read-only or virtual file system
        raise InputError(
            f"cannot create the output folder {target}: {exc.strerror or exc}; "
            f"choose a folder you can write with --out"
        ) from None
    return staging


def move_into_place(staging: Path, target: Path, force: bool) -> None:
    """Rename the finished staging folder to ``target``, replacing an earlier fabpanel output.

    The target is checked again: something may have been written there while the run worked.
    If it may not be replaced, the finished output is kept beside it under a visible name and
    :class:`InputError` says where.
    """
    (staging / STAGING_MARK).unlink(missing_ok=True)
    occupied = target.exists() or target.is_symlink()
    if occupied and not _replaceable(target, force):
        kept = _free_sibling(target)
        staging.rename(kept)
        raise InputError(
            f"output folder {target} was filled by something else while this run "
            f"worked; it is left as it is and the finished output is in {kept}"
        )
    old = None
    if occupied:
        old = target.parent / f".{target.name}.old-{os.getpid()}"
        target.rename(old)
    staging.rename(target)
    if old is not None:
        shutil.rmtree(old, ignore_errors=True)


def _replaceable(target: Path, force: bool) -> bool:
    if target.is_symlink() or not target.is_dir():
        return False
    if not any(target.iterdir()):
        return True
    return force and is_fabpanel_output(target)


def _free_sibling(target: Path) -> Path:
    for n in range(1, 1000):
        candidate = target.parent / f"{target.name}-{n}"
        if not candidate.exists() and not candidate.is_symlink():
            return candidate
    raise InputError(f"no free folder name beside {target}; tidy its parent folder")


def discard_staging(staging: Path) -> None:
    """Remove an unfinished staging folder (the run failed or was stopped)."""
    if (staging / STAGING_MARK).is_file():
        shutil.rmtree(staging, ignore_errors=True)
