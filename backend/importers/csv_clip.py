"""CSV keyframes -> channels.

Header `time,<dof>,<dof>,...` (the first column may also be called `t`); one row per key time in
seconds, values in rad or m, or an option name for enum DoFs; an empty cell means "no key for that
column at this time". Every column becomes one scalar channel. A cell that reads as a number but is
not finite (nan, inf) is an error naming the line, the time and the column; with `fill` it counts
as an empty cell (no key there: the keys around it interpolate).
"""

from __future__ import annotations

import csv
import math
from pathlib import Path
from typing import Any

import numpy as np

from backend.importers.mapping import ClipImportError, SourceChannel
from backend.importers.sources import Importer, ReadOptions


class CsvImporter(Importer):
    """CSV keys: a `time` column, then one column per DoF (values in the DoF's own units)."""

    name = "csv"
    label = "CSV"
    suffixes = (".csv",)
    options = frozenset({"interp"})
    axes = False  # columns are DoF values, not rotations in space

    @classmethod
    def read(cls, path: Path, options: ReadOptions) -> tuple[list[SourceChannel], dict[str, Any], list[str]]:
        return read_csv(path, fill=options.fill)


def read_csv(path: str | Path, fill: str | None = None) -> tuple[list[SourceChannel], dict, list[str]]:
    path = Path(path)
    try:
        with path.open(newline="") as fh:
            rows = [r for r in csv.reader(fh) if r and any(c.strip() for c in r)]
    except (OSError, UnicodeDecodeError) as exc:
        raise ClipImportError(f"cannot read CSV file '{path}': {exc}") from exc
    rows = [r for r in rows if not r[0].lstrip().startswith("#")]
    if not rows:
        raise ClipImportError(f"CSV '{path.name}' is empty")
    header = [h.strip() for h in rows[0]]
    if header[0].lower() not in ("time", "t"):
        raise ClipImportError(f"CSV '{path.name}': the first column must be 'time' (s), got '{header[0]}'")
    if len(header) < 2:
        raise ClipImportError(f"CSV '{path.name}': no value columns after 'time'")
    if len(set(header)) != len(header):
        raise ClipImportError(f"CSV '{path.name}': duplicate column names in {header}")
    times: list[float] = []
    filled: dict[str, int] = {}
    cols: list[list[tuple[float, float | str]]] = [[] for _ in header[1:]]
    for line, row in enumerate(rows[1:], start=2):
        if len(row) > len(header):
            raise ClipImportError(
                f"CSV '{path.name}' line {line}: {len(row)} cells, header has {len(header)}"
            )
        try:
            t = float(row[0])
        except ValueError:
            raise ClipImportError(f"CSV '{path.name}' line {line}: time '{row[0]}' is not a number") from None
        if not math.isfinite(t) or t < 0:
            raise ClipImportError(f"CSV '{path.name}' line {line}: time must be a finite number >= 0")
        if times and t <= times[-1]:
            raise ClipImportError(
                f"CSV '{path.name}' line {line}: times must increase ({times[-1]} then {t})"
            )
        times.append(t)
        for c, cell in enumerate(row[1:]):
            cell = cell.strip()
            if not cell:
                continue
            try:
                v: float | str = float(cell)
            except ValueError:
                v = cell
            if isinstance(v, float) and not math.isfinite(v):
                if fill is None:
                    raise ClipImportError(
                        f"CSV '{path.name}' line {line} (t = {t:g} s): {header[c + 1]} is "
                        f"'{cell}', not a finite number\n  --fill hold or --fill linear skips such "
                        "cells (the keys around them interpolate)"
                    )
                filled[header[c + 1]] = filled.get(header[c + 1], 0) + 1
                continue
            cols[c].append((t, v))
    channels = []
    for name, keys in zip(header[1:], cols):
        if not keys:
            continue
        ts = np.array([k[0] for k in keys])
        vals = [k[1] for k in keys]
        if all(isinstance(v, float) for v in vals):
            vals = np.array(vals, dtype=float)
        channels.append(SourceChannel(name, "scalar", ts, vals, "LINEAR", unit="row"))
    notes = []
    if filled:
        per = ", ".join(f"{k} {v}" for k, v in filled.items())
        notes.append(f"--fill {fill}: skipped {sum(filled.values())} non-finite cell(s) ({per})")
    return channels, {"rows": len(times)}, notes
