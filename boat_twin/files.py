"""Safe outputs: never overwrite without --force, write atomically (temp file + rename)."""

from __future__ import annotations

import json
import os
import shutil
import tempfile
from pathlib import Path
from typing import Any

import yaml

from boat_twin.errors import InputError

BAG_FILE_SUFFIXES = (".mcap", ".db3", ".db3-shm", ".db3-wal", ".yaml")
"""What a rosbag2 directory holds (storage files and metadata.yaml); --force replaces no other directory."""


def _is_bag_dir(path: Path) -> bool:
    """A rosbag2 directory: metadata.yaml and nothing but bag files."""
    entries = list(path.iterdir())
    return (path / "metadata.yaml").is_file() and all(e.is_file() and e.suffix in BAG_FILE_SUFFIXES for e in entries)


def prepare_output(path: Path, force: bool) -> None:
    """Check that ``path`` may be written, before any work; nothing is deleted here.

    Refused: the current directory or one that contains it, an existing path without ``force``, and with
    ``force`` a directory that is not a rosbag2 bag. The new output goes to a temporary next to ``path`` and
    :func:`replace_output` swaps it in, so a failure or an interrupt leaves the old output as it was.
    """
    resolved = path.resolve()
    cwd = Path.cwd().resolve()
    if str(path) in ("", ".") or resolved == cwd or resolved in cwd.parents:
        raise InputError(f"{path or '.'}: is the current directory or contains it; refusing to write over it "
                         "(give a new file or directory name)")
    if path.exists() or path.is_symlink():
        if not force:
            raise InputError(f"{path}: already exists (use --force to overwrite)")
        if path.is_dir() and not _is_bag_dir(path):
            raise InputError(f"{path}: is a directory that is not a rosbag2 bag (metadata.yaml and bag files "
                             "only); refusing to replace it")
    ensure_out_dir(path.parent if str(path.parent) else Path("."))


def refuse_input_as_output(out: Path | None, *inputs: Path | None) -> None:
    """An output path that is (or holds) one of the verb's inputs is refused: --force must never replace a raw
    log, a config or a bag being read."""
    if out is None:
        return
    target = out.resolve()
    for item in inputs:
        if item is not None and (item.resolve() == target or target in item.resolve().parents):
            raise InputError(f"{out}: is also an input of this command ({item}); refusing to write over it")


def replace_output(new: Path, path: Path) -> None:
    """Move the finished output ``new`` (a file or directory next to ``path``) to ``path``; an old ``path`` is
    moved aside first and removed only once the new one is in place."""
    if not (path.exists() or path.is_symlink()):
        os.rename(new, path)
        return
    old = path.with_name(f".{path.name}.old.{os.getpid()}")
    os.rename(path, old)
    try:
        os.rename(new, path)
    except BaseException:
        os.rename(old, path)
        raise
    if old.is_dir() and not old.is_symlink():
        shutil.rmtree(old)
    else:
        old.unlink()


def ensure_out_dir(path: Path) -> Path:
    """Create the report directory ``path`` (existing files inside are replaced one by one, atomically)."""
    try:
        path.mkdir(parents=True, exist_ok=True)
    except OSError as err:
        raise InputError(f"{path}: cannot create output directory ({err.strerror})") from None
    if not os.access(path, os.W_OK):
        raise InputError(f"{path}: output directory is not writable")
    return path


def _new_file_mode() -> int:
    """The permissions ``open()`` gives a new file under the process umask (0o644 for the usual 022): the
    temporary files of an atomic write are created 0o600 by :func:`tempfile.mkstemp` and get these before the
    rename, like every other output (bags included). The umask is read from /proc where it is shown (Linux ≥ 4.7),
    since setting it to read it back would briefly change it for the node threads writing files."""
    try:
        with open("/proc/self/status") as status:
            umask = next(int(line.split()[1], 8) for line in status if line.startswith("Umask:"))
    except (OSError, StopIteration, ValueError, IndexError):
        umask = os.umask(0)
        os.umask(umask)
    return 0o666 & ~umask


def atomic_write_bytes(path: Path, data: bytes) -> None:
    """Write ``data`` to ``path`` through a temporary file in the same directory and a rename."""
    fd, tmp = tempfile.mkstemp(dir=path.parent, prefix=f".{path.name}.", suffix=".tmp")
    try:
        with os.fdopen(fd, "wb") as fh:
            fh.write(data)
        os.chmod(tmp, _new_file_mode())
        os.replace(tmp, path)
    except BaseException:
        Path(tmp).unlink(missing_ok=True)
        raise


def atomic_write_text(path: Path, text: str) -> None:
    """Write ``text`` (UTF-8) to ``path`` atomically."""
    atomic_write_bytes(path, text.encode("utf-8"))


def atomic_write_yaml(path: Path, data: Any) -> None:
    """Write ``data`` as block-style YAML to ``path`` atomically."""
    atomic_write_text(path, yaml.safe_dump(data, sort_keys=False))


def atomic_save_figure(path: Path, figure: Any) -> None:
    """Save a matplotlib figure as PNG to ``path`` atomically."""
    fd, tmp = tempfile.mkstemp(dir=path.parent, prefix=f".{path.name}.", suffix=".png")
    os.close(fd)
    try:
        figure.savefig(tmp, dpi=110)
        os.chmod(tmp, _new_file_mode())
        os.replace(tmp, path)
    except BaseException:
        Path(tmp).unlink(missing_ok=True)
        raise


def load_yaml(path: Path) -> Any:
    """Read a YAML file; a missing or malformed file is an :class:`InputError` naming it."""
    try:
        text = path.read_text()
    except OSError as err:
        raise InputError(f"{path}: cannot read ({err.strerror})") from None
    try:
        return yaml.safe_load(text)
    except yaml.YAMLError as err:
        mark = getattr(err, "problem_mark", None)
        where = f" at line {mark.line + 1}" if mark is not None else ""
        raise InputError(f"{path}: malformed YAML{where}") from None


def to_json(data: Any) -> str:
    """JSON for --json output: numpy scalars and arrays become plain numbers and lists."""

    def default(obj: Any) -> Any:
        if hasattr(obj, "tolist"):
            return obj.tolist()
        raise TypeError(f"not JSON serializable: {type(obj).__name__}")

    return json.dumps(data, default=default, indent=2)
