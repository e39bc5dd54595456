"""Built-in demo objects (metres), so examples and tests need no download.

Built with manifold3d primitives, so every object is closed by construction.
"""

from __future__ import annotations

import manifold3d

from exactgrasp.geometry.manifold import mesh_arrays
from exactgrasp.geometry.solid import Solid


def _solid(shape: manifold3d.Manifold, name: str) -> Solid:
    vertices, faces = mesh_arrays(shape)
    return Solid(vertices, faces, name=name)


def box(size: tuple[float, float, float] = (0.06, 0.2, 0.28)) -> Solid:
    """A box centred on the origin (default: roughly a cereal box, 6 x 20 x 28 cm).

    Parameters
    ----------
    size : (float, float, float)
        Side lengths along x, y, z (m).

    Returns
    -------
    Solid
    """
    return _solid(manifold3d.Manifold.cube(tuple(map(float, size)), center=True), "box")


def cylinder(radius: float = 0.035, height: float = 0.12, segments: int = 64) -> Solid:
    """A cylinder along z centred on the origin (default: roughly a can).

    Parameters
    ----------
    radius, height : float
        Metres.
    segments : int
        Facets around the circle.

    Returns
    -------
    Solid
    """
    shape = manifold3d.Manifold.cylinder(height, radius, radius, segments, center=True)
    return _solid(shape, "cylinder")


def bottle_with_handle(segments: int = 48) -> Solid:
    """A bottle with a loop handle on its side (a jug), axis along z, base centred at z = 0.

    Body: radius 4 cm, 18 cm tall; neck: radius 1.5 cm, 5 cm; handle: half a torus (major
    radius 4 cm, tube radius 0.8 cm) on the +x side.

    Returns
    -------
    Solid
    """
    body = manifold3d.Manifold.cylinder(0.18, 0.04, 0.04, segments)
    shoulder = manifold3d.Manifold.cylinder(0.03, 0.04, 0.015, segments).translate((0, 0, 0.18))
    neck = manifold3d.Manifold.cylinder(0.05, 0.015, 0.015, segments).translate((0, 0, 0.2))
    ring = manifold3d.CrossSection.circle(0.008, segments // 2).translate((0.04, 0.0))
    torus = manifold3d.Manifold.revolve(ring, segments)
    # Stand the torus upright in the x-z plane and keep its outer half, beside the body.
    torus = torus.rotate((90.0, 0.0, 0.0))
    half = torus.trim_by_plane((1.0, 0.0, 0.0), 0.0)
    handle = half.translate((0.035, 0.0, 0.1))
    shape = manifold3d.Manifold.batch_boolean(
        [body, shoulder, neck, handle], manifold3d.OpType.Add
    )
    return _solid(shape, "bottle_with_handle")


DEMO_OBJECTS = {"box": box, "cylinder": cylinder, "bottle_with_handle": bottle_with_handle}


def get(name: str) -> Solid:
    """A demo object by name (``"box"``, ``"cylinder"``, ``"bottle_with_handle"``)."""
    try:
        return DEMO_OBJECTS[name]()
    except KeyError:
        raise KeyError(
            f"unknown demo object {name!r}; use one of {sorted(DEMO_OBJECTS)}"
        ) from None


__all__ = ["DEMO_OBJECTS", "bottle_with_handle", "box", "cylinder", "get"]
