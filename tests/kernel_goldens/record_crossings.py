"""Record what `find_crossings` and `find_contacts` return on fixed meshes.

``numba_crossings.npz`` in this folder holds the meshes made here and the results of the numba
crossing kernels of commit 473962b (the last with them), recorded with that commit's package::

    python tests/kernel_goldens/record_crossings.py   # writes numba_crossings.npz beside it

Every mesh is scanned three ways: ``crossings`` (`find_crossings` by shell, every vertex its
own), ``self`` (with self-contacts, copies of one point counted as one vertex, as the intake
asks) and ``contacts`` (`find_contacts`, as the exact cut asks). The meshes:

* ``built/...``: the tests' solids that touch themselves (`tests.touching_meshes`), the messy
  meshes (`tests.messy_meshes`) and the degenerate palms (`tests.degenerate_palms`), as built
  (exact contacts) and moved by a rotation, a scale and a shift (contacts rounded);
* ``fuzz/...``: triangle soups from fixed seeds: corners on a small integer grid (shared
  corners, coplanar and touching triangles), the same rotated (signs within the bound), random
  triangles, a few large ones among small ones (the grid made coarser), huge and tiny
  coordinates (the bound overflowing and underflowing), none and one;
* ``intake/...``: the meshes the intake itself scans while it resolves some of those solids
  and crumpled spheres (`Solid`, caught at the scan): after edges of four faces are split and
  after shells are cut. Stored as they were; they depend on the intake's code, not only here;
* ``large/...``: the messy-hand benchmark's palm (82k triangles, made by trimesh here) and the
  LEAP Hand link of the shared data's ``exactness/dip_link_ball.npz`` (31k triangles, its
  edges of four faces split as the intake does): only a SHA-256 of the inputs and the results
  are stored.

`tests/test_kernel_goldens.py` checks that the compiled kernels give the same results to the
bit. Run this again only to add a case on purpose (the file then records the kernels of the
day, which the test can no longer compare with numba's).
"""

from __future__ import annotations

import hashlib
import importlib.util
import sys
import warnings
from pathlib import Path

import numpy as np

HERE = Path(__file__).resolve().parent
ROOT = HERE.parents[1]
OUT = HERE / "numba_crossings.npz"
MODES = ("crossings", "self", "contacts")
#: Intake meshes larger than this are left out (the file stays small).
MAX_INTAKE_FACES = 3000

if str(ROOT) not in sys.path:
    sys.path.insert(0, str(ROOT))


def identity_of(V: np.ndarray) -> np.ndarray:
    """Equal coordinates, one identity (as the intake counts copies of one point)."""
    return np.unique(V, axis=0, return_inverse=True)[1].reshape(-1).astype(np.int64)


def scan(V, F, label, ident) -> dict[str, np.ndarray]:
    """The three scans of one mesh: keys ``<mode>/t``, ``/u``, ``/code``, ``/point``."""
    from exactgrasp.geometry.crossings import find_contacts, find_crossings

    out = {}
    found = {
        "crossings": find_crossings(V, F, label),
        "self": find_crossings(V, F, label, identity=ident, self_contacts=True),
        "contacts": find_contacts(V, F, ident),
    }
    for mode, arrays in found.items():
        for name, a in zip(("t", "u", "code", "point"), arrays, strict=False):
            out[f"{mode}/{name}"] = a
    return out


def _moved(V: np.ndarray, rng) -> np.ndarray:
    q = np.linalg.qr(rng.normal(size=(3, 3)))[0]
    return V @ q.T * rng.choice([1e-3, 1e3]) + rng.uniform(-900.0, 900.0, 3)


def built_meshes() -> dict[str, tuple[np.ndarray, np.ndarray]]:
    """The tests' solids, as built and moved."""
    from tests import messy_meshes
    from tests.degenerate_palms import PALMS
    from tests.touching_meshes import FAMILY

    builders = {**FAMILY, **PALMS}
    for name in ("cubes_sharing_an_edge", "tetrahedra_sharing_a_vertex", "dented_box"):
        builders[name] = getattr(messy_meshes, name)
    builders["folded_box"] = messy_meshes.folded_box
    builders["figure_eight_tube"] = messy_meshes.figure_eight_tube
    rng = np.random.default_rng(4)
    meshes = {}
    for name, build in builders.items():
        V, F = build()
        V, F = np.asarray(V, np.float64), np.asarray(F, np.int64)
        key = name.replace(" ", "_").replace(",", "")
        meshes[key] = (V, F)
        if len(F) < 1000:
            meshes[key + "_moved"] = (_moved(V, rng), F)
    return meshes


