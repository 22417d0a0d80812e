"""Files and folders written whole or not at all.

A file is written to a temporary file beside it and renamed over it.

A design's output folder ``ROOT/<name>/`` is replaced as a whole (:func:`new_folder`): the new
version is written into a staging folder ``ROOT/.<name>.XXXX.tmp`` and swapped with the
published one by a single ``renameat2(RENAME_EXCHANGE)`` (Linux 3.15+, ext4, xfs, btrfs, tmpfs),
so at every instant ``ROOT/<name>/`` is one whole version, old or new, whatever is killed when.
Two writers at once both finish and the last to publish wins. Where the exchange is not
available, the old folder is first renamed aside to ``.<name>.previous`` (a kill between the
two renames leaves it there, and the next writer puts it back).

A published folder is never changed in place, only replaced. Readers take a snapshot
(:func:`snapshot`: hard links to its files, made in a few milliseconds) and read that, so a
version swapped in while they read does not mix with the one they started on.

Locks (``flock``, released by the kernel when a process dies, even by SIGKILL), no lock files:

* each staging folder is locked by the process writing it, so a staging folder that can be
  locked by someone else belongs to a dead process and is removed (:func:`clean_leftovers`);
* ``ROOT`` itself is locked exclusively while a staging folder is created and locked, while
  leftovers are removed, and while a version is swapped in; shared while a snapshot or a
  copy is taken. Each of these is short.
"""
from __future__ import annotations

import ctypes
import errno
import fcntl
import json
import os
import shutil
import tempfile
from collections.abc import Iterator
from contextlib import ExitStack, contextmanager
from pathlib import Path

AT_FDCWD = -100
RENAME_EXCHANGE = 2
STAGING_SUFFIX = ".tmp"


@contextmanager
def atomic_path(path: str | Path) -> Iterator[Path]:
    """A temporary path beside ``path`` to write to; it replaces ``path`` when the block ends
    without an error, and is removed when it raises."""
    path = Path(path)
    path.parent.mkdir(parents=True, exist_ok=True)
    fd, tmp = tempfile.mkstemp(prefix=f".{path.name}.", suffix=".tmp", dir=path.parent)
    os.close(fd)
    try:
        yield Path(tmp)
        os.chmod(tmp, 0o644)
        os.replace(tmp, path)
    except BaseException:
        Path(tmp).unlink(missing_ok=True)
        raise


def write_text(path: str | Path, text: str) -> None:
    with atomic_path(path) as tmp:
        tmp.write_text(text, encoding="utf-8")


def write_json(path: str | Path, obj) -> None:
    write_text(path, json.dumps(obj, indent=2) + "\n")


# ---------------------------------------------------------------- folders

def _renameat2():
    try:
        fn = ctypes.CDLL(None, use_errno=True).renameat2
    except (AttributeError, OSError):
        return None
    fn.argtypes = [ctypes.c_int, ctypes.c_char_p, ctypes.c_int, ctypes.c_char_p, ctypes.c_uint]
    fn.restype = ctypes.c_int
    return fn


_RENAMEAT2 = _renameat2()


def exchange(a: Path, b: Path) -> bool:
    """Swap two existing paths in one step. False where the system or file system cannot."""
    if _RENAMEAT2 is None:
        return False
    if _RENAMEAT2(AT_FDCWD, os.fsencode(a), AT_FDCWD, os.fsencode(b), RENAME_EXCHANGE) == 0:
        return True
    code = ctypes.get_errno()
    if code in (errno.EINVAL, errno.ENOSYS, errno.EOPNOTSUPP, errno.ENOTSUP):
        return False
    raise OSError(code, os.strerror(code), str(b))


@contextmanager
def _locked(root: Path, exclusive: bool = True) -> Iterator[None]:
    """Hold a ``flock`` on the directory ``root``."""
    fd = os.open(root, os.O_RDONLY | os.O_DIRECTORY)
    try:
        try:
            fcntl.flock(fd, fcntl.LOCK_EX if exclusive else fcntl.LOCK_SH)
        except OSError as e:          # a file system without locks (some network mounts): go on unlocked
            if e.errno not in (errno.ENOLCK, errno.EOPNOTSUPP, errno.ENOTSUP):
                raise
        yield
    finally:
        os.close(fd)


def _try_lock(path: Path) -> int | None:
    """An fd holding an exclusive lock on the directory ``path``, or None if another process holds it."""
    try:
        fd = os.open(path, os.O_RDONLY | os.O_DIRECTORY)
    except OSError:
        return None
    try:
        fcntl.flock(fd, fcntl.LOCK_EX | fcntl.LOCK_NB)
    except OSError:
        os.close(fd)
        return None
    return fd


