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

import errno
import fcntl
import json
import math
import os
import re
import shutil
import signal
import stat
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
    "reports": ("directory of reports", lambda p: p.is_dir()),
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


def resolved_path(path: Path) -> Path:
    """``path`` with its symlinks resolved; a symlink loop is an :class:`InputError` naming it."""
    try:
        return path.resolve()
    except (RuntimeError, OSError) as err:  # Python < 3.13 raises RuntimeError for a loop
        raise InputError(f"{path}: cannot resolve it (a symlink loop?): {err}") from None


def prepare_output(path: Path, force: bool, kind: str = "file") -> None:
    """Check that ``path`` may be written, before any work; nothing is deleted here.

    Refused: the current directory or one that contains it, an existing path without ``force``, with ``force``
    a path that is not an output of this ``kind`` (:data:`REPLACEABLE`), and an output another run is writing
    now. :class:`OutputClaim` checks again under the lock when the output is written.
    """
    resolved = resolved_path(path)
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
    target = resolved_path(out)
    for item in inputs:
        if item is not None and (resolved_path(item) == target or target in resolved_path(item).parents):
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


def sync_tree(path: Path) -> None:
    """``fsync`` the file ``path``, or every file and directory under the directory ``path``: data a file system
    accepted into its cache but could not place (a full disk under delayed allocation, a quota, NFS) is an
    OSError here, not a file silently short after the rename."""
    items = [path] if not path.is_dir() else [Path(root) / name for root, _, files in os.walk(path)
                                              for name in (*files, ".")]
    for item in items:
        mode = os.lstat(item).st_mode
        if not (stat.S_ISREG(mode) or stat.S_ISDIR(mode)):  # a link, or a user's FIFO a report set keeps
            continue
        try:
            fd = os.open(item, os.O_RDONLY)
        except PermissionError:  # a user's unreadable file a report set keeps (linked, not written by this run)
            continue
        try:
            os.fsync(fd)
        except OSError as err:
            raise OSError(err.errno, err.strerror, str(item)) from None
        finally:
            os.close(fd)


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
        """Move the complete new output ``new`` (inside :attr:`scratch`) to ``path``. SIGINT and SIGTERM are
        held back during the renames (and acted on right after): a signal never lands between them. Every file
        of ``new`` is flushed to the disk first (:func:`sync_tree`): a full disk reported only then is an error
        here, and nothing incomplete is renamed into place."""
        try:
            sync_tree(new)
        except OSError as err:
            if not is_write_failure(err):
                raise
            inside = Path(err.filename).relative_to(new) if new.is_dir() else Path()
            raise InputError(f"{self.path / inside}: cannot write it ({write_failure(err)}); nothing was "
                             "replaced") from None
        with signals_held():
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

    def __exit__(self, kind: type[BaseException] | None, exc: BaseException | None, tb: object) -> None:
        self.release()
        if exc is not None and is_write_failure(exc):
            raise InputError(f"{self.path}: cannot write it ({write_failure(exc)}); nothing was replaced") from None


@contextmanager
def signals_held() -> Iterator[None]:
    """SIGINT and SIGTERM held back (in this thread) for the ``with`` block and acted on right after it: what the
    block does (a few renames, a pair of small files that must agree) is never cut in the middle."""
    held = signal.pthread_sigmask(signal.SIG_BLOCK, {signal.SIGINT, signal.SIGTERM})
    try:
        yield
    finally:
        signal.pthread_sigmask(signal.SIG_SETMASK, held)


WRITE_FAILURES = (errno.ENOSPC, errno.EFBIG, errno.EDQUOT, errno.EROFS)
"""errno of a write that failed for lack of room (full disk, file-size limit, quota) or a read-only file system."""


def is_write_failure(exc: BaseException) -> bool:
    """A full disk, a file-size limit or a quota met while writing (OSError, or sqlite3's "disk is full")."""
    if isinstance(exc, OSError):
        return exc.errno in WRITE_FAILURES
    return type(exc).__name__ == "OperationalError" and any(
        word in str(exc).lower() for word in ("disk is full", "disk i/o error", "too big"))


def write_failure(exc: BaseException) -> str:
    """The reason of a :func:`is_write_failure` in words."""
    return exc.strerror if isinstance(exc, OSError) and exc.strerror else str(exc)


