"""The MJCF text of a built-in hand of primitives: a box palm, its face site and fingers."""

from __future__ import annotations

__all__ = ["primitive_hand_mjcf"]


def primitive_hand_mjcf(
    model: str, palm: tuple[str, str], face: str, fingers: str, mirrored: tuple[str, str]
) -> str:
    """MJCF text of a hand whose palm is one box with the site ``palm_face`` on its face.

    Parameters
    ----------
    model : str
        The model's name.
    palm : (str, str)
        The palm box's ``pos`` and half-sizes (``size``), m, as MJCF writes them.
    face : str
        The ``palm_face`` site's ``pos``, m.
    fingers : str
        The fingers' ``<body>`` elements, children of the palm.
    mirrored : (str, str)
        A joint and the joint it follows, ratio 1 (the hand's one coupled motor).

    Returns
    -------
    str
    """
    follower, leader = mirrored
    return f"""<mujoco model="{model}">
  <compiler angle="radian" autolimits="true"/>
  <worldbody>
    <body name="palm">
      <geom name="palm" type="box" pos="{palm[0]}" size="{palm[1]}"/>
      <site name="palm_face" pos="{face}"/>
{fingers}
    </body>
  </worldbody>
  <equality>
    <joint joint1="{follower}" joint2="{leader}" polycoef="0 1 0 0 0"/>
  </equality>
</mujoco>
"""