def _soup(points: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Triangles given by corners (k, 3, 3), equal corners welded."""
    V, inverse = np.unique(points.reshape(-1, 3), axis=0, return_inverse=True)
    return V, inverse.reshape(-1, 3).astype(np.int64)


def fuzz_meshes(rng) -> dict[str, tuple[np.ndarray, np.ndarray]]:
    """Triangle soups (see the module): small triangles, so that each meets a few others."""
    corners = rng.integers(0, 8, (300, 1, 3)) + rng.integers(0, 3, (300, 3, 3))
    grid = _soup(corners.astype(np.float64) / 4.0)
    q = np.linalg.qr(rng.normal(size=(3, 3)))[0]
    # Three triangles spanning a box of 50^3 among small ones: the grid is made coarser.
    spanning = rng.uniform(0.0, 4.0, (300, 1, 3)) + rng.uniform(0.0, 0.4, (300, 3, 3))
    far = np.array([[-20.0, -20.0, -20.0], [30.0, 30.0, -20.0], [0.0, 30.0, 30.0]])
    spanning[:3] = rng.uniform(-2.0, 2.0, (3, 1, 3)) + far
    unwelded = rng.integers(0, 6, (100, 1, 3)) + rng.integers(0, 2, (100, 3, 3))
    return {
        "grid": grid,
        "grid_rotated": (grid[0] @ q.T + [0.3, -0.1, 0.7], grid[1]),
        "random": _soup(rng.uniform(0.0, 3.0, (200, 1, 3)) + rng.uniform(0, 1.0, (200, 3, 3))),
        "large_among_small": _soup(spanning),
        "huge": (grid[0] * 1e100, grid[1]),
        "overflowing_bound": (grid[0] @ q.T * 1e110, grid[1]),
        "tiny": (grid[0] @ q.T * 1e-150, grid[1]),
        "unwelded": (unwelded.reshape(-1, 3) / 2.0, np.arange(300, dtype=np.int64).reshape(-1, 3)),
        "one_triangle": (np.eye(3), np.array([[0, 1, 2]], np.int64)),
        "no_triangles": (np.eye(3), np.empty((0, 3), np.int64)),
    }


def intake_meshes() -> dict[str, tuple[np.ndarray, ...]]:
    """The meshes (V, F, label, identity) the intake scans while it resolves the tests'
    solids and a few crumpled spheres, as it scans them."""
    import trimesh

    from exactgrasp.errors import MeshError
    from exactgrasp.geometry import crossings
    from exactgrasp.geometry.solid import Solid
    from tests.degenerate_palms import PALMS, frames

    seen: dict[str, tuple[np.ndarray, ...]] = {}
    original = crossings._scan

    def caught(V, F, label, ident, self_contacts, everything):
        arrays = [np.ascontiguousarray(V, np.float64), np.ascontiguousarray(F, np.int64)]
        arrays += [np.ascontiguousarray(label, np.int64)]
        arrays += [np.arange(len(V), dtype=np.int64) if ident is None else np.array(ident)]
        if len(F) <= MAX_INTAKE_FACES:
            digest = hashlib.sha256(b"".join(a.tobytes() for a in arrays)).hexdigest()
            seen.setdefault(digest, tuple(a.copy() for a in arrays))
        return original(V, F, label, ident, self_contacts, everything)

    solids = list(built_meshes().values())
    for _, scale, rotation, shift, _ in frames():
        solids += [(V @ rotation.T * scale + shift, F) for V, F in (m() for m in PALMS.values())]
    rng = np.random.default_rng(0)
    for _ in range(4):
        sphere = trimesh.creation.icosphere(subdivisions=int(rng.integers(1, 3)))
        scale = 1 + rng.normal(scale=rng.uniform(0.2, 0.8), size=(len(sphere.vertices), 1))
        V = sphere.vertices * scale + rng.normal(scale=0.15, size=sphere.vertices.shape)
        solids.append((V, np.asarray(sphere.faces)))
    crossings._scan = caught
    try:
        for V, F in solids:
            with warnings.catch_warnings():
                warnings.simplefilter("ignore")
                try:
                    Solid(V, F, name="recorded", check_scale=False)
                except MeshError:  # a refused mesh was scanned all the same
                    pass
    finally:
        crossings._scan = original
    return {f"{k:03d}": arrays for k, arrays in enumerate(seen.values())}


def messy_palm() -> tuple[np.ndarray, np.ndarray]:
    """The palm of ``benchmarks/messy_hand.py``: 81,920 triangles through themselves."""
    spec = importlib.util.spec_from_file_location("messy_hand", ROOT / "benchmarks/messy_hand.py")
    module = importlib.util.module_from_spec(spec)
    spec.loader.exec_module(module)
    V, F = module.pushed_sphere()
    return np.ascontiguousarray(V, np.float64), np.ascontiguousarray(F, np.int64)


def dip_link(data: Path) -> tuple[np.ndarray, np.ndarray] | None:
    """The LEAP Hand link of the shared data with its edges of four faces split, as the intake
    scans it, or None where the shared data is absent."""
    from exactgrasp.geometry.topology import split_nonmanifold

    path = data / "exactness" / "dip_link_ball.npz"
    if not path.is_file():
        return None
    with np.load(path) as arrays:
        V, F = arrays["link_vertices"], arrays["link_faces"]
    W, G, _, _ = split_nonmanifold(V, F)
    return np.ascontiguousarray(W, np.float64), np.ascontiguousarray(G, np.int64)


def digest(*arrays: np.ndarray) -> np.ndarray:
    """SHA-256 of the arrays' dtypes, shapes and bytes, as 32 uint8."""
    h = hashlib.sha256()
    for a in arrays:
        h.update(f"{a.dtype}{a.shape}".encode())
        h.update(np.ascontiguousarray(a).tobytes())
    return np.frombuffer(h.digest(), np.uint8)


def with_shells(V: np.ndarray, F: np.ndarray) -> dict[str, np.ndarray]:
    """A mesh's arrays: V, F, its shells as labels and its identity by coordinates."""
    from exactgrasp.geometry.topology import split_shells

    label = split_shells(F, len(V))[1].astype(np.int64)
    return {"V": V, "F": F, "label": label, "ident": identity_of(V)}


def inputs() -> dict[str, np.ndarray]:
    """The stored meshes made here (``built/``, ``fuzz/``), from fixed seeds."""
    out = {}
    for name, (V, F) in built_meshes().items():
        out.update({f"built/{name}/{k}": a for k, a in with_shells(V, F).items()})
    rng = np.random.default_rng(20261205)
    for name, (V, F) in fuzz_meshes(rng).items():
        arrays = with_shells(V, F)
        arrays["label"] = rng.integers(0, 3, len(F)).astype(np.int64)
        out.update({f"fuzz/{name}/{k}": a for k, a in arrays.items()})
    return out


def main() -> int:
    from exactgrasp.datapath import data_dir

    arrays = inputs()
    for name, (V, F, label, ident) in intake_meshes().items():
        arrays.update({f"intake/{name}/V": V, f"intake/{name}/F": F})
        arrays.update({f"intake/{name}/label": label, f"intake/{name}/ident": ident})
    cases = sorted({key.rsplit("/", 1)[0] for key in arrays})
    results = {}
    for case in cases:
        V, F = arrays[f"{case}/V"], arrays[f"{case}/F"]
        found = scan(V, F, arrays[f"{case}/label"], arrays[f"{case}/ident"])
        results.update({f"{case}/{k}": a for k, a in found.items()})
    large = {"palm": messy_palm(), "dip_link": dip_link(data_dir())}
    for name, mesh in large.items():
        if mesh is None:
            print(f"skipped large/{name}: not found")
            continue
        shells = with_shells(*mesh)
        results[f"large/{name}/sha256"] = digest(*shells.values())
        found = scan(*shells.values())
        results.update({f"large/{name}/{k}": a for k, a in found.items()})
    np.savez_compressed(OUT, **arrays, **results)
    print(f"wrote {OUT} ({OUT.stat().st_size:,} bytes, {len(cases)} meshes and the large)")
    return 0


if __name__ == "__main__":
    sys.exit(main())
