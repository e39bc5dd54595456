"""Mesh URIs of robotics packages: ``package://NAME/...``, ``model://NAME/...``, ``file://...``.

URDF and MJCF files written for ROS or Gazebo name their meshes by package, not by path. A
`PackageResolver` turns such a URI into a file: through ``package_dirs`` (a mapping name ->
folder, or folders holding packages), then the ``ROS_PACKAGE_PATH`` environment variable
(for ``model://`` also ``GZ_SIM_RESOURCE_PATH`` and ``GAZEBO_MODEL_PATH``), then the model
file's own folder and its parents. A folder is package NAME when its ``package.xml`` says so
or when it is named NAME. `rewrite_urdf` and `rewrite_spec` replace the URIs of a model by
absolute paths before MuJoCo compiles it.
"""

from __future__ import annotations

import os
import re
import xml.etree.ElementTree as ET
from collections.abc import Iterable, Mapping
from pathlib import Path
from typing import Any

from exactgrasp.errors import Fix, ModelError

__all__ = [
    "ENV_PATHS",
    "SCAN_DEPTH",
    "PackageResolver",
    "package_env",
    "rewrite_spec",
    "rewrite_urdf",
    "split_uri",
]

#: Environment variables searched for each URI scheme, in order (``os.pathsep``-separated).
ENV_PATHS = {
    "package": ("ROS_PACKAGE_PATH",),
    "model": ("ROS_PACKAGE_PATH", "GZ_SIM_RESOURCE_PATH", "GAZEBO_MODEL_PATH"),
}
#: How deep below a search folder packages are looked for (a ROS workspace's ``src/``
#: holds packages two or three levels down).
SCAN_DEPTH = 4
# MJCF's parser normalises "package://x" to "package:/x"; both spellings are URIs here.
_URI = re.compile(r"^(package|model|file):/+(.*)$", re.IGNORECASE)


def split_uri(text: str) -> tuple[str, str, str] | None:
    """``(scheme, package name, path inside it)`` of a URI, None for a plain path.

    For ``file://`` URIs the name is empty and the path is absolute.
    """
    match = _URI.match(text.strip())
    if match is None:
        return None
    scheme, rest = match.group(1).lower(), match.group(2)
    if scheme == "file":
        return scheme, "", "/" + rest
    name, _, inside = rest.partition("/")
    return scheme, name, inside


def package_env() -> dict[str, str]:
    """The environment variables the resolver reads, with their current values."""
    names = dict.fromkeys(n for group in ENV_PATHS.values() for n in group)
    return {n: os.environ[n] for n in names if n in os.environ}


def _package_name(folder: Path) -> str | None:
    """The name a folder's ``package.xml`` gives, if it has a readable one."""
    try:
        name = ET.parse(folder / "package.xml").getroot().findtext("name")
    except (OSError, ET.ParseError):
        return None
    return name.strip() if name else None


