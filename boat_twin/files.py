"""Safe outputs: never overwrite without --force, one writer per output, write atomically (temporary + rename).

Every output (a bag, a bag file, a .tlog, a report file) is written through an :class:`OutputClaim`:

- ``.NAME.lock`` next to ``NAME`` is locked (``flock``, exclusive) for the whole write: a second writer of the
  same output is refused at once. The kernel drops the lock when its holder dies, even by SIGKILL.
- The new output is written into the scratch directory ``.NAME.partial-PID`` and renamed into place when
  complete; an old ``NAME`` is first moved to ``.NAME.old-PID`` and removed only once the new one is in place.
- Leftovers of a killed writer (``.NAME.partial-PID``, ``.NAME.old-PID``) are provably stale once the lock is
  held again: the next writer of ``NAME`` removes them, restores an old output the killed run had moved aside
  but not yet replaced, and names each on stderr.
"""

from __future__ import annotations

import fcntl
import json
import math
import os
import re
import shutil
import sys
from collections.abc import Callable, Iterator
from contextlib import contextmanager
from pathlib import Path
from typing import Any

import yaml

from boat_twin.errors import InputError

BAG_FILE_SUFFIXES = (".mcap", ".db3", ".db3-shm", ".db3-wal", ".yaml")
"""What a rosbag2 directory holds (storage files and metadata.yaml); --force replaces no other directory."""


MCAP_MAGIC = b"\x89MCAP0\r\n"
"""The first 8 bytes of an MCAP file (mcap.dev specification)."""
MAVLINK_MAGICS = (0xFD, 0xFE)
"""First byte of a MAVLink 2 or 1 packet: in a .tlog, after the 8-byte time stamp."""


def _is_bag_dir(path: Path) -> bool:
    """A rosbag2 directory: metadata.yaml and nothing but bag files."""
    entries = list(path.iterdir())
    return (path / "metadata.yaml").is_file() and all(e.is_file() and e.suffix in BAG_FILE_SUFFIXES for e in entries)


def _starts_with(path: Path, test: Callable[[bytes], bool], size: int) -> bool:
    """A regular file that is empty or whose first ``size`` bytes pass ``test``."""
    if not path.is_file():
        return False
    with path.open("rb") as fh:
        head = fh.read(size)
    return not head or (len(head) == size and test(head))


REPLACEABLE: dict[str, tuple[str, Callable[[Path], bool]]] = {
    "bag": ("rosbag2 bag (metadata.yaml and bag files) or MCAP file",
            lambda p: _is_bag_dir(p) if p.is_dir() else _starts_with(p, lambda h: h == MCAP_MAGIC, 8)),
    "tlog": ("MAVLink telemetry log", lambda p: _starts_with(p, lambda h: h[8] in MAVLINK_MAGICS, 9)),
    "file": ("file", lambda p: p.is_file()),
}
"""Kind of output → (what it is, whether an existing path is one): --force replaces nothing else (an empty file
is always replaceable)."""


def _lock_path(path: Path) -> Path:
    return path.with_name(f".{path.name}.lock")


def _probe_lock(path: Path) -> None:
    """Refuse ``path`` now if its directory takes no new file or another run holds its lock."""
    lock = _lock_path(path)
    existed = lock.exists()
    try:
        fd = os.open(lock, os.O_RDWR | os.O_CREAT, 0o644)
    except OSError as err:
        raise InputError(f"{path}: cannot write in {path.parent} ({err.strerror})") from None
    try:
        fcntl.flock(fd, fcntl.LOCK_EX | fcntl.LOCK_NB)
    except BlockingIOError:
        raise InputError(f"{path}: another run is writing it now (lock {lock}); refusing to write it too") from None
    finally:
        if not existed:
            lock.unlink(missing_ok=True)
        os.close(fd)


def prepare_output(path: Path, force: bool, kind: str = "file") -> None:
    """Check that ``path`` may be written, before any work; nothing is deleted here.

    Refused: the current directory or one that contains it, an existing path without ``force``, with ``force``
    a path that is not an output of this ``kind`` (:data:`REPLACEABLE`), and an output another run is writing
    now. :class:`OutputClaim` checks again under the lock when the output is written.
    """
    resolved = path.resolve()
    cwd = Path.cwd().resolve()
    if str(path) in ("", ".") or resolved == cwd or resolved in cwd.parents:
        raise InputError(f"{path or '.'}: is the current directory or contains it; refusing to write over it "
                         "(give a new file or directory name)")
    if path.exists() or path.is_symlink():
        if not force:
            raise InputError(f"{path}: already exists (use --force to overwrite)")
        what, replaceable = REPLACEABLE[kind]
        if not replaceable(path):
            raise InputError(f"{path}: is not a {what}; refusing to replace it")
    ensure_out_dir(path.parent if str(path.parent) else Path("."))
    _probe_lock(path)


