"""`LRUCache`: the one keyed-cache idiom of exactgrasp (imports nothing from exactgrasp)."""

from __future__ import annotations

from collections import OrderedDict
from collections.abc import Callable, Hashable
from typing import Any


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
