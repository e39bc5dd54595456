"""The documentation builds as a site with `mkdocs build --strict` and links what it promises."""

from __future__ import annotations

import subprocess
import sys
from pathlib import Path

import pytest

ROOT = Path(__file__).resolve().parents[1]


def test_mkdocs_strict_build(tmp_path):
    pytest.importorskip("mkdocs", reason="mkdocs is in the 'docs' and 'dev' extras")
    pytest.importorskip("mkdocstrings", reason="mkdocstrings is in the 'docs' and 'dev' extras")
    result = subprocess.run(
        [sys.executable, "-m", "mkdocs", "build", "--strict", "--site-dir", str(tmp_path)],
        cwd=ROOT,
        capture_output=True,
        text=True,
    )
    assert result.returncode == 0, result.stderr[-3000:]
    assert (tmp_path / "validation" / "index.html").is_file()
    assert (tmp_path / "reports" / "index.html").is_file()
    # The API reference holds the docstrings themselves: headings, signatures, parameters.
    api = (tmp_path / "api" / "index.html").read_text()
    for name in ("exactgrasp.descriptor.compute_descriptor", "exactgrasp.grasp.grasp.Grasp",
                 "exactgrasp.hands.hand.Hand", "exactgrasp.batch.run.run_batch"):  # fmt: skip
        assert f'id="{name}"' in api, name
    assert "Anything <code>exactgrasp.paths.as_sampler</code> takes" in api


def test_docs_index_links_every_page():
    index = (ROOT / "docs" / "index.md").read_text()
    pages = sorted(p.name for p in (ROOT / "docs").glob("*.md") if p.name != "index.md")
    missing = [p for p in pages if f"({p})" not in index]
    assert not missing, f"docs/index.md does not link {missing}"
