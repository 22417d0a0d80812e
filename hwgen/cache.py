"""A content-addressed store for what is expensive to make: part files, keyed by what made them.

Two kinds of entry, both under one root (``--cache-dir``; default ``$HWGEN_CACHE_DIR``, else
``$XDG_CACHE_HOME/hwgen``, else ``~/.cache/hwgen``, never inside ``out/``):

* ``objects/ab/abcd…``: bytes (an STL, a STEP, a BREP), named by their own sha256. A read
  hashes them again; bytes that do not match their name are a corrupt entry: it is deleted and
  reported as missing, so the caller makes it afresh.
* ``records/ab/abcd….json``: a JSON record, named by its key (:func:`key`, the sha256 of the
  canonical form of everything that made it). The file holds the record and the sha256 of the
  record's canonical text; one that does not parse or does not match is corrupt, as above.

Every read or write of an entry marks it used (its modification time); :meth:`Store.trim` removes
the least recently used until the store is within its size (``--cache-size``, ``$HWGEN_CACHE_SIZE``,
default :data:`DEFAULT_SIZE`); every build and check trims it when it ends.

Every write goes to a temporary file in the entry's own folder and is renamed over the name
(:func:`os.replace`), so two builds sharing a cache never see half an entry: the last writer of
a record wins, and both wrote the same thing. So that they do not make the same entry twice at
once, a build takes the entry's lock first (:meth:`Store.lock`, :meth:`Store.try_lock`: an
``flock`` on ``locks/ab/abcd….lock``, let go when its holder ends, even when killed) and reads
the entry again once it has it. Nothing here knows about parts or CAD; it only
hashes plain data (frozen dataclasses, pydantic models, numpy arrays, JSON values) and stores
bytes.
"""
from __future__ import annotations

import dataclasses
import enum
import hashlib
import json
import os
import tempfile
from collections.abc import Callable, Iterator
from contextlib import ExitStack, contextmanager, nullcontext, suppress
from contextvars import ContextVar
from functools import lru_cache
from pathlib import Path

import numpy as np

ENV_DIR = "HWGEN_CACHE_DIR"
ENV_SIZE = "HWGEN_CACHE_SIZE"
DEFAULT_SIZE = 2 * 1024 ** 3  # bytes: about 25 builds of the prototype (75 MB each, files, solids and stages)
LAYOUT = "v1"                 # the on-disk layout; a change of it starts a fresh store beside the old
_UNITS = {"": 1, "K": 1024, "M": 1024 ** 2, "G": 1024 ** 3, "T": 1024 ** 4}


def default_dir() -> Path:
    """Where the cache lives unless ``--cache-dir`` says otherwise."""
    if os.environ.get(ENV_DIR):
        return Path(os.environ[ENV_DIR])
    base = os.environ.get("XDG_CACHE_HOME") or os.path.join(os.path.expanduser("~"), ".cache")
    return Path(base) / "hwgen"


def parse_size(text: str) -> int:
    """``2G``, ``500M``, ``1.5GB``, ``300000`` (bytes) as a count of bytes; ValueError if it is none."""
    t = str(text).strip().upper().removesuffix("IB").removesuffix("B")
    unit = t[-1:] if t[-1:] in _UNITS and t[-1:] else ""
    number = float(t[:-1] if unit else t)
    if not number >= 0 or number == float("inf"):
        raise ValueError(f"{text!r} is not a size")
    return int(number * _UNITS[unit])


# ---------------------------------------------------------------- keys