def refuse_input_as_output(out: Path | None, *inputs: Path | None) -> None:
    """An output path that is (or holds) one of the verb's inputs is refused: --force must never replace a raw
    log, a config or a bag being read."""
    if out is None:
        return
    target = out.resolve()
    for item in inputs:
        if item is not None and (item.resolve() == target or target in item.resolve().parents):
            raise InputError(f"{out}: is also an input of this command ({item}); refusing to write over it")


def _remove(path: Path) -> None:
    if path.is_dir() and not path.is_symlink():
        shutil.rmtree(path)
    else:
        path.unlink()


def replace_output(new: Path, path: Path) -> None:
    """Move the finished output ``new`` (a file or directory next to ``path``) to ``path``. A file replaces a
    file in one atomic rename; otherwise the old ``path`` is moved to ``.NAME.old-PID`` first and removed only
    once the new one is in place (a run killed in between leaves it there for :class:`OutputClaim` to restore)."""
    if not (path.exists() or path.is_symlink()):
        os.rename(new, path)
        return
    if not new.is_dir() and not path.is_dir():
        os.replace(new, path)
        return
    old = path.with_name(f".{path.name}.old-{os.getpid()}")
    os.rename(path, old)
    try:
        os.rename(new, path)
    except BaseException:
        os.rename(old, path)
        raise
    _remove(old)


class OutputClaim:
    """The exclusive right to write the output ``path`` until :meth:`release` (or the end of a ``with``).

    Taking it checks ``path`` as :func:`prepare_output` does (an output of ``kind``), locks ``.NAME.lock``
    (refused at once if another run holds it), cleans the stale leftovers of killed writers of ``path`` and
    creates :attr:`scratch`, an empty directory next to ``path`` for the new output; :meth:`commit` moves it
    into place. Leaving a ``with`` by an exception (Ctrl-C included) removes the scratch: ``path`` stays as it
    was.
    """

    def __init__(self, path: Path, force: bool, kind: str = "file") -> None:
        prepare_output(path, force, kind)
        self.path = path
        self._lock = _lock_path(path)
        self._fd: int | None = None
        self._acquire()
        try:
            self._clean_stale()
            if not force and (path.exists() or path.is_symlink()):  # written by a run that just finished
                raise InputError(f"{path}: already exists (use --force to overwrite)")
            self.scratch = path.with_name(f".{path.name}.partial-{os.getpid()}")
            self.scratch.mkdir()
        except BaseException:
            self._unlock()
            raise

    def _acquire(self) -> None:
        for _ in range(3):  # a retry when the holder finished between our open and our lock
            try:
                fd = os.open(self._lock, os.O_RDWR | os.O_CREAT, 0o644)
            except OSError as err:
                raise InputError(f"{self.path}: cannot write in {self.path.parent} ({err.strerror})") from None
            try:
                fcntl.flock(fd, fcntl.LOCK_EX | fcntl.LOCK_NB)
            except BlockingIOError:
                os.close(fd)
                break
            if os.path.exists(self._lock) and os.stat(self._lock).st_ino == os.fstat(fd).st_ino:
                self._fd = fd
                return
            os.close(fd)  # locked an inode its holder had already unlinked
        raise InputError(f"{self.path}: another run is writing it now (lock {self._lock}); refusing to write it "
                         "too")

    def _clean_stale(self) -> None:
        """Leftovers of writers of ``path`` killed before they finished: stale, since the lock is ours."""
        pattern = re.compile(rf"\.{re.escape(self.path.name)}\.(partial|old)-\d+")
        found = [(m.group(1), self.path.parent / m.group(0))
                 for m in map(pattern.fullmatch, os.listdir(self.path.parent)) if m]
        for kind, item in sorted(found, key=lambda f: f[0] != "old"):  # an old output to restore first
            if kind == "old" and not (self.path.exists() or self.path.is_symlink()):
                os.rename(item, self.path)
                sys.stderr.write(f"boat-twin: restored {self.path} from {item.name} (a run replacing it was "
                                 "killed)\n")
            else:
                _remove(item)
                sys.stderr.write(f"boat-twin: removed {item} (left by a run killed while writing {self.path})\n")

    def commit(self, new: Path) -> None:
        """Move the complete new output ``new`` (inside :attr:`scratch`) to ``path``."""
        replace_output(new, self.path)

    def _unlock(self) -> None:
        if self._fd is not None:
            self._lock.unlink(missing_ok=True)  # before the lock drops: a waiting opener sees another inode
            os.close(self._fd)
            self._fd = None

    def release(self) -> None:
        """Remove the scratch directory and drop the lock (idempotent)."""
        if self._fd is not None:
            shutil.rmtree(self.scratch, ignore_errors=True)
        self._unlock()

    def __enter__(self) -> OutputClaim:
        return self

    def __exit__(self, *exc: object) -> None:
        self.release()


