"""The hand's canonical frame (paper, section III-C).

Origin half-way along the palm normal between the palm and the outside of the loosely closed
fingers; axes: z "out" of the palm, y "up" towards the enclosing finger(s), x = y × z; scaled
so that half the palm-to-fingertip depth ``d`` is 1. Paths of length 1 then take the object out
of the hand, whatever the hand's size.
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import Any

import numpy as np

from exactgrasp.errors import FrameError


def _unit(vector: Any, name: str) -> np.ndarray:
    arr = np.asarray(vector, dtype=np.float64).reshape(-1)
    if arr.shape != (3,) or not np.all(np.isfinite(arr)):
        raise FrameError(f"{name} must be 3 finite numbers, got {vector!r}.")
    norm = np.linalg.norm(arr)
    if norm < 1e-12:
        raise FrameError(f"{name} must be a non-zero vector, got {vector!r}.")
    return arr / norm


@dataclass(frozen=True, eq=False)
class HandFrame:
    """Map from hand coordinates (metres) to the canonical frame (dimensionless).

    Use `from_palm` or `identity` rather than the constructor.

    Attributes
    ----------
    matrix : numpy.ndarray, shape (4, 4)
        ``x_canonical = matrix @ [x_hand, 1]``: a rotation times ``scale`` plus a translation.
    scale : float
        Canonical units per metre (``2 / depth`` for a palm frame).
    palm : dict or None
        The palm parameters it was built from (origin, normal, up, depth), for provenance.
    """

    matrix: np.ndarray
    scale: float
    palm: dict | None = None

    @classmethod
    def from_palm(
        cls, origin: Any, normal: Any, up: Any, depth: float, scale: float | None = None
    ) -> HandFrame:
        """The paper's frame from the palm.

        Parameters
        ----------
        origin : array_like, shape (3,)
            A point on the palm face, hand coordinates (m).
        normal : array_like, shape (3,)
            Direction "out" of the palm; becomes canonical +z.
        up : array_like, shape (3,)
            Direction "up" along the enclosing finger(s); its part orthogonal to ``normal``
            becomes canonical +y.
        depth : float
            ``d``, palm to the outside of the loosely closed fingers along ``normal`` (m).
        scale : float, optional
            Override the paper's ``2 / depth`` (e.g. the authors' code used 5.15568 for the
            Barrett hand, fitting its spread into the unit sphere).

        Returns
        -------
        HandFrame
        """
        origin = np.asarray(origin, dtype=np.float64).reshape(-1)
        if origin.shape != (3,) or not np.all(np.isfinite(origin)):
            raise FrameError(f"origin must be 3 finite numbers, got {origin!r}.")
        z = _unit(normal, "normal")
        up_vec = _unit(up, "up")
        y = up_vec - np.dot(up_vec, z) * z
        if np.linalg.norm(y) < 1e-6:
            raise FrameError(
                f"up {up!r} is parallel to the palm normal {normal!r}; give an 'up' direction "
                "across the palm, towards the enclosing finger(s)."
            )
        y /= np.linalg.norm(y)
        x = np.cross(y, z)
        if not np.isfinite(depth) or depth <= 0:
            raise FrameError(f"depth must be a positive length in metres, got {depth!r}.")
        s = 2.0 / depth if scale is None else float(scale)
        if not np.isfinite(s) or s <= 0:
            raise FrameError(f"scale must be positive, got {scale!r}.")
        centre = origin + z * depth / 2.0
        rot = np.stack([x, y, z])  # rows: hand -> canonical axes
        matrix = np.eye(4)
        matrix[:3, :3] = s * rot
        matrix[:3, 3] = -s * rot @ centre
        palm = {
            "origin": origin.tolist(),
            "normal": z.tolist(),
            "up": y.tolist(),
            "depth": float(depth),
            "scale": s,
        }
        return cls(matrix=matrix, scale=s, palm=palm)

    @classmethod
    def identity(cls) -> HandFrame:
        """Hand coordinates are used as canonical coordinates unchanged."""
        return cls(matrix=np.eye(4), scale=1.0, palm=None)

    @classmethod
    def from_dict(cls, data: dict) -> HandFrame:
        """Inverse of `to_dict`; also reads the shared data's ``palm_frame.json`` schema."""
        if data.get("identity"):
            return cls.identity()
        missing = [key for key in ("origin", "normal", "up", "depth") if key not in data]
        if missing:
            raise FrameError(
                f"a palm frame needs origin, normal, up and depth; {missing[0]!r} is missing."
            )
        return cls.from_palm(
            data["origin"], data["normal"], data["up"], data["depth"], data.get("scale")
        )

    def to_dict(self) -> dict:
        """JSON-serialisable form."""
        return {"identity": True} if self.palm is None else dict(self.palm)

    def apply(self, points: np.ndarray) -> np.ndarray:
        """Hand coordinates (m) to canonical coordinates.

        Parameters
        ----------
        points : numpy.ndarray, shape (..., 3)

        Returns
        -------
        numpy.ndarray, shape (..., 3)
        """
        return np.asarray(points) @ self.matrix[:3, :3].T + self.matrix[:3, 3]

    def __repr__(self) -> str:
        if self.palm is None:
            return "HandFrame.identity()"
        p = self.palm
        return (
            f"HandFrame.from_palm(origin={p['origin']}, normal={p['normal']}, up={p['up']}, "
            f"depth={p['depth']}, scale={p['scale']:.6g})"
        )