class ReportSet:
    """The report files a verb writes into ``--out DIR``, replaced all at once or not at all.

    ``DIR`` is claimed as one output (:class:`OutputClaim`: one writer, leftovers of killed runs restored or
    removed). The new set is written into :attr:`staging`, a copy of ``DIR`` beside it (hard links: other files
    of ``DIR`` are kept, the verb's own ``names`` left out), and swapped in by :meth:`commit`; until then ``DIR``
    holds the old set untouched, and an error or an interrupt drops the new one whole. Without ``force`` a
    ``DIR`` already holding one of ``names`` is refused; ``DIR`` itself may exist (it is locked for the run).
    """

    def __init__(self, path: Path, names: tuple[str, ...], force: bool,
                 kinds: dict[str, str | tuple[str, ...]] | None = None) -> None:
        if path.is_symlink() and resolved_path(path).is_dir():
            path = resolved_path(path)  # write into the directory the link names, keep the link
        self._kinds = kinds or {}
        self._check(path, names, force, self._kinds)
        self.path = path
        self._dir_lock = _lock_directory(path) if path.is_dir() else None
        try:
            self._claim = OutputClaim(path, force=True, kind="reports")
        except BaseException:
            self._unlock_dir()
            raise
        try:
            self._check(path, names, force, self._kinds)  # again: the claim may have restored a set moved aside
            self.staging = self._claim.scratch / path.name
            if path.is_dir():
                _link_tree(path, self.staging)
                for name in names:
                    if (self.staging / name).exists() or (self.staging / name).is_symlink():
                        _remove(self.staging / name)
            else:
                self.staging.mkdir()
        except OSError as err:
            self.release()
            raise InputError(f"{path}: cannot prepare the new report set beside it ({err.strerror})") from None
        except BaseException:
            self.release()
            raise

    @staticmethod
    def _check(path: Path, names: tuple[str, ...], force: bool, kinds: dict[str, str | tuple[str, ...]]) -> None:
        if path.exists() and not path.is_dir():
            raise InputError(f"{path}: --out must be a directory for the reports, and this is a file")
        for name in names:
            item = path / name
            if not (item.exists() or item.is_symlink()):
                continue
            if not force:
                raise InputError(f"{item} exists; use --force to overwrite it")
            _check_same_kind(item, kinds.get(name, "file"))

    def commit(self) -> None:
        """Swap the complete new set in place of ``DIR``."""
        self._claim.commit(self.staging)

    def _unlock_dir(self) -> None:
        if self._dir_lock is not None:
            os.close(self._dir_lock)
            self._dir_lock = None

    def release(self) -> None:
        """Drop an uncommitted new set and the locks (idempotent)."""
        if hasattr(self, "_claim"):
            self._claim.release()
        self._unlock_dir()

    def __enter__(self) -> ReportSet:
        return self

    def __exit__(self, kind: type[BaseException] | None, exc: BaseException | None, tb: object) -> None:
        named = self._named(exc) if exc is not None and hasattr(self, "staging") else None
        try:
            if hasattr(self, "_claim"):
                self._claim.__exit__(kind, None if named is not None else exc, tb)
        finally:
            self._unlock_dir()
        if named is not None:
            raise named from None

    def _named(self, exc: BaseException) -> InputError | None:
        """An error about a file of the new set, naming it as ``DIR/NAME`` (the user's name for it), not by its
        place in the scratch copy; None for any other error."""
        scratch = str(self.staging)
        if isinstance(exc, InputError) and scratch in str(exc):
            return InputError(str(exc).replace(scratch, str(self.path)))
        filename = str(getattr(exc, "filename", None) or "")
        if is_write_failure(exc) and filename.startswith(scratch):
            return InputError(f"{self.path}{filename[len(scratch):]}: cannot write it ({write_failure(exc)}); nothing "
                              "was replaced")
        return None


def _check_same_kind(item: Path, kind: str | tuple[str, ...]) -> None:
    """--force replaces ``item`` (one output of a report set) only if it is an output of ``kind``: a key of
    :data:`REPLACEABLE` (a report file: ``"file"``), or the names of the files of a report directory (a directory
    holding only such files). A directory where a file goes, a user's file inside a report directory: refused."""
    if isinstance(kind, tuple):
        what = f"directory of {', '.join(kind)}"
        same = item.is_dir() and not item.is_symlink() and all(
            entry.name in kind and entry.is_file() for entry in item.iterdir())
    else:
        what, replaceable = REPLACEABLE[kind]
        same = replaceable(item)
    if not same:
        found = ("a directory holding other files" if isinstance(kind, tuple) and item.is_dir() else
                 "a directory" if item.is_dir() else "a file" if item.is_file() else "not a regular file")
        raise InputError(f"{item}: is {found}, not a {what}; --force replaces only an output of the same kind, "
                         "refusing to replace it")


