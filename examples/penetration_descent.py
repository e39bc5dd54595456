"""Gradient descent on the exact penetration volume, through forward kinematics in PyTorch.

A grasp whose hand sinks into its object is pulled apart by gradient descent on

    loss = Σ over the hand's links of volume(link ∩ object)     (m^3)

(`exactgrasp.torch.intersection_volume`: exact, differentiable by every vertex), over the
hand's joints and the object's rigid motion (a translation, and a rotation about its
centroid). The links' vertices follow the joints through forward kinematics written here in
a few lines of torch (`TorchKinematics`: products of exponentials of the hand model's own
joint axes and anchors), so one ``loss.backward()`` gives the derivative by every joint and
by the object's motion. The loss's minimum is known (0), so each step is Polyak's, with
momentum; joints stay within their limits; the descent stops when the loss reads exactly 0,
at the point of the last step where it first does (`descend`).

    python examples/penetration_descent.py [GRASP.json ...] [--steps N] [--object-scale S]
    python examples/penetration_descent.py --compare [--limit N] [--json out.json]
    python examples/penetration_descent.py --table out.json

Without a file it runs on one raw cereal-box record of the shared data. ``--compare`` runs
the descent and `exactgrasp.separate` (library defaults) on the 34 raw cereal-box records
that ``benchmarks/separate_authors.py`` compares with the authors' contact-adjusted grasps,
in that benchmark's terms, and prints the table of ``docs/penetration-volume.md`` ("Gradient
descent on the exact volume, against `separate`"); ``--table`` prints that table again
from the rows ``--json`` wrote. Needs torch (the ``torch`` extra).

Long because it is one worked example a reader can copy whole: the kinematics, the loss, the
descent and its command line.
"""

from __future__ import annotations

import argparse
import json
import sys
import time
from dataclasses import dataclass, field
from pathlib import Path

import numpy as np
import torch

import exactgrasp as eg
from exactgrasp.torch import intersection_volume

ROOT = Path(__file__).resolve().parents[1]

#: The object's weight against the joints: one unit of its parameters moves it (its farthest
#: vertex, for a rotation) by this many canonical units (half the palm-to-fingertip depth;
#: 4.25 mm on the records' hand), where a joint's unit is a radian. Below 1, turning a finger
#: out of the object is cheaper than moving the object, which moves where nothing else helps
#: (a palm sunk into it). Chosen on subsets of the records, see the docs.
OBJECT_SCALE = 0.1
#: Largest change of any parameter in one step (radians, or the object's units above).
MAX_STEP = 0.25
#: Most loss evaluations (each one volume and gradient per link) before giving up.
MAX_STEPS = 40
#: Heavy-ball momentum: links on opposite sides of the object (fingers closing on it) pull
#: its motion back and forth from step to step, and the momentum averages that out.
MOMENTUM = 0.5
#: Polyak's step aims the linearised loss at 0, which undershoots a loss growing faster than
#: linearly with depth; a step that sheds less than this fraction of the loss doubles the
#: overshoot of the next (up to `MAX_OVERSHOOT`), so the loss reaches an exact 0.
SLOW = 0.5
MAX_OVERSHOOT = 4.0
#: The descent stops where the loss reads exactly 0. The library's volume of the whole
#: grasp (the union of the links, in the canonical frame) is another rounding of the same
#: geometry: where a link lies face on face with the object, one reads 0 within its certified
#: bound and the other a few 1e-16 m^3. Removed means that volume is at most this fraction of
#: the object's.
TOLERANCE = 1e-12
#: Samples per round of the search for contact along the last step, and where the rounds
#: stop: the bracket's width times the step's largest parameter change.
BRACKET = 16
CONTACT_TOL = 1e-3


def _skew(w: torch.Tensor) -> torch.Tensor:
    """The cross-product matrix (3, 3) of ``w`` (3,): ``_skew(w) @ x == w × x``."""
    return torch.linalg.cross(w.expand(3, 3), torch.eye(3, dtype=torch.float64), dim=1).T


def _hinge(axis: torch.Tensor, anchor: torch.Tensor, angle: torch.Tensor) -> torch.Tensor:
    """The rigid motion (4, 4) of turning ``angle`` rad about the unit ``axis`` through
    ``anchor`` (Rodrigues)."""
    k = _skew(axis)
    r = torch.eye(3, dtype=torch.float64) + torch.sin(angle) * k + (1 - torch.cos(angle)) * k @ k
    return _rigid(r, anchor - r @ anchor)


