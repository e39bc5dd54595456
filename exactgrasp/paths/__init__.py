"""Rigid-body paths out of the hand: the sampler, its presets and the one input coercion."""

from exactgrasp.paths.sampler import PRESETS, PathSampler, PathTable

__all__ = ["PRESETS", "PathSampler", "PathTable"]
