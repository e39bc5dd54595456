"""The build: meson.build installs every file of the package, compiles every Cython kernel with
the flags that round as the numba kernels they replaced did (no fused multiply-add, no
fast-math), and the kernels' sources follow the house rules.

The kernels themselves are checked against the numba kernels' results in
``tests/test_kernel_goldens.py`` and ``tests/test_exact_kernel_goldens.py``; building and
installing a wheel is described in ``docs/building.md``.
"""

from __future__ import annotations

import re
import subprocess
import sys
import tomllib
from pathlib import Path

import pytest

import exactgrasp

ROOT = Path(__file__).resolve().parents[1]
PACKAGE = ROOT / "exactgrasp"
#: What a folder of the package may hold that is not installed from it.
NOT_INSTALLED = {"meson.build"}
PYX = sorted(PACKAGE.rglob("*.pyx"))
#: Inline functions the kernels cimport (declarations and bodies, no extension of their own).
PXD = sorted(PACKAGE.rglob("*.pxd"))
MAX_LINES, MAX_FUNCTION_LINES = 400, 80


def folders() -> list[Path]:
    return [PACKAGE, *sorted(p for p in PACKAGE.rglob("*") if p.is_dir() and not ignored(p))]


def ignored(path: Path) -> bool:
    return any(part == "__pycache__" or part.startswith(".") for part in path.parts)


def listed(folder: Path) -> tuple[set[str], set[str], set[str]]:
    """Files installed, extension modules built and subfolders entered by a meson.build."""
    text = (folder / "meson.build").read_text()
    sources = re.search(r"py\.install_sources\(\s*\[(.*?)\]", text, re.S)
    files = set(re.findall(r"'([^']+)'", sources.group(1))) if sources else set()
    modules = set(re.findall(r"py\.extension_module\(\s*'(\w+)',\s*'(\w+\.pyx)'", text))
    assert all(name + ".pyx" == source for name, source in modules), modules
    return files, {source for _, source in modules}, set(re.findall(r"subdir\('(\w+)'\)", text))


@pytest.mark.parametrize("folder", folders(), ids=lambda p: str(p.relative_to(ROOT)))
def test_meson_installs_every_file_of_the_package(folder):
    files, extensions, subfolders = listed(folder)
    present = {p.name for p in folder.iterdir() if p.is_file() and not ignored(p)}
    present = {name for name in present if not name.endswith((".so", ".pyd", ".c", ".pyc"))}
    assert files == present - NOT_INSTALLED, f"{folder}/meson.build: add or drop files"
    assert extensions == {name for name in present if name.endswith(".pyx")}
    assert subfolders == {p.name for p in folder.iterdir() if p.is_dir() and not ignored(p)}


def test_package_data_is_installed():
    files, _, _ = listed(PACKAGE)
    assert "py.typed" in files
    assert "grasp-file.schema.json" in listed(PACKAGE / "grasp")[0]


def test_kernels_are_compiled_without_contraction_or_fast_math():
    text = (ROOT / "meson.build").read_text()
    assert "'-ffp-contract=off', '-fno-fast-math'" in text
    for pyx in PYX:
        build = (pyx.parent / "meson.build").read_text()
        block = re.search(rf"'{pyx.stem}',\s*'{pyx.name}',\s*c_args: (\w+)", build)
        assert block and block.group(1) == "kernel_c_args", pyx


def test_versions_and_build_backend_agree():
    project = tomllib.loads((ROOT / "pyproject.toml").read_text())
    assert project["build-system"]["build-backend"] == "mesonpy"
    requires = " ".join(project["build-system"]["requires"])
    assert "meson-python" in requires and "Cython" in requires
    meson = re.search(r"version: '([^']+)'", (ROOT / "meson.build").read_text()).group(1)
    assert meson == project["project"]["version"] == exactgrasp.__version__


def test_the_kernels_are_compiled_extensions_and_need_no_numba():
    # Every backend's kernels, the exact one's included, run with numba absent: an exact
    # volume, a voxel grid and a crossing scan in a process that never imports it.
    code = (
        "import sys\n"
        "import numpy as np\n"
        "import exactgrasp as eg\n"
        "from exactgrasp.geometry import crossings, winding\n"
        "from exactgrasp.backends.exact import intersector\n"
        "import exactgrasp.geometry._winding as w, exactgrasp.backends.voxel._kernel as k\n"
        "import exactgrasp.geometry._crossings as c, exactgrasp.backends.exact._kernel as x\n"
        "from exactgrasp.geometry.primitives import box\n"
        "cube = box([0.5, 0.5, 0.5])\n"
        "volume = eg.intersection_volume(cube, cube, np.eye(4))\n"
        "print(w.__file__, k.__file__, c.__file__, x.__file__)\n"
        "print(type(winding.winding_number).__name__, type(crossings.pair_scan).__name__)\n"
        "print(type(intersector.pose_volumes).__name__, volume, 'numba' in sys.modules)\n"
    )
    out = subprocess.run(
        [sys.executable, "-c", code], capture_output=True, text=True, check=True, cwd=ROOT
    ).stdout.split()
    assert all(path.endswith((".so", ".pyd")) for path in out[:4]), out
    assert out[4] == out[5] == out[6] == "cython_function_or_method", out
    assert abs(float(out[7]) - 1.0) < 1e-12 and out[8] == "False", out


