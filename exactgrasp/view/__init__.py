"""Looking at a grasp: an interactive HTML page (plotly) and a static PNG (matplotlib).

`show` is the entry point (``eg.show``, ``exactgrasp show``); `build_scene` gives the geometry
it draws. See ``docs/viewing.md``.
"""

from __future__ import annotations

from typing import TYPE_CHECKING

from exactgrasp.lazy import lazy_names

if TYPE_CHECKING:
    from exactgrasp.view.scene import Scene, build_scene
    from exactgrasp.view.write import Shown, show

__getattr__, __dir__ = lazy_names(
    __name__,
    {
        "exactgrasp.view.scene": ("Scene", "build_scene"),
        "exactgrasp.view.write": ("Shown", "show"),
    },
)

__all__ = ["Scene", "Shown", "build_scene", "show"]