def _rigid(r: torch.Tensor, t: torch.Tensor) -> torch.Tensor:
    """The rigid motion (4, 4) ``x -> r @ x + t``."""
    bottom = torch.tensor([[0.0, 0.0, 0.0, 1.0]], dtype=torch.float64)
    return torch.cat([torch.cat([r, t[:, None]], dim=1), bottom])


@dataclass(frozen=True)
class TorchKinematics:
    """A hand model's forward kinematics in torch: links posed by the joints, differentiably.

    Built from the model's own data (`KinematicModel.joint_frames`, `link_poses`,
    `joint_links`, `couplings`, `joint_limits`) at its default joints ``q0``; a link's pose
    is the product of exponentials ``T_l(q) = Π_j exp(ξ_j (q_j - q0_j)) T_l(q0)`` over the
    joints above it, root first, ``ξ_j`` the joint's axis and anchor at ``q0``.

    Attributes
    ----------
    joint_names : tuple of str
        The independent joints, in `Hand.joint_names` order (k).
    lower, upper : torch.Tensor, shape (k,)
        Joint limits, rad (m for a slide joint).
    local, faces : tuple of torch.Tensor (n_l, 3) and of numpy.ndarray (m_l, 3)
        Each link's mesh in its own frame (metres), in `Hand.link_names` order.
    """

    joint_names: tuple[str, ...]
    lower: torch.Tensor
    upper: torch.Tensor
    #: Per joint of the model (coupled ones too), root first: (kind, axis, anchor, driver
    #: index or None, ratio, offset, q0 of the joint).
    joints: tuple
    #: Per link: the indices into `joints` of those above it, root first.
    chains: tuple
    home: torch.Tensor = field(repr=False)
    local: tuple = field(repr=False)
    faces: tuple = field(repr=False)

    @classmethod
    def of(cls, hand: eg.Hand) -> TorchKinematics:
        """The kinematics of ``hand``'s model (its joint values play no part); a `TypeError`
        for a hand without a kinematic model (a rigid mesh)."""
        model = hand.model
        if not hasattr(model, "joint_frames"):
            raise TypeError(
                f"hand {model.name!r} has no kinematic model to follow; pass a hand with "
                "joints (eg.hands.barrett(), eg.Hand.from_urdf(...))"
            )
        names = tuple(hand.joint_names)
        q0 = dict(model.default_joints)
        every = model.all_joint_values(q0)
        frames = model.joint_frames(q0)  # model order: a body's joints after its parent's
        couplings = model.couplings
        joints = []
        for name, (kind, anchor, axis) in frames.items():
            driver, ratio, offset = couplings.get(name, (name, 1.0, 0.0))
            index = names.index(driver) if driver is not None else None
            joints.append(
                (kind, torch.tensor(axis), torch.tensor(anchor), index, ratio, offset, every[name])
            )
        moved = model.joint_links()
        order = list(frames)
        chains = tuple(
            tuple(order.index(j) for j in order if link in moved[j])
            for link in range(len(model.link_names))
        )
        local = model.link_local_meshes()
        return cls(
            joint_names=names,
            lower=torch.tensor([model.joint_limits[n][0] for n in names], dtype=torch.float64),
            upper=torch.tensor([model.joint_limits[n][1] for n in names], dtype=torch.float64),
            joints=tuple(joints),
            chains=chains,
            home=torch.from_numpy(model.link_poses(q0)),
            local=tuple(torch.from_numpy(np.asarray(v, dtype=np.float64)) for _, v, _ in local),
            faces=tuple(np.asarray(f) for _, _, f in local),
        )

    def link_transforms(self, q: torch.Tensor) -> torch.Tensor:
        """Every link's pose in the hand frame, ``x_hand = T[l] @ [x_link, 1]``.

        Parameters
        ----------
        q : torch.Tensor, shape (k,), float64
            The independent joints, in `joint_names` order (rad, m for slides).

        Returns
        -------
        torch.Tensor, shape (n_links, 4, 4)

        Raises
        ------
        TypeError
            ``q`` is not float64 (its rounding would reach the links by 1e-8 m).
        """
        if q.dtype != torch.float64:
            raise TypeError(
                f"q: dtype {q.dtype}; pass q.double() (the volume is exact in float64)"
            )
        motions = []
        for kind, axis, anchor, index, ratio, offset, home in self.joints:
            value = offset + ratio * (q[index] if index is not None else 0.0)
            delta = value - home
            if kind == "hinge":
                motions.append(_hinge(axis, anchor, torch.as_tensor(delta)))
            else:
                motions.append(_rigid(torch.eye(3, dtype=torch.float64), axis * delta))
        out = []
        for chain, home in zip(self.chains, self.home, strict=True):
            t = torch.eye(4, dtype=torch.float64)
            for j in chain:
                t = t @ motions[j]
            out.append(t @ home)
        return torch.stack(out)

    def link_vertices(self, q: torch.Tensor) -> list[torch.Tensor]:
        """Every link's vertices (n_l, 3), metres, hand frame, posed by ``q``."""
        poses = self.link_transforms(q)
        return [v @ p[:3, :3].T + p[:3, 3] for v, p in zip(self.local, poses, strict=True)]


