"""`as_sampler`: the one coercion of what callers pass as a sampler into a `PathSampler`.

Every entry point (``compute_descriptor``, ``compare_backends``, ``run_batch`` and the
command line) goes through `as_sampler`, so they accept the same forms and fail with the same
message. The preset table itself, `PRESETS`, lives beside `PathSampler.preset` in
`exactgrasp.paths.sampler` (this module imports that one, never the reverse).
"""

from __future__ import annotations

import inspect
import json
import os
from pathlib import Path
from typing import Any

from exactgrasp.errors import Fix, SamplerError
from exactgrasp.paths.sampler import PRESETS, PathSampler

__all__ = ["DEFAULT_PRESET", "PRESETS", "SAMPLER_PARAMETERS", "accepted_forms", "as_sampler"]

#: The preset used when no sampler is given.
DEFAULT_PRESET = "balanced"

#: Keyword arguments of `PathSampler` (the keys a parameter dict may hold).
SAMPLER_PARAMETERS = tuple(inspect.signature(PathSampler.__init__).parameters)[1:]


def accepted_forms() -> str:
    """What `as_sampler` accepts, in words (ends its error messages, as `FORMS`)."""
    return (
        f"give None (the {DEFAULT_PRESET!r} preset), a PathSampler, a preset name "
        f"({', '.join(sorted(PRESETS))}), a dict of PathSampler parameters "
        f"({', '.join(SAMPLER_PARAMETERS)}), the JSON text of one or the path of a .json "
        "file holding it"
    )


def _subject(value: Any, kind: str = "sampler") -> Fix:
    """The sampler a message is about (``sampler '...': ``), which a front end may name its
    own way."""
    return Fix("sampler", value, "subject", python=f"{kind} {value!r}: ")


def _forms() -> Fix:
    """The accepted forms, as a fix of ``sampler`` (a front end words its own forms)."""
    return Fix("sampler", form="forms", python=accepted_forms())


def as_sampler(value: Any = None, n_steps: int | None = None) -> PathSampler:
    """The `PathSampler` that ``value`` stands for.

    Parameters
    ----------
    value : None or PathSampler or str or os.PathLike or dict
        None: the ``"balanced"`` preset. A `PathSampler`: itself. A str: a preset name
        (``"balanced"``, ``"translations"``, ``"rotations"``) or, when it starts with ``{``,
        JSON text of `PathSampler.params`. A path ending in ``.json``: a file holding that
        JSON. A dict: `PathSampler.params`.
    n_steps : int, optional
        Poses per path, replacing the preset's or the parameters' ``n_steps``. Not
        allowed with a `PathSampler` whose ``n_steps`` differs (it is already built).

    Returns
    -------
    PathSampler

    Raises
    ------
    SamplerError
        Any other type, an unknown preset, invalid JSON, unknown or invalid parameters; the
        message names the value and the accepted forms.
    """
    if isinstance(value, os.PathLike) or (
        isinstance(value, str) and value not in PRESETS and value.endswith(".json")
    ):
        file = Path(value)
        try:
            value = file.read_text()
        except OSError as exc:
            raise SamplerError(
                _subject(str(file), "sampler file"), f"cannot be read ({exc})."
            ) from exc
        if not value.lstrip().startswith("{"):
            raise SamplerError(
                _subject(str(file), "sampler file"), "not a JSON object; ", _forms(), "."
            )
    if isinstance(value, PathSampler):
        if n_steps is not None and n_steps != value.n_steps:
            raise SamplerError(
                Fix("n_steps", n_steps),
                f" cannot change the sampler {value!r}, which is already built with ",
                Fix("n_steps", shown=str(value.n_steps)),
                "; pass its parameters (a dict) or a preset name instead.",
            )
        return value
    overrides = {} if n_steps is None else {"n_steps": n_steps}
    if value is None:
        return PathSampler.preset(DEFAULT_PRESET, **overrides)
    if isinstance(value, str) and value.lstrip().startswith("{"):
        try:
            params = json.loads(value)
        except json.JSONDecodeError as exc:
            raise SamplerError(
                _subject(value), f"not valid JSON ({exc}); ", _forms(), "."
            ) from exc
        if not isinstance(params, dict):
            raise SamplerError(_subject(value), "not a JSON object; ", _forms(), ".")
        value = params
    if isinstance(value, str):
        if value not in PRESETS:
            raise SamplerError(f"unknown preset {value!r}; ", _forms(), ".")
        return PathSampler.preset(value, **overrides)
    if isinstance(value, dict):
        unknown = sorted(str(k) for k in value if k not in SAMPLER_PARAMETERS)
        if unknown:
            raise SamplerError(
                _subject(value),
                f"unknown parameter(s) {', '.join(unknown)}; ",
                _forms(),
                ".",
            )
        return PathSampler.from_params({**value, **overrides})
    raise SamplerError(
        Fix("sampler", value, python=f"sampler {value!r}"),
        f" is a {type(value).__name__}; ",
        _forms(),
        ".",
    )
