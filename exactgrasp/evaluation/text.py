"""The Markdown of the report "What the descriptor tells you", from its summary.

May import: nothing of exactgrasp (it formats the summary dict of
`exactgrasp.evaluation.run.build_report`).
"""

from __future__ import annotations

from typing import Any

__all__ = ["report_markdown"]


def report_markdown(summary: dict[str, Any]) -> str:
    """The report as Markdown text."""
    return "# What the descriptor tells you\n\n(placeholder)\n"
