"""Run the validation report from a checkout: ``python validation/run.py --data D --out O``.

The same as ``exactgrasp validate`` (the report code lives in the installed package,
``exactgrasp/validation/``, so the command works without a checkout); this script only makes
the package importable from the checkout when it is not installed.
"""

from __future__ import annotations

import sys
from pathlib import Path

if __name__ == "__main__":
    try:
        import exactgrasp  # noqa: F401
    except ImportError:
        sys.path.insert(0, str(Path(__file__).resolve().parents[1]))
    from exactgrasp.cli import main

    sys.exit(main(["validate", *sys.argv[1:]]))
