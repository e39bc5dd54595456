"""Rigid-body paths out of the hand: the sampler, its presets and the one input coercion."""

from exactgrasp.errors import SamplerError
from exactgrasp.paths.presets import DEFAULT_PRESET, as_sampler
from exactgrasp.paths.sampler import PRESETS, PathSampler, PathTable

__all__ = ["DEFAULT_PRESET", "PRESETS", "PathSampler", "PathTable", "SamplerError", "as_sampler"]
