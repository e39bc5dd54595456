"""The exact backend's options and the rules they follow, shared by `backend.ExactBackend` and
`intersector.ExactIntersector`.
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import Any

from exactgrasp.backends import defaults
from exactgrasp.backends.params import Interval, Options, Param, validate_parameters
from exactgrasp.geometry.bvh import require_engine

BROADPHASES = ("coal", "fcl", None)


#: What each option of the exact backend may be (checked by `check_options`).
PARAMETERS: dict[str, Param] = {
    "broadphase": Param(
        Options(BROADPHASES), hint="library of the broad phase; None tests every pose in full"
    ),
    "n_jobs": Param(
        Interval(int, 1, None),
        Options((-1,)),
        None,
        hint="threads; None uses every core (one in a batch worker), -1 every core",
    ),
    **{
        key: Param(
            Interval(float, 0, None, closed="neither"),
            None,
            hint=(
                "grid cell edge, same units as the meshes; None for the default, "
                f"1/{defaults.EXACT_CELLS_PER_EXTENT} of the mesh's extent"
            ),
        )
        for key in ("hand_cell", "object_cell")
    },
    "capacity": Param(
        Interval(int, 1, None),
        hint=(
            "edge crossings recorded per pose before the pose falls back to a boolean; "
            f"default {defaults.EXACT_CAPACITY}"
        ),
    ),
}


@dataclass(frozen=True)
class ExactOptions:
    """The exact backend's options, checked (made only by `check_options`).

    Attributes
    ----------
    broadphase : {"coal", "fcl", None}
    n_jobs : int or None
    tuning : dict
        ``hand_cell``, ``object_cell`` and ``capacity`` as given, as plain numbers, None cells
        left out.
    """

    broadphase: str | None
    n_jobs: int | None
    tuning: dict[str, Any]


def check_options(
    broadphase: Any, n_jobs: Any, tuning: dict[str, Any], owner: str = "ExactBackend"
) -> ExactOptions:
    """Check the exact backend's options against `PARAMETERS`, and that the broad phase's
    library is installed: the one check of them, which `ExactIntersector` built from the result
    does not repeat.

    Returns
    -------
    ExactOptions

    Raises
    ------
    BackendError
        Naming `owner`, the option, the value and what is allowed.
    MissingDependencyError
        The library of ``broadphase`` is not installed.
    """
    given = validate_parameters(
        PARAMETERS, {"broadphase": broadphase, "n_jobs": n_jobs, **tuning}, owner
    )
    if broadphase is not None:
        require_engine(broadphase, f"the exact backend's {broadphase} broad phase")
    return ExactOptions(
        broadphase,
        None if n_jobs is None else int(n_jobs),
        {key: given[key] for key in tuning if given[key] is not None},
    )