@contextmanager
def locked_directory(path: Path) -> Iterator[Path]:
    """Hold an exclusive lock (``flock`` on the directory itself) while a run writes its reports into ``path``:
    a second run writing there is refused at once; the kernel drops the lock when the holder dies."""
    fd = os.open(path, os.O_RDONLY | os.O_DIRECTORY)
    try:
        try:
            fcntl.flock(fd, fcntl.LOCK_EX | fcntl.LOCK_NB)
        except BlockingIOError:
            raise InputError(f"{path}: another run is writing its reports into it now; refusing to write there "
                             "too") from None
        yield path
    finally:
        os.close(fd)


def ensure_out_dir(path: Path) -> Path:
    """Create the report directory ``path`` (existing files inside are replaced one by one, atomically)."""
    try:
        path.mkdir(parents=True, exist_ok=True)
    except OSError as err:
        raise InputError(f"{path}: cannot create output directory ({err.strerror})") from None
    if not path.is_dir():
        raise InputError(f"{path}: output directory is a file")
    if not os.access(path, os.W_OK):
        raise InputError(f"{path}: output directory is not writable")
    return path


def atomic_write_bytes(path: Path, data: bytes) -> None:
    """Write ``data`` to ``path`` (replacing a file there) through an :class:`OutputClaim`."""
    with OutputClaim(path, force=True) as claim:
        new = claim.scratch / path.name
        new.write_bytes(data)
        claim.commit(new)


def atomic_write_text(path: Path, text: str) -> None:
    """Write ``text`` (UTF-8) to ``path`` atomically."""
    atomic_write_bytes(path, text.encode("utf-8"))


def atomic_write_yaml(path: Path, data: Any) -> None:
    """Write ``data`` as block-style YAML to ``path`` atomically."""
    atomic_write_text(path, yaml.safe_dump(data, sort_keys=False))


def atomic_save_figure(path: Path, figure: Any, title: str | None = None) -> None:
    """Save a matplotlib figure as PNG to ``path`` atomically; ``title``: its overall title (the trial it shows)."""
    if title is not None:
        figure.suptitle(title)
    with OutputClaim(path, force=True) as claim:
        new = claim.scratch / path.name
        figure.savefig(new, dpi=110, format="png")
        claim.commit(new)


def load_yaml(path: Path) -> Any:
    """Read a YAML file; a missing, binary or malformed file is an :class:`InputError` naming it."""
    try:
        text = path.read_bytes().decode("utf-8")
    except OSError as err:
        raise InputError(f"{path}: cannot read ({err.strerror})") from None
    except UnicodeDecodeError as err:
        raise InputError(f"{path}: not a UTF-8 text file (byte {err.start}); expected YAML") from None
    try:
        return yaml.safe_load(text)
    except yaml.YAMLError as err:
        mark = getattr(err, "problem_mark", None)
        where = f" at line {mark.line + 1}" if mark is not None else ""
        raise InputError(f"{path}: malformed YAML{where}") from None


def to_json(data: Any) -> str:
    """JSON for --json output: numpy scalars and arrays become plain numbers and lists, and a non-finite number
    (an unbounded interval, a value not measurable) becomes null: strict JSON, which every parser reads."""

    def plain(obj: Any) -> Any:
        if isinstance(obj, dict):
            return {key: plain(value) for key, value in obj.items()}
        if isinstance(obj, (list, tuple)):
            return [plain(value) for value in obj]
        if hasattr(obj, "tolist"):
            return plain(obj.tolist())
        if isinstance(obj, float) and not math.isfinite(obj):
            return None
        return obj

    return json.dumps(plain(data), indent=2, allow_nan=False)