def canonical(obj) -> object:
    """``obj`` as plain JSON values, the same for equal inputs in every process: a dataclass as
    its class name and fields in order, a pydantic model as its JSON dump, an array as dtype,
    shape and values, floats exactly (JSON's repr round-trips a double), dict keys sorted.
    Anything else is a TypeError: a key must never depend on an object's address."""
    if obj is None or isinstance(obj, (bool, str)):
        return obj
    if isinstance(obj, enum.Enum):
        return canonical(obj.value)
    if isinstance(obj, (int, np.integer)):
        return int(obj)
    if isinstance(obj, (float, np.floating)):
        f = float(obj)
        return f if np.isfinite(f) else repr(f)
    if isinstance(obj, np.ndarray):
        return {"ndarray": str(obj.dtype), "shape": list(obj.shape), "values": canonical(obj.tolist())}
    if dataclasses.is_dataclass(obj) and not isinstance(obj, type):
        return {"dataclass": type(obj).__qualname__,
                "fields": [[f.name, canonical(getattr(obj, f.name))] for f in dataclasses.fields(obj)]}
    if hasattr(obj, "model_dump") and hasattr(type(obj), "model_fields"):      # pydantic
        return {"model": type(obj).__qualname__, "fields": canonical(obj.model_dump(mode="json"))}
    if isinstance(obj, dict):
        if all(type(k) is str for k in obj):          # the common case, ordered without a JSON text per entry
            return {"dict": [[k, canonical(obj[k])] for k in sorted(obj)]}
        return {"dict": sorted(([canonical(k), canonical(v)] for k, v in obj.items()), key=json.dumps)}
    if isinstance(obj, (list, tuple)):
        return [canonical(v) for v in obj]
    if isinstance(obj, (set, frozenset)):
        return {"set": sorted((canonical(v) for v in obj), key=json.dumps)}
    if isinstance(obj, Path):
        return str(obj)
    raise TypeError(f"cannot key a {type(obj).__name__}")


def _text(obj) -> bytes:
    return json.dumps(obj, sort_keys=True, separators=(",", ":"), ensure_ascii=True).encode()


def key(*parts) -> str:
    """The sha256 of the canonical form of ``parts`` (equal values, equal digests). A store's
    entries are named by :func:`entry_key`, which is made with it."""
    return hashlib.sha256(_text(canonical(list(parts)))).hexdigest()


# the parts of hwgen's code (folders of the package, "data" its tables) a kept value may depend on
ALL_CODE = ("",)                        # the whole package
SOLID_CODE = ("cad", "model", "data")   # what makes the solids: the model, the CAD and the tables they read
NO_CODE = ()                            # a value no hwgen code shapes (a library's parse of a file)

# the libraries whose versions a remembered value depends on unless it names its own
LIBRARIES = ("numpy", "scipy", "numba", "trimesh", "manifold3d", "matplotlib", "vtk", "pillow", "ezdxf",
             "cadquery", "cadquery-ocp", "lib3mf", "rectpack")


def entry_key(kind: str, inputs, *, code: tuple[str, ...] = ALL_CODE, libraries: tuple[str, ...] = ()) -> str:
    """The one rule every entry of the store is named by: what kind of entry it is, its inputs (any
    value :func:`canonical` takes), hwgen's version and the digest of the parts of its code the
    value depends on (:func:`code_digest`), and the versions of the libraries it names. An entry
    made by other code, or by another version of a library it names, is not found."""
    return key(kind, inputs, _version(), code_digest(tuple(code)) if code else None,
               {dist: library_version(dist) for dist in libraries})


def _version() -> str:
    from . import __version__
    return __version__


@lru_cache(maxsize=None)
def code_files(scope: tuple[str, ...]) -> tuple[Path, ...]:
    """The files of hwgen's package under the folders ``scope`` names ("": all of it; "data": its
    tables): every .py file there, and every table in data/ when the whole package or "data" is named."""
    root = Path(__file__).resolve().parent
    out = set()
    for part in scope:
        if part == "data" or part == "":
            out |= set(root.glob("data/*"))
        if part != "data":
            out |= set((root / part).rglob("*.py") if part else root.rglob("*.py"))
    return tuple(sorted(out))