def _previous(target: Path) -> Path:
    return target.with_name(f".{target.name}.previous")


def _identity(path: Path) -> tuple[int, int] | None:
    try:
        st = os.stat(path)
    except OSError:
        return None
    return st.st_dev, st.st_ino


def clean_leftovers(target: Path) -> list[Path]:
    """Remove what killed writers and readers of ``target`` left beside it: staging folders no
    live process holds, and an old version set aside (put back if ``target`` itself is
    missing). Returns what was removed or restored. Call it with the root locked exclusively
    (:func:`new_folder` does)."""
    root, name = target.parent, target.name
    done = []
    prev = _previous(target)
    if prev.exists():
        if target.exists():
            shutil.rmtree(prev, ignore_errors=True)
        else:
            os.rename(prev, target)
        done.append(prev)
    for p in sorted(root.glob(f".{name}.*{STAGING_SUFFIX}")):
        if not p.is_dir() or p.is_symlink():
            continue
        fd = _try_lock(p)
        if fd is None:
            continue                      # a live process's
        try:
            shutil.rmtree(p, ignore_errors=True)
        finally:
            os.close(fd)
        done.append(p)
    return done


@contextmanager
def _staging(target: Path) -> Iterator[Path]:
    """A fresh staging folder beside ``target``, locked by this process, removed at the end
    unless it was swapped in."""
    root = target.parent
    root.mkdir(parents=True, exist_ok=True)
    with _locked(root):
        clean_leftovers(target)
        staging = Path(tempfile.mkdtemp(prefix=f".{target.name}.", suffix=STAGING_SUFFIX, dir=root))
        fd = _try_lock(staging)
    try:
        yield staging
    finally:
        if _identity(staging) is not None:
            shutil.rmtree(staging, ignore_errors=True)
        if fd is not None:
            os.close(fd)


def _publish(staging: Path, target: Path, expect: tuple[int, int] | None) -> bool:
    """Swap ``staging`` in as ``target``; the old version is removed. With ``expect`` (the
    identity of the version ``staging`` was copied from) nothing is published if another
    writer published meanwhile: its version is newer. Returns whether it published."""
    with _locked(target.parent):
        if expect is not None and _identity(target) != expect:
            return False
        os.chmod(staging, 0o755)
        if target.exists() and exchange(staging, target):
            old = staging                 # the staging path now holds the old version
        elif target.exists():             # no exchange here: two renames, recoverable (see above)
            old = _previous(target)
            os.rename(target, old)
            os.rename(staging, target)
        else:
            os.rename(staging, target)
            old = None
    if old is not None:
        shutil.rmtree(old, ignore_errors=True)
    return True


@contextmanager
def new_folder(target: Path, copy_current: bool = False) -> Iterator[Path]:
    """A locked staging folder for a new version of ``target``, published when the block ends
    without an error and removed when it raises (or when the process dies: see the module).

    ``copy_current``: start from a copy of the published version (to add files to it); if
    another writer publishes before this block ends, this version is dropped for the newer one.
    """
    target = Path(target)
    with _staging(target) as staging:
        expect = None
        if copy_current:
            with _locked(target.parent, exclusive=False):
                expect = _identity(target)
                if expect is not None:
                    shutil.copytree(target, staging, dirs_exist_ok=True)
        yield staging
        _publish(staging, target, expect)


@contextmanager
def snapshot(target: Path) -> Iterator[Path]:
    """A private, unchanging view of the published ``target`` (hard links to its files) to
    read from; a path that does not exist if nothing is published. Removed at the end."""
    target = Path(target)
    if not target.parent.is_dir():
        yield target
        return
    with ExitStack() as stack:
        try:
            staging = stack.enter_context(_staging(target))
        except OSError:              # no root, or a root this process may not write: nobody swaps there
            yield target
            return
        with _locked(target.parent, exclusive=False):
            if _identity(target) is None:
                shutil.rmtree(staging, ignore_errors=True)
            else:
                shutil.copytree(target, staging, dirs_exist_ok=True, copy_function=_link_or_copy)
        yield staging


@contextmanager
def side_folder(folder: Path, target: Path) -> Iterator[Path]:
    """A private staging folder beside ``target`` holding hard links to ``folder``'s files, for
    work that runs beside other work on ``folder`` and whose new files are moved into it after;
    removed at the end (or by the next writer, if this process dies)."""
    with _staging(Path(target)) as staging:
        shutil.copytree(folder, staging, dirs_exist_ok=True, copy_function=_link_or_copy)
        yield staging


def _link_or_copy(src: str, dst: str) -> None:
    try:
        os.link(src, dst)
    except OSError:
        shutil.copy2(src, dst)
