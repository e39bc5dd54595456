"""Looking at a grasp: an interactive HTML page (plotly) and a static PNG (matplotlib).

`show` is the entry point (``eg.show``, ``exactgrasp show``); `build_scene` gives the geometry
it draws. See ``docs/viewing.md``.
"""

from exactgrasp.view.scene import Scene, build_scene
from exactgrasp.view.write import Shown, show

__all__ = ["Scene", "Shown", "build_scene", "show"]
