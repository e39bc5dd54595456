"""``exactgrasp show GRASP.json``: an interactive HTML page (and a PNG) of a grasp and its paths.

The command-line face of `exactgrasp.view.show`; see ``docs/viewing.md``.
"""

from __future__ import annotations

import argparse
from typing import Any

from exactgrasp.cli.common import add_command, add_grasp_inputs, sampler_and_grasp

__all__ = ["add_parser", "cmd_show"]


#: The command's line in ``exactgrasp --help``.
HELP = "an interactive HTML page (and a PNG) of a grasp and its sampled paths"
#: Its ``--help`` description, and the example that follows it.
DESCRIPTION = (
    "Draw the hand links, the object at the grasp pose, the canonical frame's axes "
    "and a spread of the sampler's paths (the object's centre, coloured by time) "
    "into one self-contained HTML page that needs no network to open."
)
EXAMPLE = "exactgrasp show box.json -o box.html --png box.png"


def cmd_show(args: argparse.Namespace) -> int:
    """Handler of ``exactgrasp show``; prints what it wrote, returns 0."""
    from exactgrasp.view.scene import choose_paths
    from exactgrasp.view.write import show

    # --paths checked here first so that the message names the flag, not the Python argument.
    sampler, grasp = sampler_and_grasp(
        args, check=lambda sampler: choose_paths(sampler, args.paths, name="--paths")
    )
    shown = show(
        grasp, sampler, n_paths=args.paths, path=args.output, png=args.png, open_browser=args.open
    )
    written = ", ".join(str(p) for p in (shown.html, shown.png) if p is not None)
    print(
        f"{grasp.name}: {len(shown.scene.paths)} of {shown.scene.n_sampler_paths} paths, "
        f"{sampler.n_steps} steps each -> {written}"
    )
    return 0


def add_parser(subparsers: Any) -> argparse.ArgumentParser:
    """Add the ``show`` sub-command to the ``exactgrasp`` command's subparsers."""
    parser = add_command(subparsers, "show", cmd_show, HELP, DESCRIPTION, EXAMPLE)
    parser.add_argument("grasp", metavar="GRASP", help="grasp JSON file")
    parser.add_argument(
        "-o", "--output", default="grasp.html", help="HTML page to write (default grasp.html)"
    )
    parser.add_argument("--png", default=None, help="also write a static PNG picture")
    parser.add_argument(
        "--paths",
        type=int,
        default=24,
        metavar="N",
        help="how many sampled paths to draw, spread evenly (default 24)",
    )
    add_grasp_inputs(parser)
    parser.add_argument("--open", action="store_true", help="open the page in a web browser")
    return parser
