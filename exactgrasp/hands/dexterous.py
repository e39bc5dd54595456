"""Built-in five-finger hands from the ``gymnasium-robotics`` package: Adroit and the Shadow hand.

Nothing is downloaded and nothing is bundled: the models are the MJCF files that the optional
package ``gymnasium-robotics`` (MIT licence; ``pip install "exactgrasp[hands]"``) installs,
found through ``importlib.util.find_spec`` without importing the package. Both are the Shadow
Dexterous Hand's kinematics with capsule and box collision geoms (22 links, 24 joints, the
wrist's two among them):

* ``adroit``: ``adroit_hand/adroit_relocate.xml``, the hand under its body ``forearm``
  (a 1030 cm^3 forearm cylinder included, as the Adroit environments move it); joint names
  ``WRJ1``, ``FFJ3`` .. ``THJ0``;
* ``shadow_hand``: ``hand/reach.xml``, the hand under ``robot0:hand mount`` (its forearm mesh,
  2786 cm^3, included); the same joints with the prefix ``robot0:``.

Frame of both (the root body's): the palm faces -y, the thumb is on +x, the fingers point
along +z. Palm frame: origin at the centre of the palm face, normal -y, up +x (towards the
thumb), depth 0.07 m (palm face to the outside of the fingers with every finger joint at
0.785 rad, loosely closed). Closing joints (`close_fingers`' default): the three flexion joints
of each finger (``FFJ2``, ``FFJ1``, ``FFJ0``, ... towards their upper limits) and the thumb's
``THJ3`` (towards its upper limit, across the palm) and ``THJ0`` (towards its lower limit);
the wrist, the finger spreads, ``LFJ4`` and the thumb's rotation stay as posed.
"""

from __future__ import annotations

import importlib.util
from pathlib import Path
from typing import TYPE_CHECKING

from exactgrasp.cache import LRUCache
from exactgrasp.errors import MissingDependencyError, ModelError

if TYPE_CHECKING:
    from exactgrasp.hands.hand import Hand
    from exactgrasp.hands.model import KinematicModel

__all__ = [
    "DEXTEROUS_HANDS",
    "PACKAGE",
    "adroit",
    "adroit_model",
    "model_file",
    "shadow_hand",
    "shadow_hand_model",
]

#: The Python package (import name) and the distribution that ships the models.
PACKAGE = ("gymnasium_robotics", "gymnasium-robotics")

#: Per built-in name: the model file inside the package's ``envs/assets``, the hand's root
#: body, the joint-name prefix and the palm face's origin (m, root-body frame).
DEXTEROUS_HANDS: dict[str, dict] = {
    "adroit": {
        "file": "adroit_hand/adroit_relocate.xml",
        "root_body": "forearm",
        "prefix": "",
        "palm_origin": (0.0, -0.011, 0.468),
    },
    "shadow_hand": {
        "file": "hand/reach.xml",
        "root_body": "robot0:hand mount",
        "prefix": "robot0:",
        "palm_origin": (0.0, -0.001, 0.328),
    },
}

_FLEXION = tuple(f"{f}J{k}" for f in ("FF", "MF", "RF", "LF") for k in (2, 1, 0))
_DIRECTIONS = {**dict.fromkeys(_FLEXION, 1), "THJ3": 1, "THJ0": -1}


def model_file(name: str) -> Path:
    """The installed MJCF file of a built-in five-finger hand (``"adroit"``, ``"shadow_hand"``).

    Raises
    ------
    MissingDependencyError
        When ``gymnasium-robotics`` is not installed.
    ModelError
        When its file is missing.
    """
    spec = importlib.util.find_spec(PACKAGE[0])
    if spec is None or not spec.submodule_search_locations:
        raise MissingDependencyError(f"the built-in hand {name!r}", PACKAGE[1], "hands")
    root = Path(next(iter(spec.submodule_search_locations))) / "envs" / "assets"
    path = root / DEXTEROUS_HANDS[name]["file"]
    if not path.is_file():
        raise ModelError(
            f"the built-in hand {name!r}: {PACKAGE[1]} is installed at {root.parent.parent} "
            f"but holds no {DEXTEROUS_HANDS[name]['file']}; a version >= 1.4 ships it."
        )
    return path


_MODELS = LRUCache(2)


def _model(name: str) -> KinematicModel:
    import warnings

    from exactgrasp.hands.loading import load_model

    entry = DEXTEROUS_HANDS[name]
    prefix = entry["prefix"]
    palm = {"origin": entry["palm_origin"], "normal": (0, -1, 0), "up": (1, 0, 0), "depth": 0.07}
    with warnings.catch_warnings():
        # The scene's table, floor and object are left out of the hand, as intended.
        warnings.filterwarnings("ignore", message=".*geoms left out of the hand.*")
        model = load_model(model_file(name), root_body=entry["root_body"], palm=palm)
    model.closing_joints = tuple(prefix + n for n in _DIRECTIONS)
    model.closing_directions = {prefix + n: d for n, d in _DIRECTIONS.items()}
    return model


def adroit_model() -> KinematicModel:
    """The Adroit hand as a `KinematicModel` (compiled once, then cached).

    Returns
    -------
    KinematicModel
        22 links (``forearm``, ``wrist``, ``palm/C_palm0``, ..., ``thdistal``); 24 joints in
        radians, 0 = fingers stretched out.
    """
    return _MODELS.get("adroit", lambda: _model("adroit"))


def shadow_hand_model() -> KinematicModel:
    """The Shadow hand of ``hand/reach.xml`` as a `KinematicModel` (compiled once, cached).

    Returns
    -------
    KinematicModel
        22 links (``robot0:forearm``, ...); 24 joints ``robot0:WRJ1`` .. ``robot0:THJ0``.
    """
    return _MODELS.get("shadow_hand", lambda: _model("shadow_hand"))


def _posed(name: str, model: KinematicModel, joints, hand_kwargs) -> Hand:
    from exactgrasp.hands.hand import Hand

    source = {"type": "builtin", "name": name, "options": {}}
    return Hand(model, joints=joints, source=source, **hand_kwargs)


def adroit(joints: dict[str, float] | None = None, **hand_kwargs) -> Hand:
    """The Adroit five-finger hand (from ``gymnasium-robotics``), posed.

    Parameters
    ----------
    joints : dict of str to float, optional
        Joint values in radians (``FFJ2``, ``THJ3``, ...); missing ones are 0 (the flat
        hand).
    **hand_kwargs
        Passed to `exactgrasp.hands.hand.Hand` (``frame``, ``on_limit``).

    Returns
    -------
    exactgrasp.hands.hand.Hand
        With the hand's palm frame unless ``frame=`` is given.
    """
    return _posed("adroit", adroit_model(), joints, hand_kwargs)


def shadow_hand(joints: dict[str, float] | None = None, **hand_kwargs) -> Hand:
    """The Shadow hand (from ``gymnasium-robotics``), posed: as `adroit`, its joints named
    ``robot0:FFJ2``, ``robot0:THJ3``, ... (radians; missing ones are 0)."""
    return _posed("shadow_hand", shadow_hand_model(), joints, hand_kwargs)
