"""A campaign's output directory: its manifest and its results as Parquet, resumable.

::

    DIR/campaign.json          the campaign and its runs (ids, axes), written before any run
    DIR/runs/part-*.parquet    one row per finished run (sim.campaign.rows), appended as runs
                               complete: each part is written to a temporary file and renamed,
                               so a part on disk is always whole, whatever stops the writer
    DIR/report.md, DIR/figures/  the report (ftc-campaign report)

Rows go to disk at most ``flush_s`` after a run finishes (at once for the first), and when the
campaign ends or is interrupted; at the end of a run of the command the parts written with
the current columns are merged into one. A run id appears once in the results: when parts
disagree (a run flown again with ``--retry-errors``), the later part wins. Read everything
back with :func:`read_rows`, or with any Parquet reader
(``pyarrow.parquet.read_table(DIR/runs)``, ``pandas.read_parquet``).

One ``ftc-campaign run`` writes to a directory at a time (a lock file, ``DIR/.lock``).
"""

from __future__ import annotations

import fcntl
import json
import math
import os
import time
from collections.abc import Iterable, Mapping, Sequence
from pathlib import Path
from typing import IO, Any

import pyarrow as pa
import pyarrow.parquet as pq

from flightdata.config import ConfigError
from sim.campaign.expand import RunSpec
from sim.campaign.spec import Campaign

MANIFEST = "campaign.json"
RUNS_DIR = "runs"
LOCK_FILE = ".lock"
FLUSH_S = 2.0  # s of wall clock at most between a run's end and its row on disk
_ARROW_TYPES = {str: pa.string(), int: pa.int64(), float: pa.float64()}


def arrow_schema(columns: Sequence[tuple[str, type]]) -> pa.Schema:
    """The Parquet schema of rows with ``columns`` (:func:`sim.campaign.rows.columns`)."""
    return pa.schema([(name, _ARROW_TYPES[kind]) for name, kind in columns])


def write_manifest(out_dir: Path, campaign: Campaign, runs: Sequence[RunSpec],
                   n_faults: int) -> None:
    """Write ``DIR/campaign.json``: the campaign and every run's id and axes."""
    out_dir.mkdir(parents=True, exist_ok=True)
    data = {
        "campaign": campaign.name, "description": campaign.description,
        "source": campaign.source, "scenario": campaign.scenario,
        "base_faults": campaign.base_faults, "swept": list(campaign.swept),
        "metrics": list(campaign.metrics), "n_faults": n_faults,
        "runs": [{"run_id": r.run_id, "index": r.index, "own_fault": r.own_fault, **r.axes}
                 for r in runs],
    }
    tmp = out_dir / (MANIFEST + ".tmp")
    tmp.write_text(json.dumps(data, indent=1) + "\n")
    os.replace(tmp, out_dir / MANIFEST)


def read_manifest(out_dir: Path) -> dict[str, Any]:
    """``DIR/campaign.json`` as written by :func:`write_manifest`.

    Raises
    ------
    ConfigError
        No campaign was run into ``out_dir``, or the file is damaged.
    """
    path = out_dir / MANIFEST
    try:
        data: dict[str, Any] = json.loads(path.read_text())
    except (FileNotFoundError, NotADirectoryError):
        raise ConfigError(f"{out_dir}: holds no campaign ({MANIFEST} is missing); "
                          "run one there first with ftc-campaign run CAMPAIGN --out "
                          f"{out_dir}") from None
    except (json.JSONDecodeError, UnicodeDecodeError) as exc:
        raise ConfigError(f"{path}: not a campaign manifest ({exc})") from None
    return data


def _parts(out_dir: Path) -> list[Path]:
    return sorted((out_dir / RUNS_DIR).glob("part-*.parquet"))


def read_rows(out_dir: Path) -> list[dict[str, Any]]:
    """Every row in ``DIR/runs``, one per run id (the latest part wins), by ``index``."""
    rows: dict[str, dict[str, Any]] = {}
    for part in _parts(out_dir):
        for row in pq.read_table(part).to_pylist():
            rows[row["run_id"]] = row
    return sorted(rows.values(), key=lambda r: (r.get("index", 0), r["run_id"]))


