"""`given`: the keyword arguments a caller set, None meaning "not given".

Optional settings default to None so that a caller can pass them on unchanged; what reaches
the code that applies them (a grasp file's overrides, a hand model's options, a report's
configuration) is only those that were set, and None keeps what the file or default says.
"""

from __future__ import annotations

from collections.abc import Mapping
from typing import Any

__all__ = ["given"]


def given(values: Mapping[str, Any]) -> dict[str, Any]:
    """The entries of ``values`` that are not None, in their order.

    Parameters
    ----------
    values : mapping of str to any
        Name -> value of each optional setting, None where the caller set none.

    Returns
    -------
    dict
    """
    return {name: value for name, value in values.items() if value is not None}
