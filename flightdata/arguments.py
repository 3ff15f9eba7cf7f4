"""Command-line pieces shared by the project's tools: argparse ``type=`` functions and the
run of a chosen sub-command."""

from __future__ import annotations

import argparse
import math
import sys

from flightdata.config import ConfigError

__all__ = ["EXIT_INTERRUPTED", "EXIT_USAGE", "positive_float", "run_subcommand"]

EXIT_USAGE = 2  # bad flags or input: the status argparse itself exits with
EXIT_INTERRUPTED = 130  # 128 + SIGINT, what a shell reports after Ctrl-C


def positive_float(text: str) -> float:
    """A finite number > 0, refused by argparse in one line otherwise."""
    try:
        value = float(text)
    except ValueError:
        raise argparse.ArgumentTypeError(f"{text!r} is not a number") from None
    if not (math.isfinite(value) and value > 0):
        raise argparse.ArgumentTypeError(f"{text!r}: must be a finite number > 0")
    return value


def run_subcommand(prog: str, args: argparse.Namespace) -> int:
    """Run the sub-command argparse chose (``args.func(args)``) and return its exit status.

    A bad value (:class:`~flightdata.config.ConfigError`) is one line ``"<prog>: <why>"`` on
    stderr and :data:`EXIT_USAGE`; Ctrl-C is ``"<prog>: interrupted"`` and
    :data:`EXIT_INTERRUPTED`, without a traceback.
    """
    try:
        return int(args.func(args))
    except ConfigError as exc:
        print(f"{prog}: {exc}", file=sys.stderr)
        return EXIT_USAGE
    except KeyboardInterrupt:
        print(f"{prog}: interrupted", file=sys.stderr)
        return EXIT_INTERRUPTED