def functions(text: str) -> list[tuple[str, int]]:
    """(name, lines) of every top-level function of a Cython source."""
    lines = text.splitlines()
    opening = re.compile(r"(def|cdef|cpdef)\s(?!class\s)[^=]*?\w+\(")
    starts = [i for i, line in enumerate(lines) if opening.match(line)]
    found = []
    for i in starts:
        end = next(
            (j for j in range(i + 1, len(lines)) if lines[j][:1] not in ("", " ", ")")), len(lines)
        )
        while not lines[end - 1].strip():
            end -= 1
        # The name before the first call parenthesis (a ctuple return type has its own).
        found.append((re.search(r"(\w+)\(", lines[i]).group(1), end - i))
    return found


def definition(text: str, name: str) -> int:
    """Where the definition of function ``name`` opens its arguments (its calls may come
    first)."""
    return re.search(rf"^(c?p?def)\s[^=\n]*?\b{name}\(", text, re.M).end()


@pytest.mark.parametrize("pyx", PYX, ids=lambda p: str(p.relative_to(ROOT)))
def test_cython_kernels_follow_the_house_rules(pyx):
    text = pyx.read_text()
    assert len(text.splitlines()) <= MAX_LINES, f"{pyx.name}: more than {MAX_LINES} lines"
    # Directives, then the module docstring.
    assert re.match(r"(# cython: .*\n)+\"\"\"\S", text), f"{pyx.name}: no module docstring"
    directives = " ".join(re.findall(r"# cython: (.*)", text))
    for directive in ("boundscheck=False", "wraparound=False", "cdivision=True"):
        assert directive in directives, f"{pyx.name}: {directive}"
    # A variant compiled with other flags includes its source whole, and defines nothing.
    included = re.findall(r'^include "(\w+\.pyx)"$', text, re.M)
    if included:
        assert all((pyx.parent / name).is_file() for name in included), included
        assert not functions(text), f"{pyx.name}: a variant defines nothing of its own"
        return
    found = functions(text)
    assert found, pyx.name
    long = [(name, n) for name, n in found if n > MAX_FUNCTION_LINES]
    assert not long, f"{pyx.name}: functions over {MAX_FUNCTION_LINES} lines: {long}"
    for name, _ in found:
        body = text[definition(text, name) :]
        assert '"""' in body.split("\n\n\n", 1)[0], f"{pyx.name}: {name} has no docstring"
    for public in re.findall(r"^def (\w+)\(", text, re.M):
        if not public.startswith("_"):
            doc = text.split(f"def {public}(", 1)[1].split('"""')[1]
            sections = ("Parameters\n    ----------", "Returns\n    -------")
            assert any(h in doc for h in sections), f"{pyx.name}: {public} (numpydoc)"
    # The GIL is released where the kernels loop (a module of extension types alone has no
    # loop of its own).
    if re.search(r"^\s+for ", text, re.M):
        assert "with nogil:" in text and "noexcept nogil" in text


@pytest.mark.parametrize("pxd", PXD, ids=lambda p: str(p.relative_to(ROOT)))
def test_inline_kernel_parts_follow_the_house_rules(pxd):
    text = pxd.read_text()
    assert len(text.splitlines()) <= MAX_LINES, f"{pxd.name}: more than {MAX_LINES} lines"
    assert re.match(r"(# cython: .*\n)+\"\"\"\S", text), f"{pxd.name}: no module docstring"
    found = functions(text)
    # A part of declarations alone (extension types, constants) defines no function.
    assert found or not re.search(r"^cdef inline", text, re.M), pxd.name
    long = [(name, n) for name, n in found if n > MAX_FUNCTION_LINES]
    assert not long, f"{pxd.name}: functions over {MAX_FUNCTION_LINES} lines: {long}"
    for name, _ in found:
        head, body = text[: definition(text, name)], text[definition(text, name) :]
        assert head.rsplit("\n", 1)[-1].startswith("cdef inline "), f"{pxd.name}: {name}"
        assert "noexcept nogil:" in body.split('"""', 1)[0], f"{pxd.name}: {name} holds the GIL"
        assert '"""' in body.split("\n\n\n", 1)[0], f"{pxd.name}: {name} has no docstring"


def test_the_function_rule_measures_functions():
    text = 'cdef int f(int a) noexcept nogil:\n    """x"""\n    return a\n\n\ndef g(\n    b,\n):\n'
    text += '    """y"""\n' + "    b += 1\n" * 3 + "\n\ncdef struct S:\n    int a\n"
    assert functions(text) == [("f", 3), ("g", 7)]
    ctuple = "cdef inline (double, int) h(double a) noexcept nogil:\n    return a, 1\n"
    assert functions(ctuple) == [("h", 2)]


def test_make_installs_the_build_requirements_first():
    makefile = (ROOT / "Makefile").read_text()
    deps = re.search(r"^BUILD_DEPS := (.*)$", makefile, re.M).group(1)
    requires = tomllib.loads((ROOT / "pyproject.toml").read_text())["build-system"]["requires"]
    assert re.findall(r'"([^"]+)"', deps) == [*requires, "ninja"]
    assert "--no-build-isolation -e" in makefile