class PackageResolver:
    """Resolves the mesh URIs of one model file.

    Parameters
    ----------
    model_path : pathlib.Path
        The model file; its folder and parents are the last place searched.
    package_dirs : mapping of str to path, path, or sequence of paths, optional
        ``{package name: its folder}``, or folders each of which is a package or holds
        packages (up to `SCAN_DEPTH` levels down).
    source : str
        The model, for messages.
    """

    def __init__(self, model_path: Path, package_dirs: Any = None, source: str = ""):
        self.model_dir = Path(model_path).resolve().parent
        self.source = source or str(model_path)
        self.named: dict[str, Path] = {}
        self.roots: list[Path] = []
        if package_dirs is None:
            pass
        elif isinstance(package_dirs, Mapping):
            for name, folder in package_dirs.items():
                entry = Fix(
                    "package_dirs", {name: folder}, "entry", python=f"package_dirs[{name!r}]"
                )
                self.named[str(name)] = self._folder(folder, entry)
        elif isinstance(package_dirs, str | os.PathLike):
            self.roots.append(self._folder(package_dirs, Fix("package_dirs", form="entry")))
        elif isinstance(package_dirs, Iterable):
            entry = Fix("package_dirs", form="entry", python="package_dirs entry")
            self.roots += [self._folder(f, entry) for f in package_dirs]
        else:
            raise ModelError(
                Fix("package_dirs"),
                " must be a dict {package name: folder} or a list of folders "
                f"holding packages, got {type(package_dirs).__name__}",
            )
        self._scans: dict[Path, dict[str, Path]] = {}

    def _folder(self, folder: Any, what: Fix) -> Path:
        if not isinstance(folder, str | os.PathLike):
            raise ModelError(what, f": expected a folder path, got {folder!r}")
        path = Path(folder).expanduser()
        if not path.is_dir():
            raise ModelError(f"{self.source}: ", what, f" {str(folder)!r} is not a folder")
        return path.resolve()

    def _scan(self, root: Path) -> dict[str, Path]:
        """Packages in and below ``root``: ``{name: folder}``, the shallowest first."""
        if root not in self._scans:
            found: dict[str, Path] = {}
            level = [root]
            for _ in range(SCAN_DEPTH + 1):
                deeper = []
                for folder in level:
                    name = _package_name(folder)
                    found.setdefault(name or folder.name, folder)
                    if name is None:  # a package's own subfolders are not packages
                        try:
                            deeper += [
                                p
                                for p in sorted(folder.iterdir())
                                if p.is_dir() and not p.name.startswith(".")
                            ]
                        except OSError:
                            pass
                level = deeper
            self._scans[root] = found
        return self._scans[root]

    def _env_roots(self, scheme: str) -> list[tuple[str, str, list[Path]]]:
        """``(variable, its value, the existing folders it names)`` per variable searched."""
        out = []
        for var in ENV_PATHS[scheme]:
            value = os.environ.get(var, "")
            entries = [Path(e).expanduser() for e in value.split(os.pathsep) if e]
            out.append((var, value, [e for e in entries if e.is_dir()]))
        return out

    def resolve(self, uri: str) -> Path:
        """The absolute file a URI names; `ModelError` naming it and the places searched."""
        parts = split_uri(uri)
        if parts is None:
            return Path(uri)
        scheme, name, inside = parts
        full = f"{scheme}://{name}/{inside}" if scheme != "file" else f"file://{inside}"
        if scheme == "file":
            if Path(inside).is_file():
                return Path(inside)
            raise ModelError(f"{self.source}: mesh {full!r}: {inside} does not exist")
        tried: list[str] = []

        def hit(folder: Path | None) -> Path | None:
            if folder is None:
                return None
            target = folder / inside
            if target.is_file():
                return target.resolve()
            tried.append(f"package {name!r} found at {folder}, but it holds no {inside}")
            return None

        if name in self.named and (found := hit(self.named[name])):
            return found
        for root in self.roots:
            if found := hit(self._scan(root).get(name)):
                return found
        env = self._env_roots(scheme)
        for _, _, roots in env:
            for root in roots:
                if found := hit(self._scan(root).get(name)):
                    return found
        if found := self._fallback(name, inside, hit):
            return found
        raise ModelError(*self._message(full, name, inside, env, tried))

    def _fallback(self, name: str, inside: str, hit) -> Path | None:
        """The model's folder and its parents: a package.xml naming the package, a folder
        named like it, or a folder that holds ``NAME/inside``; then any that holds
        ``inside``."""
        ancestors = [self.model_dir, *self.model_dir.parents]
        for folder in ancestors:
            if _package_name(folder) == name or folder.name == name:
                if found := hit(folder):
                    return found
            if (folder / name / inside).is_file():
                return (folder / name / inside).resolve()
        for folder in ancestors:
            if (folder / inside).is_file():
                return (folder / inside).resolve()
        return None

    def _message(self, full: str, name: str, inside: str, env, tried: list[str]) -> tuple:
        given = (
            ", ".join(
                [f"{k!r}: {str(v)!r}" for k, v in self.named.items()]
                + [str(r) for r in self.roots]
            )
            or "not given"
        )
        env_text = "; ".join(f"{var}: {value or 'not set'}" for var, value, _ in env)
        parents = ", ".join(str(p) for p in [self.model_dir, *self.model_dir.parents])
        found = f" ({'; '.join(dict.fromkeys(tried))})" if tried else ""
        return (
            f"{self.source}: cannot resolve mesh {full!r}: no package {name!r} holding "
            f"{inside} was found{found}. Searched ",
            Fix("package_dirs"),
            f" ({given}); {env_text}; the model's folder and its parents ({parents}). ",
            Fix("package_dirs", {name: f"/path/to/{name}"}, "Pass"),
            " or ",
            Fix("package_dirs", ["/folder/holding/packages"]),
            ", or set ROS_PACKAGE_PATH.",
        )


def rewrite_urdf(robot: ET.Element, resolver: PackageResolver, keep_visual: bool) -> int:
    """Replace the URI mesh file names of a parsed URDF by absolute paths, in place.

    Parameters
    ----------
    robot : xml.etree.ElementTree.Element
        The ``<robot>`` element.
    resolver : PackageResolver
    keep_visual : bool
        False: ``<visual>`` meshes are left alone (MuJoCo discards them unread).

    Returns
    -------
    int
        How many file names were replaced.
    """
    count = 0
    for kind in ("collision", "visual"):
        if kind == "visual" and not keep_visual:
            continue
        for mesh in robot.iterfind(f".//link/{kind}/geometry/mesh"):
            filename = mesh.get("filename", "")
            if split_uri(filename) is not None:
                mesh.set("filename", str(resolver.resolve(filename)))
                count += 1
    return count


def rewrite_spec(spec: Any, resolver: PackageResolver) -> int:
    """Replace the URI file names of a parsed MJCF's assets (``mujoco.MjSpec``) in place.

    Returns
    -------
    int
        How many file names were replaced.
    """
    count = 0
    for group in ("meshes", "hfields", "textures", "skins"):
        for asset in getattr(spec, group, ()):
            filename = getattr(asset, "file", "") or ""
            if split_uri(filename) is not None:
                asset.file = str(resolver.resolve(filename))
                count += 1
    return count