def _link_tree(source: Path, target: Path) -> None:
    """``target``: a copy of the directory ``source`` made of hard links (a plain copy where links fail)."""

    def link(src: str, dst: str) -> None:
        try:
            os.link(src, dst, follow_symlinks=False)
        except OSError:
            shutil.copy2(src, dst, follow_symlinks=False)

    shutil.copytree(source, target, symlinks=True, copy_function=link)


@contextmanager
def locked_directory(path: Path) -> Iterator[Path]:
    """Hold an exclusive lock (``flock`` on the directory itself) while a run writes its reports into ``path``:
    a second run writing there is refused at once; the kernel drops the lock when the holder dies."""
    fd = _lock_directory(path)
    try:
        yield path
    finally:
        os.close(fd)


def _lock_directory(path: Path) -> int:
    """An open descriptor of the directory ``path`` holding its exclusive ``flock``; refused if held."""
    fd = os.open(path, os.O_RDONLY | os.O_DIRECTORY)
    try:
        fcntl.flock(fd, fcntl.LOCK_EX | fcntl.LOCK_NB)
    except BlockingIOError:
        os.close(fd)
        raise InputError(f"{path}: another run is writing its reports into it now; refusing to write there "
                         "too") from None
    return fd


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


PNG_COMPRESS_LEVEL = 1
"""zlib level of the PNG figures: the same pixels as the default 6 in 60 % of the encoding time (a tenth of a
second of a ``diagnose`` report's five figures), files ~13 % larger."""


def atomic_save_figure(path: Path, figure: Any, title: str | None = None) -> None:
    """Save a matplotlib figure as PNG to ``path`` atomically; ``title``: its overall title (the trial it shows)."""
    if title is not None:
        figure.suptitle(title)
    with OutputClaim(path, force=True) as claim:
        new = claim.scratch / path.name
        figure.savefig(new, dpi=110, format="png", pil_kwargs={"compress_level": PNG_COMPRESS_LEVEL})
        claim.commit(new)


MAX_YAML_BYTES = 4 << 20
"""Largest YAML input file, bytes (the shipped configs and calibrations are a few kB)."""
MAX_YAML_DEPTH = 64
"""Deepest nesting of a YAML input (the configs nest 4 levels)."""
MAX_YAML_NODES = 1_000_000
"""Most nodes a YAML input may stand for with its aliases expanded (an alias bomb stands for billions)."""
MAX_YAML_INT_DIGITS = 30
"""Longest integer literal in a YAML input (beyond int64 and float64's exact integers, no quantity needs more)."""


class _YamlBound(yaml.YAMLError):
    """A YAML input beyond a bound, or with a duplicate key: its message is the reason."""

    def __init__(self, reason: str, mark: Any = None) -> None:
        super().__init__(reason)
        self.problem, self.problem_mark = reason, mark


class BoundedLoader(yaml.SafeLoader):
    """``yaml.SafeLoader`` with bounds checked before anything is built: nesting depth (:data:`MAX_YAML_DEPTH`),
    nodes with aliases expanded (:data:`MAX_YAML_NODES`), integer length (:data:`MAX_YAML_INT_DIGITS`); a key
    given twice in one mapping is refused (the last would silently win)."""

    def __init__(self, stream: str) -> None:
        super().__init__(stream)
        self._depth = 0

    def compose_node(self, parent: Any, index: Any) -> Any:
        self._depth += 1
        try:
            if self._depth > MAX_YAML_DEPTH:
                raise _YamlBound(f"nested deeper than {MAX_YAML_DEPTH} levels", self.peek_event().start_mark)
            return super().compose_node(parent, index)
        finally:
            self._depth -= 1

    def get_single_node(self) -> Any:
        node = super().get_single_node()
        if node is not None:
            _check_expanded_size(node)
        return node

    def construct_mapping(self, node: Any, deep: bool = False) -> Any:
        if isinstance(node, yaml.MappingNode):
            seen: set[Any] = set()
            for key_node, _ in node.value:
                if key_node.tag == "tag:yaml.org,2002:merge":
                    continue
                key = self.construct_object(key_node, deep=True)
                try:
                    duplicate = key in seen
                    seen.add(key)
                except TypeError:  # an unhashable key: refused by the constructor below
                    continue
                if duplicate:
                    raise _YamlBound(f"key {key!r} given twice (the first would be silently dropped)",
                                     key_node.start_mark)
        return super().construct_mapping(node, deep)

    def construct_yaml_int(self, node: Any) -> Any:
        digits = sum(ch.isdigit() for ch in str(node.value))
        if digits > MAX_YAML_INT_DIGITS:
            raise _YamlBound(f"an integer of {digits} digits (at most {MAX_YAML_INT_DIGITS})", node.start_mark)
        return super().construct_yaml_int(node)