def _rotation(w: torch.Tensor) -> torch.Tensor:
    """The rotation (3, 3) of rotation vector ``w`` (rad); differentiable at 0 too."""
    return torch.linalg.matrix_exp(_skew(w))


@dataclass(frozen=True)
class Problem:
    """One grasp's loss as a function of ``z`` = (the hand's joints (k), the object's
    translation (3) and rotation vector about its centroid (3), in units of
    ``object_scale`` canonical units).

    Attributes
    ----------
    kinematics : TorchKinematics
    object_vertices, object_faces : torch.Tensor (n, 3) and numpy.ndarray (m, 3)
        The object at the grasp's pose, hand frame, metres.
    centre : torch.Tensor, shape (3,)
        The object's centroid there (what it turns about).
    length, radius : float
        Metres one unit of the object's translation moves it; the distance of its farthest
        vertex from the centroid (a unit of rotation moves that vertex by ``length``).
    """

    kinematics: TorchKinematics
    object_vertices: torch.Tensor
    object_faces: np.ndarray
    centre: torch.Tensor
    length: float
    radius: float

    @classmethod
    def of(cls, grasp: eg.Grasp, object_scale: float = OBJECT_SCALE) -> Problem:
        pose, solid = grasp.object_pose, grasp.object
        return cls(
            kinematics=TorchKinematics.of(grasp.hand),
            object_vertices=torch.from_numpy(solid.vertices @ pose[:3, :3].T + pose[:3, 3]),
            object_faces=np.asarray(solid.faces),
            centre=torch.from_numpy(pose[:3, :3] @ solid.centroid + pose[:3, 3]),
            length=object_scale / grasp.frame.scale,
            radius=float(np.linalg.norm(solid.vertices - solid.centroid, axis=1).max()),
        )

    def start(self, grasp: eg.Grasp) -> torch.Tensor:
        """``z`` of the grasp as it is (its joints clamped to their limits)."""
        kin = self.kinematics
        q = torch.tensor([grasp.hand.joints[n] for n in kin.joint_names], dtype=torch.float64)
        return torch.cat([q.clamp(kin.lower, kin.upper), torch.zeros(6, dtype=torch.float64)])

    def motion(self, z: torch.Tensor) -> torch.Tensor:
        """The object's rigid motion (4, 4) of ``z``, hand frame."""
        k = len(self.kinematics.joint_names)
        r = _rotation(z[k + 3 :] * (self.length / self.radius))
        return _rigid(r, self.centre + self.length * z[k : k + 3] - r @ self.centre)

    def loss(self, z: torch.Tensor, backend="exact") -> tuple[torch.Tensor, list[float]]:
        """Σ over links of volume(link ∩ object) (m^3, a tensor with its graph), and each
        link's volume. A link whose bounding box misses the object's has volume exactly 0
        and is not computed."""
        k = len(self.kinematics.joint_names)
        m = self.motion(z)
        moved = self.object_vertices @ m[:3, :3].T + m[:3, 3]
        lo, hi = moved.detach().min(0).values, moved.detach().max(0).values
        total, volumes = torch.zeros((), dtype=torch.float64), []
        links = self.kinematics.link_vertices(z[:k])
        for v, f in zip(links, self.kinematics.faces, strict=True):
            box = v.detach()
            if (box.min(0).values > hi).any() or (box.max(0).values < lo).any():
                volumes.append(0.0)
                continue
            volume = intersection_volume(v, f, moved, self.object_faces, backend=backend)
            volumes.append(float(volume.detach()))
            total = total + volume
        return total, volumes

    def volumes_along(self, z, step, fractions, backend="exact") -> np.ndarray:
        """The loss at ``z + s step`` for each ``s`` of ``fractions`` (m^3), without its
        gradient: per link, one call for every fraction (the object's pose relative to the
        link is a rigid motion at each)."""
        k = len(self.kinematics.joint_names)
        with torch.no_grad():
            points = [z + s * step for s in fractions]
            links = torch.stack([self.kinematics.link_transforms(p[:k]) for p in points])
            motions = torch.stack([self.motion(p) for p in points])
        relative = np.linalg.inv(links.numpy()) @ motions.numpy()[:, None]
        b = (self.object_vertices.numpy(), self.object_faces)
        total = np.zeros(len(fractions))
        for i, (v, f) in enumerate(zip(self.kinematics.local, self.kinematics.faces, strict=True)):
            total += eg.intersection_volume((v.numpy(), f), b, relative[:, i], backend=backend)
        return total

    def grasp(self, start: eg.Grasp, z: torch.Tensor) -> eg.Grasp:
        """``start`` with the joints and the object's pose of ``z``."""
        k = len(self.kinematics.joint_names)
        joints = dict(zip(self.kinematics.joint_names, z[:k].tolist(), strict=True))
        pose = self.motion(z.detach()).numpy() @ start.object_pose
        return eg.Grasp(start.hand.with_joints(joints), start.object, pose, start.name)


