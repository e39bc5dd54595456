"""The ``exactgrasp`` command, one module per sub-command."""

from exactgrasp.cli.main import build_parser, main

__all__ = ["build_parser", "main"]
