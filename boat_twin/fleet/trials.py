"""The trials of a batch: the paths, globs and directories a user gives, expanded into trials with unique report
names and the boat each belongs to."""

from __future__ import annotations

import glob
import os
from dataclasses import dataclass
from pathlib import Path

from boat_twin.errors import InputError

TRIAL_SUFFIXES = (".mcap", ".tlog", ".bin")
"""Files taken as trials inside a directory (besides rosbag2 directories); .csv too when the verb has --columns."""
GLOB_CHARS = "*?["
"""A path with one of these that does not exist as written is a glob pattern (``**`` recursive)."""


@dataclass(frozen=True)
class TrialTask:
    """One trial of a batch: its report's name (``DIR/<name>/``), its absolute path and its boat."""

    name: str
    path: str
    boat: str
    """The folder the trial lies in: for a directory given, its first level below it (``fleet/boatA/day1.mcap``
    → ``boatA``); the directory's own name for a trial directly in it, the parent folder's for a path given."""


def is_bag_dir(path: Path) -> bool:
    """A rosbag2 directory (it holds metadata.yaml): one trial, not a folder of trials."""
    return (path / "metadata.yaml").is_file()


def _is_trial(path: Path, csv: bool) -> bool:
    if path.is_dir():
        return is_bag_dir(path)
    suffix = path.suffix.lower()
    return suffix in TRIAL_SUFFIXES or (csv and suffix == ".csv")


def _inside(path: Path, folder: Path | None) -> bool:
    return folder is not None and (path == folder or folder in path.parents)


def _found_in(root: Path, csv: bool, skip: Path | None) -> list[Path]:
    """Trials under ``root``, sorted: rosbag2 directories (not entered) and trial files, ``skip`` left out."""
    found: list[Path] = []
    for folder, subdirs, files in os.walk(root):
        here = Path(folder)
        if _inside(here, skip):
            subdirs[:] = []
            continue
        bags = [d for d in subdirs if is_bag_dir(here / d)]
        found += [here / d for d in bags]
        subdirs[:] = sorted(d for d in subdirs if d not in bags and not d.startswith("."))
        found += [here / f for f in files if not f.startswith(".") and _is_trial(here / f, csv)]
    return sorted(p for p in found if not _inside(p, skip))


def trial_bytes(task: TrialTask) -> int:
    """The size of ``task``'s recording on disk (a rosbag2 directory's files summed; 0 when missing), bytes: the
    batch's guess of its cost, to start the longest trials first."""
    path = Path(task.path)
    try:
        if path.is_dir():
            return sum(f.stat().st_size for f in path.rglob("*") if f.is_file())
        return path.stat().st_size
    except OSError:
        return 0


def expand_trials(items: list[Path], csv: bool = False, skip: Path | None = None) -> list[tuple[Path, str]]:
    """(absolute path, boat) of every trial ``items`` name: a trial (file or rosbag2 directory, kept even when
    missing: its row will say so), a directory of trials (searched recursively; ``skip``, the batch's own
    output directory, left out) or a glob pattern. ``csv``: .csv files in a directory are trials (the verb has
    --columns). A pattern or directory with no trial is bad input. Each trial once, in the order given."""
    out: dict[Path, str] = {}
    for item in items:
        text = str(item)
        if not item.exists() and any(c in text for c in GLOB_CHARS):
            matches = sorted(Path(m) for m in glob.glob(text, recursive=True))
            matches = [m for m in matches if _is_trial(m, csv) and not _inside(m.resolve(), skip)]
            if not matches:
                raise InputError(f"{text}: no trial matches this pattern")
            for match in matches:
                out.setdefault(match.resolve(), match.resolve().parent.name)
        elif item.is_dir() and not is_bag_dir(item):
            root = item.resolve()
            found = _found_in(root, csv, skip)
            if not found:
                kinds = "rosbag2 directories, " + ", ".join(TRIAL_SUFFIXES) + (", .csv" if csv else "")
                raise InputError(f"{item}: no trial in this directory ({kinds})")
            for path in found:
                relative = path.relative_to(root)
                out.setdefault(path, relative.parts[0] if len(relative.parts) > 1 else root.name)
        else:
            out.setdefault(item.resolve(), item.resolve().parent.name)
    return list(out.items())


def _relative_names(paths: list[Path], keep_suffix: bool) -> list[str]:
    common = Path(os.path.commonpath([str(p.parent) for p in paths]))
    names = []
    for path in paths:
        relative = path.relative_to(common)
        if not keep_suffix:
            relative = relative.with_name(relative.stem if path.suffix else relative.name)
        names.append("__".join(relative.parts))
    return names


def name_trials(found: list[tuple[Path, str]]) -> list[TrialTask]:
    """:class:`TrialTask` of each (path, boat), named by the trial's file name without its suffix; where two share
    a name, every name is the path below the trials' common folder with ``__`` for ``/`` (and the suffix, if
    needed)."""
    paths = [path for path, _ in found]
    names = [p.stem if p.suffix else p.name for p in paths]
    if len(set(names)) < len(names):
        names = _relative_names(paths, keep_suffix=False)
    if len(set(names)) < len(names):
        names = _relative_names(paths, keep_suffix=True)
    return [TrialTask(name, str(path), boat) for name, (path, boat) in zip(names, found, strict=True)]