@lru_cache(maxsize=None)
def code_digest(scope: tuple[str, ...]) -> str:
    """The sha256 of :func:`code_files` (their paths and bytes)."""
    root = Path(__file__).resolve().parent
    h = hashlib.sha256()
    for f in code_files(scope):
        h.update(str(f.relative_to(root)).encode() + b"\0" + f.read_bytes() + b"\0")
    return h.hexdigest()


@lru_cache(maxsize=None)
def library_version(dist: str) -> str | None:
    """The installed version of the distribution ``dist`` (None: not installed)."""
    from importlib.metadata import PackageNotFoundError, version
    try:
        return version(dist)
    except PackageNotFoundError:
        return None


def sha256(data: bytes) -> str:
    return hashlib.sha256(data).hexdigest()


# ---------------------------------------------------------------- the store

class Store:
    """The cache at ``root`` (None: no cache: every get misses, every put is dropped)."""

    def __init__(self, root: Path | None):
        self.folder = None if root is None else Path(root)     # as given (another process opens it again)
        self.root = None if root is None else Path(root) / LAYOUT
        self.corrupt: list[str] = []          # entries found damaged (and removed) by this store
        self.unwritable: str | None = None    # why the store turned itself off, if it did

    @property
    def enabled(self) -> bool:
        return self.root is not None

    def _path(self, kind: str, name: str, suffix: str = "") -> Path:
        return self.root / kind / name[:2] / (name + suffix)

    def _write(self, path: Path, data: bytes) -> None:
        """Write an entry whole or not at all. A cache that cannot be written (no permission, a
        full disk) costs the reuse, never the build: the store turns itself off and says why."""
        try:
            self._replace(path, data)
        except OSError as e:
            self.unwritable = f"{self.root}: {e.strerror or e}"
            self.root = None

    def _replace(self, path: Path, data: bytes) -> None:
        path.parent.mkdir(parents=True, exist_ok=True)
        fd, tmp = tempfile.mkstemp(dir=path.parent, prefix=".tmp-")
        try:
            with os.fdopen(fd, "wb") as f:
                f.write(data)
            os.replace(tmp, path)
        except BaseException:
            with suppress(OSError):     # the temp file never made: nothing to remove
                os.unlink(tmp)
            raise

    @staticmethod
    def _used(path: Path) -> None:
        """Mark an entry as just used (its modification time; access times are often not kept)."""
        with suppress(OSError):     # a read-only store: its entries age by when they were made
            os.utime(path)

    def trim(self, limit: int) -> tuple[int, int]:
        """Remove the least recently used entries (records and bytes alike) until the store holds
        at most ``limit`` bytes. Returns (entries removed, bytes freed). An entry removed under a
        build that shares the store is a miss for it, made again: never a wrong file."""
        if not self.enabled or not self.root.is_dir():
            return 0, 0
        entries, total = [], 0
        self._drop_free_locks()
        for kind in ("objects", "records"):
            for sub in os.scandir(self.root / kind) if (self.root / kind).is_dir() else ():
                for e in os.scandir(sub.path) if sub.is_dir() else ():
                    try:
                        st = e.stat()
                    except OSError:
                        continue
                    entries.append((st.st_mtime_ns, st.st_size, e.path))
                    total += st.st_size
        removed = freed = 0
        for _, size, path in sorted(entries):
            if total - freed <= limit:
                break
            try:
                os.unlink(path)
            except OSError:
                continue
            removed, freed = removed + 1, freed + size
        return removed, freed

    # one maker of an entry at a time
    def try_lock(self, name: str):
        """A context holding the lock on entry ``name`` (a record's key), or None when another
        process holds it: that one is making the entry now, and the caller does other work first.
        Without a store there is nothing to share and the lock is always free."""
        if not self.enabled:
            return nullcontext()
        return self._lock(name, blocking=False)

    def lock(self, name: str):
        """A context holding the lock on entry ``name``, waiting for it while another process
        holds it (it is making the entry: read it again once inside)."""
        if not self.enabled:
            return nullcontext()
        return self._lock(name, blocking=True)

    def _lock(self, name: str, blocking: bool):
        try:
            import fcntl
        except ImportError:                       # no flock (Windows): builds may make an entry twice
            return nullcontext()
        path = self._path("locks", name, ".lock")
        stack = ExitStack()
        try:
            path.parent.mkdir(parents=True, exist_ok=True)
            f = stack.enter_context(open(path, "a"))
            fcntl.flock(f, fcntl.LOCK_EX | (0 if blocking else fcntl.LOCK_NB))
        except BlockingIOError:
            stack.close()
            return None
        except OSError:                           # a store that cannot hold locks shares no work
            stack.close()
            return nullcontext()
        stack.callback(fcntl.flock, f, fcntl.LOCK_UN)
        return stack

    def _drop_free_locks(self) -> None:
        """Remove the lock files no process holds (one is left per entry ever made)."""
        try:
            import fcntl
        except ImportError:
            return
        top = self.root / "locks"
        for sub in os.scandir(top) if top.is_dir() else ():
            for e in os.scandir(sub.path) if sub.is_dir() else ():
                try:
                    with open(e.path, "a") as f:
                        fcntl.flock(f, fcntl.LOCK_EX | fcntl.LOCK_NB)
                        os.unlink(e.path)
                except OSError:
                    continue

    def _drop(self, path: Path, what: str) -> None:
        self.corrupt.append(what)
        with suppress(OSError):     # gone already (another process dropped it) or read-only: not read again
            path.unlink()

    # bytes, by their own hash
    def put_bytes(self, data: bytes) -> str:
        name = sha256(data)
        if self.enabled:
            path = self._path("objects", name)
            if not path.exists():
                self._write(path, data)
            else:
                self._used(path)
        return name

    def get_bytes(self, name: str) -> bytes | None:
        if not self.enabled:
            return None
        path = self._path("objects", name)
        try:
            data = path.read_bytes()
        except OSError:
            return None
        if sha256(data) != name:
            self._drop(path, f"object {name[:12]}")
            return None
        self._used(path)
        return data

    # records, by their key
    def put_record(self, key_: str, record) -> None:
        if not self.enabled:
            return
        body = json.loads(json.dumps(record))          # as it will read back, keys in their order
        self._write(self._path("records", key_, ".json"),
                    json.dumps({"record": body, "sha256": sha256(_text(body))}).encode())

    def get_record(self, key_: str):
        if not self.enabled:
            return None
        path = self._path("records", key_, ".json")
        try:
            text = path.read_bytes()
        except OSError:
            return None
        try:
            doc = json.loads(text)
            body = doc["record"]
            ok = doc["sha256"] == sha256(_text(body))
        except (ValueError, TypeError, KeyError):
            ok = False
        if not ok:
            self._drop(path, f"record {key_[:12]}")
            return None
        self._used(path)
        return body


