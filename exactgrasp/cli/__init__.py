"""The ``exactgrasp`` command, one module per sub-command (see `exactgrasp.cli.main`).

``main`` is the console script ``exactgrasp.cli:main``; ``python -m exactgrasp.cli`` runs it
too (`exactgrasp.cli.__main__`).
"""

from exactgrasp.cli.main import build_parser, main

__all__ = ["build_parser", "main"]