def link_volumes(grasp: eg.Grasp, backend="exact") -> list[float]:
    """Each link's volume ∩ the object (m^3), in `Hand.link_names` order: the loss's terms at
    the grasp as it is, from the hand's own posed links (the library's kinematics, not
    `TorchKinematics`)."""
    b, pose = (grasp.object.vertices, grasp.object.faces), grasp.object_pose
    return [
        float(eg.intersection_volume(a, b, pose, backend=backend))
        for a in grasp.hand.link_arrays()
    ]


@dataclass(frozen=True)
class Descent:
    """What `descend` did.

    Attributes
    ----------
    grasp : exactgrasp.Grasp
        The result: the start's hand and object, new joints and object pose.
    losses : tuple of float
        The loss (m^3) at the start and after each accepted step; the last is the result's.
    evaluations : int
        Loss and gradient evaluations (the start's, and every step's, taken back or not).
    seconds : float
        Wall time.
    """

    grasp: eg.Grasp
    losses: tuple[float, ...]
    evaluations: int
    seconds: float

    @property
    def removed(self) -> bool:
        """The loss reads exactly 0: no link penetrates the object."""
        return self.losses[-1] == 0.0


def _contact(problem: Problem, z, step, backend) -> float:
    """The fraction ``s`` of ``step`` (from ``z``, penetrating, to ``z + step``, not) where
    the loss first reads 0 along it, to `CONTACT_TOL` of the step's largest parameter."""
    lo, hi = 0.0, 1.0
    while (hi - lo) * float(step.abs().max()) > CONTACT_TOL:
        s = np.linspace(lo, hi, BRACKET + 1)[1:-1]
        inside = np.flatnonzero(problem.volumes_along(z, step, s, backend) > 0)
        if not len(inside):
            hi = float(s[0])
            continue
        lo = float(s[inside[-1]])
        hi = float(s[inside[-1] + 1]) if inside[-1] + 1 < len(s) else hi
    return hi


def _evaluate(problem: Problem, z: torch.Tensor, backend) -> tuple:
    """``(z, loss, gradient by z)``."""
    z = z.detach().requires_grad_()
    loss, _ = problem.loss(z, backend)
    if not loss.requires_grad:  # no link near the object
        return z.detach(), 0.0, torch.zeros_like(z)
    loss.backward()
    return z.detach(), float(loss.detach()), z.grad


