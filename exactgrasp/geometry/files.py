"""Files next to grasp records: resolving and relativising paths, file identities, binary PLY."""

from __future__ import annotations

import os
from pathlib import Path

import numpy as np

from exactgrasp.errors import GraspFileError

__all__ = ["file_identity", "relative_path", "resolve_path", "write_ply"]


def resolve_path(base_dir: Path, relative: str, source: str, what: str) -> Path:
    """A path named in a grasp file, resolved against the file's folder; it must exist.

    Parameters
    ----------
    base_dir : pathlib.Path
        Folder of the grasp file.
    relative : str
        The path as written (relative to ``base_dir``, or absolute).
    source : str
        The grasp file, for the message.
    what : str
        What the path names ("object", "hand model", ...), for the message.

    Returns
    -------
    pathlib.Path
    """
    path = Path(relative)
    path = path if path.is_absolute() else base_dir / path
    if not path.exists():
        raise GraspFileError(
            f"{source}: the {what} file {relative!r} (resolved to {path}) does not exist; paths "
            "in a grasp file are relative to the grasp file."
        )
    return path


def relative_path(path: str | os.PathLike, base_dir: Path) -> str:
    """``path`` relative to ``base_dir`` (both resolved), as written into a grasp file."""
    return os.path.relpath(Path(path).resolve(), base_dir.resolve())


def file_identity(path: Path) -> tuple:
    """``(resolved path, mtime in ns, size in bytes)``, or ``(path, None)`` for a missing file.

    Equal identities mean "the same file, unchanged", for caches keyed by files.
    """
    try:
        stat = path.stat()
    except OSError:
        return (str(path), None)
    return (str(path.resolve()), stat.st_mtime_ns, stat.st_size)


def write_ply(path: Path, vertices: np.ndarray, faces: np.ndarray | None = None) -> None:
    """Binary little-endian PLY with float64 vertices.

    trimesh's exporter writes float32, which would break bit-for-bit round trips of grasp
    files.

    Parameters
    ----------
    path : pathlib.Path
    vertices : numpy.ndarray, shape (n, 3)
        Coordinates (in the unit the reader will be told).
    faces : numpy.ndarray, shape (m, 3), optional
        Vertex indices of triangles; None writes a point cloud.
    """
    vertices = np.ascontiguousarray(vertices, dtype="<f8")
    header = [
        "ply",
        "format binary_little_endian 1.0",
        f"element vertex {len(vertices)}",
        "property double x",
        "property double y",
        "property double z",
    ]
    body = vertices.tobytes()
    if faces is not None:
        header += [f"element face {len(faces)}", "property list uchar int vertex_indices"]
        rows = np.zeros(len(faces), dtype=[("n", "u1"), ("v", "<i4", (3,))])
        rows["n"] = 3
        rows["v"] = faces
        body += rows.tobytes()
    path.write_bytes(("\n".join([*header, "end_header"]) + "\n").encode() + body)
