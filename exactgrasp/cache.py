"""The keyed caches of exactgrasp: `LRUCache` in memory, `DiskCache` of arrays on disk, and
`code_digest`, the sources of the code that fills a disk cache, part of its keys."""

from __future__ import annotations

import functools
import hashlib
import json
import os
import tempfile
from collections import OrderedDict
from collections.abc import Callable, Hashable, Iterable
from pathlib import Path
from typing import Any

import numpy as np

#: The rooms (folders of the package) whose sources compute what the disk caches keep: the
#: geometry (welding, shells, crossings, winding numbers, repairs).
CODE_ROOMS = ("geometry",)
#: The sources digested: Python modules, and the compiled kernels' Cython sources and inline
#: parts (installed beside their extensions).
CODE_SOURCES = ("*.py", "*.pyx", "*.pxd")


@functools.cache
def rooms_digest() -> str:
    """SHA-256 (hex) of every source (`CODE_SOURCES`) of `CODE_ROOMS`, with its path, in path
    order."""
    root = Path(__file__).resolve().parent
    files = []
    for folder in CODE_ROOMS:
        files += sorted(p for pattern in CODE_SOURCES for p in (root / folder).rglob(pattern))
    digest = hashlib.sha256()
    for path in files:
        digest.update(path.relative_to(root).as_posix().encode())
        digest.update(path.read_bytes())
    return digest.hexdigest()


def code_digest(*modules: str | os.PathLike) -> str:
    """`rooms_digest` and the SHA-256 of each of ``modules`` (the source files that compute a
    disk cache's entries): part of that cache's keys (`DiskCache`'s ``version``), so that an
    edit to any of them starts it afresh, where the package's version has not changed (a
    checkout).

    Parameters
    ----------
    *modules : path-like
        Source files, usually the caller's ``__file__``.

    Returns
    -------
    str
        ``"<rooms' sources>/<module>/..."``, SHA-256 hex digests.
    """
    own = [hashlib.sha256(Path(module).read_bytes()).hexdigest() for module in modules]
    return "/".join([rooms_digest(), *own])


def mesh_key(vertices: np.ndarray, faces: np.ndarray) -> str:
    """SHA-256 (hex) of a mesh's vertex (float64) and face (int64) arrays: its content, the key
    of what is prepared once per mesh (link solids, BVHs)."""
    digest = hashlib.sha256()
    digest.update(np.ascontiguousarray(vertices, dtype=np.float64).tobytes())
    digest.update(np.ascontiguousarray(faces, dtype=np.int64).tobytes())
    return digest.hexdigest()


class LRUCache:
    """A bounded mapping that keeps the most recently used values.

    Parameters
    ----------
    maxsize : int
        Most values kept; the least recently used one goes first.

    Attributes
    ----------
    hits, builds : int
        Lookups answered from the cache / values built (a ``None`` key always builds), since
        the cache was made: what tells that a worker prepared a thing once and reused it.
    """

    def __init__(self, maxsize: int):
        self.maxsize = int(maxsize)
        self._store: OrderedDict[Hashable, Any] = OrderedDict()
        self.hits = 0
        self.builds = 0

    def get(self, key: Hashable | None, build: Callable[[], Any]) -> Any:
        """The value cached under ``key``, built with ``build()`` (and kept) when missing.

        A ``None`` key means "not cacheable": the value is built and not kept.
        """
        if key is None:
            self.builds += 1
            return build()
        store = self._store
        if key in store:
            store.move_to_end(key)
            self.hits += 1
            return store[key]
        self.builds += 1
        value = store[key] = build()
        while len(store) > self.maxsize:
            store.popitem(last=False)
        return value

    def __len__(self) -> int:
        return len(self._store)

    def __contains__(self, key: Hashable) -> bool:
        return key in self._store

    def clear(self) -> None:
        """Drop every value."""
        self._store.clear()


def cache_root() -> Path:
    """The folder of exactgrasp's disk caches: ``EXACTGRASP_CACHE``, else
    ``$XDG_CACHE_HOME/exactgrasp``, else ``~/.cache/exactgrasp``."""
    explicit = os.environ.get("EXACTGRASP_CACHE")
    if explicit:
        return Path(explicit).expanduser()
    base = os.environ.get("XDG_CACHE_HOME") or Path.home() / ".cache"
    return Path(base).expanduser() / "exactgrasp"


class DiskCache:
    """Arrays and a JSON record kept on disk under a key of the inputs' content.

    Each entry is one ``.npz`` file (no pickles), written to a temporary name and renamed, so
    processes that share the folder (batch workers) never read half an entry. Keys include
    ``version``: a new version of the code that writes entries starts afresh. An unreadable
    or unwritable cache is skipped, never an error.

    Parameters
    ----------
    kind : str
        Subfolder, and part of every key (``"solids"``).
    version : str or callable
        Part of every key: the version of whatever computes the entries, or a function
        giving it (called once, on first use).
    """

    def __init__(self, kind: str, version: str | Callable[[], str]):
        self.kind = kind
        self._version = version

    @functools.cached_property
    def version(self) -> str:
        """The version part of every key."""
        return self._version if isinstance(self._version, str) else self._version()

    def key(self, parts: Iterable[bytes | str | np.ndarray]) -> str:
        """SHA-256 (hex) of the version, the kind and each part (array bytes with dtype and
        shape)."""
        digest = hashlib.sha256(f"{self.version}/{self.kind}".encode())
        for part in parts:
            if isinstance(part, np.ndarray):
                array = np.ascontiguousarray(part)
                digest.update(f"{array.dtype.str}{array.shape}".encode())
                digest.update(array.tobytes())
            else:
                digest.update(part.encode() if isinstance(part, str) else part)
            digest.update(b"|")
        return digest.hexdigest()

    def _path(self, key: str) -> Path:
        return cache_root() / self.kind / f"{key}.npz"

    def get(
        self, key: str, build: Callable[[], tuple[dict[str, np.ndarray], dict[str, Any]]]
    ) -> tuple[dict[str, np.ndarray], dict[str, Any]]:
        """The ``(arrays, record)`` stored under ``key``, built with ``build()`` (and stored)
        when missing."""
        path = self._path(key)
        try:
            with np.load(path, allow_pickle=False) as data:
                arrays = {name: data[name] for name in data.files if name != "__record__"}
                record = json.loads(str(data["__record__"]))
            return arrays, record
        except (OSError, ValueError, KeyError):
            pass
        arrays, record = build()
        tmp = None
        try:
            path.parent.mkdir(parents=True, exist_ok=True)
            handle, tmp = tempfile.mkstemp(dir=path.parent, suffix=".tmp")
            with os.fdopen(handle, "wb") as out:
                np.savez(out, __record__=np.array(json.dumps(record)), **arrays)
            os.replace(tmp, path)
            tmp = None
        except OSError:
            pass
        finally:
            if tmp is not None and os.path.exists(tmp):
                os.remove(tmp)
        return arrays, record