def descend(
    grasp: eg.Grasp,
    *,
    rotation: bool = True,
    object_scale: float = OBJECT_SCALE,
    max_steps: int = MAX_STEPS,
    backend="exact",
) -> Descent:
    """Remove a grasp's penetration by gradient descent on the exact volume.

    Each step is Polyak's with momentum, ``Δz = β Δz_prev - c L(z) g / (g · g)``: ``L`` the
    loss, ``g`` its gradient by ``z`` projected onto the joint limits, ``β`` = `MOMENTUM`,
    ``c`` the overshoot (1 at first, doubled after a step that shed less than `SLOW` of the
    loss, halved after one that shed none, which is taken back and drops the momentum); cut
    to `MAX_STEP`, joints clamped to their limits. The step that takes the loss to 0 is
    searched back to where the loss first reads 0 along it (`_contact`).

    Parameters
    ----------
    grasp : exactgrasp.Grasp
        A hand model with joints (hinges or slides) and an object.
    rotation : bool
        Let the object turn (about its centroid) as well as move.
    object_scale : float
        See `OBJECT_SCALE`.
    max_steps : int
        Most loss evaluations.
    backend : "exact" or ExactBackend

    Returns
    -------
    Descent
    """
    t0 = time.perf_counter()
    problem = Problem.of(grasp, object_scale)
    kin = problem.kinematics
    k = len(kin.joint_names)
    unbounded = torch.full((6,), torch.inf, dtype=torch.float64)
    lower, upper = torch.cat([kin.lower, -unbounded]), torch.cat([kin.upper, unbounded])
    free = torch.ones(k + 6, dtype=torch.float64)
    free[k + 3 :] = float(rotation)
    z, loss, grad = _evaluate(problem, problem.start(grasp), backend)
    losses, evaluations, overshoot, previous = [loss], 1, 1.0, torch.zeros_like(z)
    while loss > 0.0 and evaluations < max_steps:
        # Joints at a limit the gradient pushes them past take no part in the step.
        g = grad * free
        g = torch.where(((z <= lower) & (g > 0)) | ((z >= upper) & (g < 0)), 0.0, g)
        if not bool((g != 0).any()):
            break
        step = MOMENTUM * previous - overshoot * loss / float(g @ g) * g
        step = step * min(1.0, MAX_STEP / float(step.abs().max()))
        step = torch.minimum(torch.maximum(z + step, lower), upper) - z
        trial, trial_loss, trial_grad = _evaluate(problem, z + step, backend)
        evaluations += 1
        if trial_loss == 0.0:
            # The search reads volumes in the links' frames, the loss in the hand's: where a
            # face lies on a face their roundings may differ, so the loss has the last word.
            touching = z + _contact(problem, z, step, backend) * step
            evaluations += 1
            z = touching if _evaluate(problem, touching, backend)[1] == 0.0 else trial
            loss = 0.0
            losses.append(loss)
        elif trial_loss < loss:
            if trial_loss > SLOW * loss:
                overshoot = min(2.0 * overshoot, MAX_OVERSHOOT)
            z, loss, grad, previous = trial, trial_loss, trial_grad, step
            losses.append(loss)
        else:
            overshoot, previous = overshoot / 2.0, torch.zeros_like(z)
    return Descent(
        grasp=problem.grasp(grasp, z),
        losses=tuple(losses),
        evaluations=evaluations,
        seconds=time.perf_counter() - t0,
    )


def _report(name: str, r: Descent) -> None:
    left = "" if r.removed else " (penetration left)"
    print(f"{name}: loss {r.losses[0] * 1e9:.6g} -> {r.losses[-1] * 1e9:.6g} mm^3 in "
          f"{r.evaluations} evaluations, {r.seconds:.1f} s{left}", flush=True)  # fmt: skip


def main(argv: list[str] | None = None) -> int:
    """The command line (see the module's docstring); returns the exit status."""
    if str(ROOT / "benchmarks") not in sys.path:
        sys.path.insert(0, str(ROOT / "benchmarks"))
    from separate_authors import RAW, compare_method, method_table
    from shared_data import add_data_options, data_or_skip

    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("records", nargs="*", type=Path, help="grasp files (default: one record)")
    ap.add_argument("--compare", action="store_true", help="against separate, 34 records")
    ap.add_argument("--limit", type=int, default=None, help="--compare: the first N only")
    ap.add_argument("--table", type=Path, help="print the table of --compare's --json file")
    ap.add_argument("--steps", type=int, default=MAX_STEPS, help="most loss evaluations")
    ap.add_argument("--object-scale", type=float, default=OBJECT_SCALE)
    ap.add_argument("--rotation", action=argparse.BooleanOptionalAction, default=True)
    add_data_options(ap)
    args = ap.parse_args(argv)
    options = {"rotation": args.rotation, "object_scale": args.object_scale}
    options["max_steps"] = args.steps
    name = "gradient descent (this example)"
    if args.table:
        print(method_table(json.loads(args.table.read_text()), name))
        return 0
    if args.records and not args.compare:
        for path in args.records:
            _report(path.stem, descend(eg.Grasp.from_file(path), **options))
        return 0
    data = data_or_skip(args, f"{RAW}/index.csv")
    if data is None:
        return 0
    if not args.compare:
        path = data / RAW / "CerealBox" / "obj5_sub4_grasp1_optimal0.json"
        _report(path.stem, descend(eg.Grasp.from_file(path), **options))
        return 0

    def method(raw):
        result = descend(raw, **options)
        return result.grasp, result.evaluations

    compare_method(data, method, link_volumes, name, args.limit, args.json)
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