BoundedLoader.add_constructor("tag:yaml.org,2002:int", BoundedLoader.construct_yaml_int)


def _check_expanded_size(root: Any) -> None:
    """Count the nodes ``root`` stands for with every alias expanded, without expanding (each node's count is
    computed once); beyond :data:`MAX_YAML_NODES`, or a node that contains itself, is a :class:`_YamlBound`."""
    sizes: dict[int, int] = {}
    stack: list[tuple[Any, bool]] = [(root, False)]
    open_nodes: set[int] = set()
    while stack:
        node, done = stack.pop()
        if id(node) in sizes:
            continue
        children = ([item for pair in node.value for item in pair] if isinstance(node, yaml.MappingNode)
                    else node.value if isinstance(node, yaml.SequenceNode) else [])
        if done:
            open_nodes.discard(id(node))
            sizes[id(node)] = size = 1 + sum(sizes[id(child)] for child in children)
            if size > MAX_YAML_NODES:
                raise _YamlBound(f"stands for more than {MAX_YAML_NODES:,} values with its aliases expanded (an "
                                 "alias bomb?)", node.start_mark)
            continue
        if id(node) in open_nodes:
            raise _YamlBound("an alias refers to a node that contains it", node.start_mark)
        open_nodes.add(id(node))
        stack.append((node, True))
        stack.extend((child, False) for child in children if id(child) not in sizes)


def regular_input(path: Path, what: str = "input file") -> Path:
    """``path`` if it is a regular file (or a directory); a FIFO, a device or a socket is refused: reading one
    could block forever or never end."""
    try:
        mode = os.stat(path).st_mode
    except OSError as err:
        raise InputError(f"{path}: cannot read ({err.strerror})") from None
    if not (stat.S_ISREG(mode) or stat.S_ISDIR(mode)):
        raise InputError(f"{path}: not a regular file (a FIFO, device or socket); expected a {what}")
    return path


def load_yaml(path: Path) -> Any:
    """Read a YAML file; a missing, binary, malformed or oversized file is an :class:`InputError` naming it.

    Bounded before parsing (every YAML reader comes here): a regular file of at most :data:`MAX_YAML_BYTES`,
    then :class:`BoundedLoader`'s depth, alias-expansion and integer bounds; duplicate keys refused."""
    if regular_input(path, "YAML file").is_dir():
        raise InputError(f"{path}: is a directory; expected a YAML file")
    try:
        with path.open("rb") as fh:
            raw = fh.read(MAX_YAML_BYTES + 1)
    except OSError as err:
        raise InputError(f"{path}: cannot read ({err.strerror})") from None
    if len(raw) > MAX_YAML_BYTES:
        raise InputError(f"{path}: larger than {MAX_YAML_BYTES >> 20} MiB; not a configuration file")
    try:
        text = raw.decode("utf-8")
    except UnicodeDecodeError as err:
        raise InputError(f"{path}: not a UTF-8 text file (byte {err.start}); expected YAML") from None
    try:
        return yaml.load(text, Loader=BoundedLoader)  # noqa: S506 - a SafeLoader with bounds
    except (yaml.YAMLError, RecursionError) as err:
        mark = getattr(err, "problem_mark", None)
        where = f" at line {mark.line + 1}" if mark is not None else ""
        reason = f": {err.problem}" if isinstance(err, _YamlBound) else ""
        raise InputError(f"{path}: malformed YAML{where}{reason}") from None


def check_trial_path(path: Path) -> None:
    """A trial is a regular file, or a directory (a rosbag2) of regular files: a FIFO, a device or a socket,
    itself or as a bag's metadata.yaml or storage file, is refused (reading it could block forever); a bag's
    metadata.yaml must pass the YAML bounds of :func:`~boat_twin.files.load_yaml` (an alias bomb is refused)."""
    if not (path.exists() or path.is_symlink()):
        return  # each reader names a missing file its own way
    regular_input(path, "trial file")
    if path.is_dir():
        for entry in sorted(path.iterdir()):
            if entry.name == "metadata.yaml" or entry.suffix in (".mcap", ".db3"):
                regular_input(entry, "bag file")
        if (path / "metadata.yaml").is_file():
            load_yaml(path / "metadata.yaml")  # the YAML bounds (size, depth, aliases) before rosbags parses it


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