# ---------------------------------------------------------------- values remembered between runs

_ACTIVE: ContextVar[Store | None] = ContextVar("hwgen_active_store", default=None)
_RECALL_ONLY: ContextVar[bool] = ContextVar("hwgen_recall_only", default=False)


class NotRemembered(Exception):
    """A :func:`remembered` value that is not in the store, met under :func:`recalling_only`."""


@contextmanager
def using(store: Store) -> Iterator[None]:
    """Within: :func:`remembered` values are read from and kept in ``store``."""
    token = _ACTIVE.set(store)
    try:
        yield
    finally:
        _ACTIVE.reset(token)


def active() -> Store | None:
    """The store :func:`using` made active here, if any."""
    return _ACTIVE.get()


@contextmanager
def recalling_only() -> Iterator[None]:
    """Within: a :func:`remembered` value not in the active store raises :class:`NotRemembered`
    instead of being computed (whether work can be skipped is told without doing any of it)."""
    token = _RECALL_ONLY.set(True)
    try:
        yield
    finally:
        _RECALL_ONLY.reset(token)


def as_json(value):
    """``value`` as JSON gives it back (numpy scalars and arrays as Python numbers and lists): what
    :func:`remembered` hands out, fresh or kept."""
    return json.loads(json.dumps(value, default=_plain))


