"""Rigid-body paths out of the hand: the sampler, its presets and the one input coercion."""

from __future__ import annotations

from typing import TYPE_CHECKING

from exactgrasp.lazy import lazy_names

if TYPE_CHECKING:
    from exactgrasp.errors import SamplerError
    from exactgrasp.paths.presets import DEFAULT_PRESET, as_sampler
    from exactgrasp.paths.sampler import PRESETS, PathSampler, PathTable

__getattr__, __dir__ = lazy_names(
    __name__,
    {
        "exactgrasp.errors": ("SamplerError",),
        "exactgrasp.paths.presets": ("DEFAULT_PRESET", "as_sampler"),
        "exactgrasp.paths.sampler": ("PRESETS", "PathSampler", "PathTable"),
    },
)

__all__ = ["DEFAULT_PRESET", "PRESETS", "PathSampler", "PathTable", "SamplerError", "as_sampler"]
