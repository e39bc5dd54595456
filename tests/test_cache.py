"""The disk caches' keys: the package version and the sources of the code that fills them."""

from __future__ import annotations

import shutil
from pathlib import Path

from exactgrasp import cache
from exactgrasp.grasp import files
from exactgrasp.hands import geoms
from exactgrasp.version import __version__


def test_rooms_digest_covers_python_and_cython_sources(tmp_path, monkeypatch):
    root = Path(cache.__file__).parent
    assert cache.CODE_ROOMS == ("geometry",)
    assert (root / "geometry/_winding.pyx").is_file()
    assert (root / "geometry/_predicates.pxd").is_file()
    original = digest = cache.rooms_digest()
    assert len(digest) == 64 and digest == cache.rooms_digest()
    # A copy of the package digests the same; with a module, a Cython kernel or its inline
    # part edited, not; with a source outside the rooms edited, the same.
    copy = tmp_path / "exactgrasp"
    shutil.copytree(root, copy, ignore=shutil.ignore_patterns("__pycache__", "*.so"))
    monkeypatch.setattr(cache, "__file__", str(copy / "cache.py"))
    cache.rooms_digest.cache_clear()
    try:
        assert cache.rooms_digest() == digest
        for edited in ("geometry/shells.py", "geometry/_winding.pyx", "geometry/_predicates.pxd"):
            (copy / edited).write_text((copy / edited).read_text() + "\n# edited\n")
            cache.rooms_digest.cache_clear()
            assert cache.rooms_digest() != digest
            digest = cache.rooms_digest()
        (copy / "descriptor.py").write_text("# edited\n")
        cache.rooms_digest.cache_clear()
        assert cache.rooms_digest() == digest
    finally:
        monkeypatch.undo()
        cache.rooms_digest.cache_clear()
    assert cache.rooms_digest() == original


def test_disk_caches_are_keyed_on_the_version_and_the_code_that_fills_them(tmp_path):
    module = tmp_path / "reader.py"
    module.write_text("x = 1\n")
    before = cache.code_digest(module)
    assert before.split("/")[0] == cache.rooms_digest()
    module.write_text("x = 2\n")
    assert cache.code_digest(module) != before
    # The objects' and the link meshes' caches: each the version, the geometry's sources and
    # its own module.
    for disk, source in ((files.OBJECT_SOLIDS, files.__file__), (geoms.WELDED, geoms.__file__)):
        assert disk.version == f"{__version__}/{cache.code_digest(source)}"
        assert len(disk.version.split("/")) == 3
    assert files.OBJECT_SOLIDS.kind != geoms.WELDED.kind
