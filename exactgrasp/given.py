"""`given`: the keyword arguments a caller set, None meaning "not given".

Optional settings default to None so that a caller can pass them on unchanged; what reaches
the code that applies them (a grasp file's overrides, a hand model's options, a report's
configuration) is only those that were set, and None keeps what the file or default says.
"""

from __future__ import annotations

from typing import Any

__all__ = ["given"]


def given(**values: Any) -> dict[str, Any]:
    """``values`` without those that are None, in the order passed.

    Returns
    -------
    dict
        Name -> value of every keyword argument that is not None.
    """
    return {name: value for name, value in values.items() if value is not None}
