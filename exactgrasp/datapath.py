"""Where the shared data folder is (`data_dir`, set by the ``EXACTGRASP_DATA`` variable), and
the checkout's ``examples/`` folder (`examples_dir`: the tutorial's hand and objects).

The shared data folder holds the authors' objects (``osu-objects/``) and Barrett grasps
(``barrett-grasps/``). Tests, benchmarks and ``exactgrasp validate`` find it here, and nowhere
else. Layer 0: imports nothing from exactgrasp.
"""

from __future__ import annotations

import os
from pathlib import Path

__all__ = ["ENV_VAR", "checkout_dir", "data_dir", "default_data_dir", "examples_dir"]

#: The environment variable that names the shared data folder.
ENV_VAR = "EXACTGRASP_DATA"


def checkout_dir() -> Path:
    """The source checkout this package runs from, or the current folder when installed.

    Returns
    -------
    pathlib.Path
        The folder holding ``pyproject.toml`` beside the ``exactgrasp`` package (an editable
        install or a run from the checkout); otherwise the current working folder.
    """
    root = Path(__file__).resolve().parents[1]
    return root if (root / "pyproject.toml").is_file() else Path.cwd()


def default_data_dir() -> Path:
    """``../shared/data`` beside the checkout (`checkout_dir`), used when `ENV_VAR` is unset."""
    return checkout_dir().parent / "shared" / "data"


def data_dir() -> Path:
    """The shared data folder: ``$EXACTGRASP_DATA`` when set and not empty, else the default.

    The folder is not checked here: callers skip (tests, benchmarks) or refuse (``validate``)
    with a message when it is missing.

    Returns
    -------
    pathlib.Path
        ``$EXACTGRASP_DATA`` with ``~`` expanded (relative to the current folder when
        relative), or `default_data_dir`.
    """
    value = os.environ.get(ENV_VAR, "").strip()
    return Path(value).expanduser() if value else default_data_dir()


def examples_dir() -> Path:
    """The checkout's ``examples/`` folder: the small URDF hand and the two STL objects of
    ``docs/tutorial.md``.

    Returns
    -------
    pathlib.Path

    Raises
    ------
    FileNotFoundError
        When exactgrasp was installed without its checkout (``pip install .``), which leaves
        the examples behind.
    """
    folder = Path(__file__).resolve().parents[1] / "examples"
    if not (folder / "hand" / "two_finger.urdf").is_file():
        raise FileNotFoundError(
            f"{folder}: the tutorial's files are not there; they come with a checkout of "
            "exactgrasp: install it from the checkout in editable mode (pip install -e ., as "
            "make demo does), or use the paths of your own hand and object files."
        )
    return folder
