"""The ``gshade`` command line.

Exit statuses: 0 success, 2 bad input (one line on stderr naming the file, the key or line,
what was expected and what was found; never a traceback).
"""

from __future__ import annotations

import argparse
import sys

from . import __version__
from .errors import GshadeError

__all__ = ["main"]


def build_parser() -> argparse.ArgumentParser:
    parser = argparse.ArgumentParser(
        prog="gshade",
        description="Render the shape quality of parametric surfaces (Kiciak's shape functions).",
    )
    parser.add_argument("--version", action="version", version=f"gshade {__version__}")
    sub = parser.add_subparsers(dest="command", metavar="COMMAND")
    shapes = sub.add_parser("shapes", help="list the shape functions, their order and parameters")
    shapes.set_defaults(run=_shapes)
    return parser


def _shapes(args: argparse.Namespace) -> int:
    from .shape import SHAPE_FUNCTIONS

    for fn in SHAPE_FUNCTIONS.values():
        flags = ", eye-dependent" if fn.eye_dependent else ""
        print(f"{fn.name}  (order {fn.order}{flags})")
        print(f"    {fn.summary}")
        for name, p in fn.parameters.items():
            default = p.default if p.kind != "choice" else f"{p.default} ({'|'.join(p.choices)})"
            print(f"    {name} = {default}: {p.help}")
    return 0


def main(argv: list[str] | None = None) -> int:
    parser = build_parser()
    args = parser.parse_args(argv)
    if args.command is None:
        parser.print_help()
        return 0
    try:
        return args.run(args)
    except GshadeError as exc:
        print(f"gshade: error: {exc}", file=sys.stderr)
        return 2


if __name__ == "__main__":  # pragma: no cover
    sys.exit(main())