def finished_runs(out_dir: Path, *, retry_errors: bool = False,
                  required: Sequence[str] = ()) -> set[str]:
    """Ids of the runs with a row holding every ``required`` column (a row written before
    the campaign kept more metrics does not count), without the failed ones when
    ``retry_errors``."""
    return {r["run_id"] for r in read_rows(out_dir)
            if all(c in r for c in required)
            and not (retry_errors and r.get("status") == "error")}


class ResultStore:
    """Appends rows to ``DIR/runs`` as Parquet parts (module docstring).

    Use as a context manager: entering takes the directory's lock, leaving writes what is
    pending, merges the parts of this schema and releases the lock.

    Parameters
    ----------
    out_dir : Path
        The campaign's output directory.
    columns : sequence of (name, type)
        The columns of every row (:func:`sim.campaign.rows.columns`).
    flush_s : float
        Wall-clock seconds at most between a row's arrival and its part on disk.
    """

    def __init__(self, out_dir: Path, columns: Sequence[tuple[str, type]],
                 flush_s: float = FLUSH_S) -> None:
        self.out_dir = out_dir
        self.schema = arrow_schema(columns)
        self.flush_s = flush_s
        self.written = 0  # rows on disk from this store
        self._pending: list[dict[str, Any]] = []
        self._last_flush = -math.inf
        self._lock: IO[str] | None = None

    def __enter__(self) -> ResultStore:
        try:
            (self.out_dir / RUNS_DIR).mkdir(parents=True, exist_ok=True)
            lock = (self.out_dir / LOCK_FILE).open("w")
        except OSError as exc:
            raise ConfigError(f"{self.out_dir}: cannot hold results ({exc.strerror}); "
                              "--out must be a directory this user can write") from None
        try:
            fcntl.flock(lock, fcntl.LOCK_EX | fcntl.LOCK_NB)
        except OSError:
            lock.close()
            raise ConfigError(f"{self.out_dir}: another ftc-campaign run is writing there; "
                              "wait for it to end or choose another --out") from None
        self._lock = lock
        return self

    def __exit__(self, *exc: object) -> None:
        try:
            self.flush()
            self.compact()
        finally:
            if self._lock is not None:
                self._lock.close()  # closing the file releases the lock
                self._lock = None

    def add(self, row: Mapping[str, Any]) -> None:
        """Queue one row; write the queue when ``flush_s`` has passed since the last write."""
        self._pending.append({name: row.get(name) for name in self.schema.names})
        if time.monotonic() - self._last_flush >= self.flush_s:
            self.flush()

    def flush(self) -> None:
        """Write the queued rows as one part (nothing when none is queued)."""
        if self._pending:
            self._write(self._pending)
            self.written += len(self._pending)
            self._pending = []
        self._last_flush = time.monotonic()

    def _write(self, rows: Iterable[Mapping[str, Any]]) -> Path:
        name = f"part-{time.time_ns():020d}-{os.getpid()}.parquet"
        path = self.out_dir / RUNS_DIR / name
        tmp = path.with_name(f".{name}.tmp")  # hidden: Parquet readers skip dot files
        pq.write_table(pa.Table.from_pylist(list(rows), schema=self.schema), tmp)
        os.replace(tmp, path)
        return path

    def compact(self) -> None:
        """Merge the parts written with this store's columns into one (later rows win)."""
        same = [p for p in _parts(self.out_dir) if pq.read_schema(p).equals(self.schema)]
        if len(same) < 2:
            return
        rows: dict[str, dict[str, Any]] = {}
        for part in same:
            for row in pq.read_table(part).to_pylist():
                rows[row["run_id"]] = row
        self._write(sorted(rows.values(), key=lambda r: r["index"]))
        for part in same:
            part.unlink()