def _plain(obj):
    if isinstance(obj, np.generic):
        return obj.item()
    if isinstance(obj, np.ndarray):
        return obj.tolist()
    raise TypeError(f"{type(obj).__name__} is not JSON")


def kept_arrays(kind: str, inputs, compute: Callable[[], dict[str, np.ndarray]], *,
                code: tuple[str, ...] = ALL_CODE, libraries: tuple[str, ...] = LIBRARIES) -> dict[str, np.ndarray]:
    """``compute()``, a few named numpy arrays, or the very arrays it gave last time for ``kind``
    and ``inputs`` when a store is active (:func:`using`): dtype, shape and bytes as they were,
    each array its own writable copy. Keyed as every entry is (:func:`entry_key`: the code and
    the libraries the arrays depend on). The bytes are one object of the store (``objects/``,
    checked by its hash on every read), its record lists each array's name, dtype and shape."""
    store = _ACTIVE.get()
    if store is None or not store.enabled:
        return compute()
    k = entry_key("arrays " + kind, inputs, code=code, libraries=libraries)
    rec = store.get_record(k)
    if isinstance(rec, dict) and isinstance(rec.get("arrays"), list):
        data = store.get_bytes(str(rec.get("object", "")))
        if data is not None:
            got = _split_arrays(bytearray(data), rec["arrays"])
            if got is not None:
                return got
    arrays = compute()
    parts = [np.ascontiguousarray(a) for a in arrays.values()]
    name = store.put_bytes(b"".join(a.tobytes() for a in parts))
    store.put_record(k, {"object": name,
                         "arrays": [[n, a.dtype.str, list(a.shape)] for n, a in zip(arrays, parts)]})
    return arrays


def _split_arrays(buffer: bytearray, layout: list) -> dict[str, np.ndarray] | None:
    """The arrays a :func:`kept_arrays` object holds, as its record lays them out (None when the
    two disagree)."""
    out, at = {}, 0
    try:
        for name, dtype, shape in layout:
            dt = np.dtype(dtype)
            count = int(np.prod(shape, dtype=np.int64))
            out[name] = np.frombuffer(buffer, dtype=dt, count=count, offset=at).reshape(shape)
            at += count * dt.itemsize
    except (ValueError, TypeError):
        return None
    return out if at == len(buffer) else None


def remembered(kind: str, inputs, compute: Callable[[], object], *, code: tuple[str, ...] = ALL_CODE,
               libraries: tuple[str, ...] = LIBRARIES):
    """``compute()`` as JSON gives it back, or what it gave last time for ``kind`` and ``inputs``
    (keyed as every entry is, :func:`entry_key`: by default on all of hwgen's code and the
    versions of :data:`LIBRARIES`) when a store is active (:func:`using`). The value is the same
    either way: a fresh one goes through JSON too. It is computed under the entry's lock: a caller
    that finds another process or thread computing it waits and reads what that one kept (a
    build's checks meet the work its own thread began ahead of them)."""
    store = _ACTIVE.get()
    if store is None or not store.enabled:
        if _RECALL_ONLY.get():
            raise NotRemembered(kind)
        return as_json(compute())
    k = entry_key("remembered " + kind, inputs, code=code, libraries=libraries)
    rec = store.get_record(k)
    if isinstance(rec, dict) and "value" in rec:
        return rec["value"]
    if _RECALL_ONLY.get():
        raise NotRemembered(kind)
    with store.lock(k):
        rec = store.get_record(k)
        if isinstance(rec, dict) and "value" in rec:
            return rec["value"]
        value = as_json(compute())
        store.put_record(k, {"value": value})
    return value
