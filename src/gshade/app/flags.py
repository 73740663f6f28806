"""The command line's words for the library's parameters.

The library's errors name its parameters (``samples: expected 1 to 4096, got 0``,
``scene.toml: override shape.x: unknown key ...``); the command line speaks of the flags
that set them (``--samples``, ``--set``).  :func:`in_flags` turns the one into the other.
"""

from __future__ import annotations

__all__ = ["FLAGS", "MENTIONS", "in_flags", "parameter"]

#: Library parameters, as an error begins with them, and the flags that set them.
FLAGS = {
    # load_scene(overrides=...), parse_overrides: "override KEY: ..."
    "override": "--set",
    # parse_sweeps: "sweep 'KEY=V1,V2': ..."
    "sweep": "--sweep",
    # continuity_report, Tolerances
    "samples": "--samples",
    "pairs": "--pair",
    **{f"tolerance {order}": f"--tol-{order}" for order in ("g0", "g1", "g2", "g3")},
    # run_batch, validate_batch_options
    "workers": "-j",
    "timeout": "--timeout",
    "scheduler": "--scheduler",
    # Thresholds, compare, compare_and_write_diffs
    **{name: f"--{name}" for name in ("fail", "failpercent", "hardfail", "warn", "warnpercent")},
    "channels": "--channels",
    "diff and diff_png": "--diff and --diff-png",
}
#: Parameters that messages mention further on (``run with update=True to create it``),
#: and the flags.
MENTIONS = {"update=True to create it": "--update to create it"}


def parameter(message: str) -> str | None:
    """The parameter in :data:`FLAGS` that a library error begins with, or None."""
    for name in FLAGS:
        if message.startswith((f"{name}:", f"{name} ")):
            return name
    return None


def in_flags(message: str, where: str = "") -> str:
    """A library error in the command line's words.

    Parameters
    ----------
    message : str
        The error's message.
    where : str
        The file the command read (``scene.toml``): a message beginning with it has the
        parameter after it (``scene.toml: override shape.x: ...``).

    Returns
    -------
    str
        The message with the parameter it begins with (after ``where: ``) and those it
        mentions (:data:`MENTIONS`) spelt as flags.
    """
    head = f"{where}: " if where and message.startswith(f"{where}: ") else ""
    rest = message[len(head) :]
    name = parameter(rest)
    if name is not None:
        rest = FLAGS[name] + rest[len(name) :]
    for mention, flag in MENTIONS.items():
        rest = rest.replace(mention, flag)
    return head + rest
