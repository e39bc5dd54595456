"""What the benchmarks on the shared data folder have in common: its ``--data`` and ``--json``
options, and the skip, with a message, when the folder is absent."""

from __future__ import annotations

import argparse
from pathlib import Path

from exactgrasp.datapath import data_dir


def add_data_options(ap: argparse.ArgumentParser) -> None:
    """``--data`` (the shared data folder) and ``--json`` (a file for the figures)."""
    ap.add_argument("--data", type=Path, default=None, help="the shared data folder")
    ap.add_argument("--json", type=Path, help="also write the figures to this JSON file")


def data_or_skip(args: argparse.Namespace, needed: str) -> Path | None:
    """The shared data folder (``--data``, else `exactgrasp.datapath.data_dir`), or None,
    after saying so, when the file ``needed`` (relative to it) is not there."""
    data = args.data or data_dir()
    if not (data / needed).is_file():
        print(f"skipped: {needed} not found under {data.resolve()} (set EXACTGRASP_DATA)")
        return None
    return data
