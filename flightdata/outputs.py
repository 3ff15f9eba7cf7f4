"""Checking, before any work, that the files and folders a command will write can be written.

A run that ends in a traceback because its figures folder cannot be created wastes the run;
the command-line tools call these first, so a bad output path is one line naming the option,
the path and why, before anything is flown. The rule, the same for every output of every
tool: missing folders are created (a file's folder, or the folder itself for ``--figures``,
``--report``, ``--out-dir``...), an existing file is replaced when written, and whatever
cannot be created or written (a read-only place, ``/proc``, a file where a folder is needed)
is refused.

The checks leave nothing behind: a probe file is created and removed, and a missing folder is
judged by creating and removing a uniquely named folder where it would go (the command creates
the real one when it writes).
"""

from __future__ import annotations

import tempfile
from collections.abc import Callable
from pathlib import Path

from flightdata.config import ConfigError

__all__ = ["OutputError", "check_file_output", "check_folder_output"]


class OutputError(ConfigError):
    """An output path that cannot be written; the message names the option and the path."""


def _reason(err: OSError) -> str:
    return err.strerror or type(err).__name__


def check_file_output(option: str, path: str | Path) -> Path:
    """Check that the file ``path`` (given with ``option``) can be written.

    Parameters
    ----------
    option : str
        The command-line option, for the message (e.g. ``"--json"``).
    path : str or Path
        The file; its folder may be missing (it is created when the file is written).

    Returns
    -------
    Path
        ``path``.

    Raises
    ------
    OutputError
        ``"<option> <path>: <why>"``: a folder, a place that cannot be written...
    """
    p = Path(path)
    if p.is_dir():
        raise OutputError(f"{option} {p}: is a folder, not a file")
    if p.exists():
        try:
            with open(p, "ab"):
                pass  # opened for writing, nothing changed
        except OSError as err:
            raise OutputError(f"{option} {p}: cannot write: {_reason(err)}") from None
        return p

    def probe(folder: Path) -> None:
        with open(folder / p.name, "xb"):
            pass
        (folder / p.name).unlink()

    _in_folder(p.parent, probe, f"{option} {p}: cannot write")
    return p


def check_folder_output(option: str, path: str | Path) -> Path:
    """:func:`check_file_output` for a folder given with ``option`` (e.g. ``"--figures"``):
    files can be written in ``path`` (created later if missing); returns ``path``, or raises
    OutputError ``"<option> <path>: <why>"`` (a file, a folder that cannot be created or
    written)."""
    p = Path(path)
    if p.exists() and not p.is_dir():
        raise OutputError(f"{option} {p}: is a file, not a folder")
    _in_folder(p, _probe_folder, f"{option} {p}: cannot write there")
    return p


def _probe_folder(folder: Path) -> None:
    with tempfile.TemporaryFile(dir=folder):
        pass


def _in_folder(folder: Path, probe: Callable[[Path], None], failure: str) -> None:
    """Run ``probe(folder)``, or, when ``folder`` is missing, check that a folder can be
    created in its nearest existing ancestor (a uniquely named one, created and removed: two
    commands checking the same missing folder at once cannot trip over each other); an
    OSError becomes ``OutputError(f"{failure}: {why}")``."""
    try:
        if folder.exists():
            probe(folder)
            return
        ancestor = folder.parent
        while not ancestor.exists() and ancestor != ancestor.parent:
            ancestor = ancestor.parent
        Path(tempfile.mkdtemp(dir=ancestor, prefix=".probe-")).rmdir()
    except OSError as err:
        raise OutputError(f"{failure}: {_reason(err)}") from None
