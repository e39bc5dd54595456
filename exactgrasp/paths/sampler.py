"""The paper's uniform sampling of rigid-body paths out of the hand (section III-A).

A path is a constant body twist: unit translation velocity ``v`` along a direction and angular
velocity ``omega = axis * amount``. The pose at time ``t`` is ``exp(t * twist)``. Directions and
axes come from the spiral phyllotaxis pattern on the sphere; rotation amounts are spread evenly
over the circle of angles. See ``docs/conventions.md`` for every choice made here. The named
settings (`PRESETS`) are here beside `PathSampler.preset`; the coercion of user input into a
sampler is `exactgrasp.paths.presets.as_sampler`.
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import Any

import numpy as np

from exactgrasp.errors import Fix, SamplerError
from exactgrasp.geometry.se3 import exp_se3

GOLDEN_ANGLE = 2.0 * np.pi * (1.0 - 2.0 / (1.0 + np.sqrt(5.0)))

PRESETS: dict[str, dict[str, int]] = {
    "balanced": {"n_translations": 18, "n_axes": 4, "n_amounts": 6},
    "translations": {"n_translations": 28, "n_axes": 2, "n_amounts": 7},
    "rotations": {"n_translations": 10, "n_axes": 4, "n_amounts": 7},
}

AMOUNT_RULES = ("circle", "linspace")
STEP_RULES = ("paper", "code")


def sphere_points(n: int) -> np.ndarray:
    """Spiral phyllotaxis points on the unit sphere (method-notes.md).

    For ``i = 0 .. n-1``: latitude ``arccos(1 - 2 i / (n - 1))`` (both poles included),
    longitude ``i * golden_angle``.

    Parameters
    ----------
    n : int
        Number of points, at least 1. With ``n == 1`` the single point is the north pole.

    Returns
    -------
    numpy.ndarray, shape (n, 3)
        Unit vectors.
    """
    if n < 1:
        raise SamplerError(f"sphere_points needs n >= 1, got {n}.")
    i = np.arange(n, dtype=np.float64)
    z = 1.0 - 2.0 * i / (n - 1) if n > 1 else np.ones(1)
    # arccos then cos/sin, as in the formula; clip guards rounding just outside [-1, 1].
    latitude = np.arccos(np.clip(z, -1.0, 1.0))
    longitude = i * GOLDEN_ANGLE
    return np.stack(
        [
            np.sin(latitude) * np.cos(longitude),
            np.sin(latitude) * np.sin(longitude),
            np.cos(latitude),
        ],
        axis=-1,
    )


def rotation_amounts(n: int, rule: str = "circle") -> np.ndarray:
    """Rotation amounts on the -1..1 scale (multiply by pi for radians).

    Parameters
    ----------
    n : int
        Number of amounts, at least 1.
    rule : {"circle", "linspace"}
        ``"circle"`` (default): the ``n + 1`` evenly spaced angles of the full circle with the
        identity (0) removed, written in -1..1, so ``2 k / (n + 1)`` for
        ``k = ±1 .. ±floor(n / 2)`` plus the half turn ``1`` when ``n`` is odd. Symmetric in
        sign (a half turn is its own mirror), never 0 (a 0 amount would repeat the
        translation-only path and make a rotation-only path that never moves), and never both
        -1 and +1 (which end at the same orientation).
        ``"linspace"``: the authors' code, ``linspace(-1, 1, n)``; it includes 0 for odd
        ``n`` and both half turns.

    Returns
    -------
    numpy.ndarray, shape (n,)
        Increasing amounts in [-1, 1].
    """
    if n < 1:
        raise SamplerError(f"n_amounts must be >= 1, got {n}.")
    if rule == "linspace":
        return np.linspace(-1.0, 1.0, n) if n > 1 else np.ones(1)
    if rule != "circle":
        raise SamplerError(f"amount rule {rule!r} is unknown; use one of {AMOUNT_RULES}.")
    k = np.arange(1, n // 2 + 1, dtype=np.float64)
    half = 2.0 * k / (n + 1)
    amounts = np.concatenate([-half[::-1], half, [1.0] if n % 2 else []])
    return np.sort(amounts)


def step_times(n_steps: int, rule: str = "paper") -> np.ndarray:
    """Times along a path at which poses are taken (the origin t = 0 is always dropped).

    Parameters
    ----------
    n_steps : int
        Number of poses per path.
    rule : {"paper", "code"}
        ``"paper"``: ``t_k = k / n_steps`` for ``k = 1 .. n_steps`` (the paper: 10 steps on
        [0, 1], origin dropped, so 1/9 .. 1 for 9 steps). ``"code"``: the authors' code,
        ``t_k = k / (n_steps + 1)``, so 0.1 .. 0.9 for 9 steps.

    Returns
    -------
    numpy.ndarray, shape (n_steps,)
    """
    if n_steps < 1:
        raise SamplerError(Fix("n_steps"), f" must be >= 1, got {n_steps}.")
    k = np.arange(1, n_steps + 1, dtype=np.float64)
    if rule == "paper":
        return k / n_steps
    if rule == "code":
        return k / (n_steps + 1)
    raise SamplerError(f"step rule {rule!r} is unknown; use one of {STEP_RULES}.")


@dataclass(frozen=True)
class PathTable:
    """Per-path metadata.

    Attributes
    ----------
    kind : numpy.ndarray, shape (n_paths,), str
        ``"both"``, ``"translation"`` or ``"rotation"``.
    direction : numpy.ndarray, shape (n_paths, 3)
        Unit translation velocity (zero for rotation-only paths), canonical lengths per unit
        time.
    axis : numpy.ndarray, shape (n_paths, 3)
        Unit rotation axis (zero for translation-only paths).
    amount : numpy.ndarray, shape (n_paths,)
        Rotation angle reached at ``t = 1``, radians (0 for translation-only paths).
    translation_index, axis_index, amount_index : numpy.ndarray, shape (n_paths,), int
        Index into the sampler's directions, axes and amounts; -1 where not used.
    """

    kind: np.ndarray
    direction: np.ndarray
    axis: np.ndarray
    amount: np.ndarray
    translation_index: np.ndarray
    axis_index: np.ndarray
    amount_index: np.ndarray

    @property
    def omega(self) -> np.ndarray:
        """Angular velocities, shape (n_paths, 3), rad per unit time."""
        return self.axis * self.amount[:, None]


class PathSampler:
    """Uniform set of rigid paths that move the object out of the hand.

    Parameters
    ----------
    n_translations : int
        ``N_t``, number of translation directions.
    n_axes : int
        ``N_a``, number of rotation axes.
    n_amounts : int
        ``N_r``, number of rotation amounts per axis.
    n_steps : int
        Poses per path, the origin excluded (the paper: 9).
    amounts : {"circle", "linspace"} or array_like of float
        Rule for the rotation amounts (see `rotation_amounts`), or explicit amounts on the
        -1..1 scale (``pi`` times them in radians); explicit amounts must number ``n_amounts``.
    steps : {"paper", "code"} or array_like of float
        Rule for step times (see `step_times`) or explicit times in (0, 1].

    Notes
    -----
    Paths are ordered: every (direction, axis, amount) triple, direction-major; then one
    translation-only path per direction; then one rotation-only path per (axis, amount).
    ``n_paths = N_t N_a N_r + N_t + N_a N_r``.
    """

    def __init__(
        self,
        n_translations: int = 18,
        n_axes: int = 4,
        n_amounts: int = 6,
        n_steps: int = 9,
        amounts: str | Any = "circle",
        steps: str | Any = "paper",
    ):
        for name, value in (
            ("n_translations", n_translations),
            ("n_axes", n_axes),
            ("n_amounts", n_amounts),
            ("n_steps", n_steps),
        ):
            if isinstance(value, bool) or not isinstance(value, int | np.integer) or value < 1:
                raise SamplerError(Fix(name), f" must be a positive integer, got {value!r}.")
        self.n_translations = int(n_translations)
        self.n_axes = int(n_axes)
        self.n_amounts = int(n_amounts)
        self.n_steps = int(n_steps)

        if isinstance(amounts, str):
            self.amount_rule = amounts
            self.amounts = rotation_amounts(self.n_amounts, amounts)
        else:
            arr = np.asarray(amounts, dtype=np.float64).ravel()
            if arr.size != self.n_amounts or not np.all(np.isfinite(arr)):
                raise SamplerError(
                    f"amounts must be {self.n_amounts} finite numbers (n_amounts), got {arr}."
                )
            if np.any(np.abs(arr) > 1.0) or np.any(arr == 0.0):
                raise SamplerError(
                    f"amounts are on the -1..1 scale (times pi radians) and must be non-zero; "
                    f"got {arr}."
                )
            self.amount_rule = "explicit"
            self.amounts = arr

        if isinstance(steps, str):
            self.step_rule = steps
            self.times = step_times(self.n_steps, steps)
        else:
            arr = np.asarray(steps, dtype=np.float64).ravel()
            if arr.size != self.n_steps or np.any(arr <= 0) or np.any(arr > 1):
                raise SamplerError(
                    f"steps must be {self.n_steps} times in (0, 1] (",
                    Fix("n_steps"),
                    f"), got {arr}.",
                )
            self.step_rule = "explicit"
            self.times = arr

    @classmethod
    def preset(cls, name: str, **overrides: Any) -> PathSampler:
        """One of the paper's three settings: ``"balanced"``, ``"translations"``,
        ``"rotations"``.

        Parameters
        ----------
        name : str
        **overrides
            Any constructor argument, e.g. ``n_steps=5``.

        Returns
        -------
        PathSampler
        """
        if name not in PRESETS:
            raise SamplerError(f"unknown preset {name!r}; use one of {sorted(PRESETS)}.")
        return cls(**{**PRESETS[name], **overrides})

    @property
    def n_paths(self) -> int:
        """``N_t N_a N_r + N_t + N_a N_r``."""
        n_t, n_a, n_r = self.n_translations, self.n_axes, self.n_amounts
        return n_t * n_a * n_r + n_t + n_a * n_r

    @property
    def n_poses(self) -> int:
        """``n_steps * n_paths``."""
        return self.n_steps * self.n_paths

    @property
    def directions(self) -> np.ndarray:
        """Translation directions, shape (N_t, 3), unit vectors."""
        return sphere_points(self.n_translations)

    @property
    def axes(self) -> np.ndarray:
        """Rotation axes, shape (N_a, 3), unit vectors."""
        return sphere_points(self.n_axes)

    @property
    def paths(self) -> PathTable:
        """Per-path metadata, in path order."""
        n_t, n_a, n_r = self.n_translations, self.n_axes, self.n_amounts
        ti, ai, ri = np.meshgrid(np.arange(n_t), np.arange(n_a), np.arange(n_r), indexing="ij")
        ti, ai, ri = ti.ravel(), ai.ravel(), ri.ravel()
        rot_a, rot_r = (
            g.ravel() for g in np.meshgrid(np.arange(n_a), np.arange(n_r), indexing="ij")
        )
        none_t, none_ar = np.full(n_t, -1), np.full(n_a * n_r, -1)
        translation_index = np.concatenate([ti, np.arange(n_t), none_ar])
        axis_index = np.concatenate([ai, none_t, rot_a])
        amount_index = np.concatenate([ri, none_t, rot_r])
        kind = np.array(["both"] * ti.size + ["translation"] * n_t + ["rotation"] * (n_a * n_r))

        directions = np.vstack([self.directions, np.zeros((1, 3))])
        axes = np.vstack([self.axes, np.zeros((1, 3))])
        amounts = np.append(self.amounts * np.pi, 0.0)
        return PathTable(
            kind=kind,
            direction=directions[translation_index],
            axis=axes[axis_index],
            amount=amounts[amount_index],
            translation_index=translation_index,
            axis_index=axis_index,
            amount_index=amount_index,
        )

    def poses(self) -> np.ndarray:
        """Object poses along every path, in the hand's canonical frame.

        Returns
        -------
        numpy.ndarray, shape (n_paths, n_steps, 4, 4)
            ``exp(t_k * twist_p)``; a vertex ``x`` of the object moves to ``R @ x + t``.
        """
        table = self.paths
        t = self.times[None, :, None]
        return exp_se3(table.omega[:, None, :] * t, table.direction[:, None, :] * t)

    @property
    def params(self) -> dict[str, Any]:
        """JSON-serialisable parameters that reproduce this sampler."""
        return {
            "n_translations": self.n_translations,
            "n_axes": self.n_axes,
            "n_amounts": self.n_amounts,
            "n_steps": self.n_steps,
            "amounts": self.amount_rule
            if self.amount_rule != "explicit"
            else self.amounts.tolist(),
            "steps": self.step_rule if self.step_rule != "explicit" else self.times.tolist(),
        }

    @classmethod
    def from_params(cls, params: dict[str, Any]) -> PathSampler:
        """Inverse of `params`."""
        return cls(**params)

    def __repr__(self) -> str:
        args = ", ".join(f"{k}={v!r}" for k, v in self.params.items())
        return f"PathSampler({args})"
