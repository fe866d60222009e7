"""`nutty filter IN.csv OUT.csv [...]`: run the Nutty Motion Filter over set-points in a CSV file.

IN has a header `t,<name>,…` and set-points at any (sorted) times. OUT has
`t,<name>,<name>.vel,<name>.acc,<name>.jerk` per name, sampled at `t0 + k/rate` from the first input
time to the last (inclusive), each sample using the latest input at or before it.
"""

from __future__ import annotations

import csv
import math
from pathlib import Path
from typing import Any

import numpy as np

from backend.commands._common import fail


def register(sub) -> None:
    p = sub.add_parser(
        "filter",
        help="filter set-points from a CSV with the Nutty Motion Filter",
        description="Filter stepped set-points (CSV: t,<name>,...) into motor-safe motion with the NMF. "
        "IN: a header 't,<name>,...', rows sorted by t (s), at any times; an empty cell means "
        "'no new set-point for that DoF' (the latest one is held). OUT: "
        "t,<name>,<name>.vel,<name>.acc,<name>.jerk sampled at t0 + k/rate up to the last input "
        "time, each sample using the latest set-point at or before it. Without --preset the "
        "filter is preset W (regular: H bypassed, V/A/J 20/100/10000) unless --sigma or --rho "
        "is given, which switches H on; explicit values override the preset's.",
    )
    p.add_argument("input", help="input CSV: header t,<name>,...; rows sorted by t (s)")
    p.add_argument("output", help="output CSV")
    p.add_argument(
        "--preset", default=None, help="W (regular), A, B, C, D or E (the paper's table; default W)"
    )
    p.add_argument(
        "--order",
        type=int,
        default=3,
        choices=(1, 2, 3),
        help="continuity order: 1 velocity, 2 acceleration, 3 jerk limited (default 3)",
    )
    p.add_argument("--limiter", default="tanh", choices=("tanh", "hard"), help="limiter (default tanh)")
    p.add_argument("--rate", type=float, default=60.0, help="output rate in Hz (default 60)")
    p.add_argument("--sigma", type=float, help="smoothness σ in [0, 1] (switches H on)")
    p.add_argument("--rho", type=float, help="responsiveness ρ in [0, 1] (switches H on)")
    p.add_argument("--vel", type=float, help="velocity limit V (units/s; the tanh limiter stays below V/2)")
    p.add_argument("--acc", type=float, help="acceleration limit A (units/s²)")
    p.add_argument("--jerk", type=float, help="jerk limit J (units/s³)")
    p.add_argument("--pmin", type=float, help="lower position limit (with --pmax)")
    p.add_argument("--pmax", type=float, help="upper position limit (with --pmin)")
    p.add_argument("--beta", type=float, default=5.0, help="position-saturation exponent β >= 1 (default 5)")
    p.add_argument("--bypass", action="store_true", help="bypass H (the regular filter W's behaviour)")
    p.set_defaults(func=run)


def read_setpoints(path: Path) -> tuple[list[str], np.ndarray, np.ndarray]:
    """(names, times (K,), values (K, n)) from a set-point CSV; empty cells are NaN ("hold").

    ValueError messages name the file, the row (the header is row 1) and the column."""
    with path.open(newline="") as fh:
        rows = list(csv.reader(fh))
    if not rows:
        raise ValueError(f"{path}: empty file")
    header = [h.strip() for h in rows[0]]
    if len(header) < 2 or header[0] != "t" or not all(header[1:]):
        raise ValueError(
            f"{path}: header must be 't,<name>,...' with non-empty names, got {','.join(header)!r}"
        )
    names = header[1:]
    repeated = sorted({nm for nm in names if names.count(nm) > 1})
    if repeated:
        raise ValueError(f"{path}: repeated column names in header: {', '.join(repeated)}")
    data, row_numbers = [], []
    for r, row in enumerate(rows[1:], start=2):
        if not row or all(not c.strip() for c in row):
            continue
        if len(row) != len(header):
            raise ValueError(f"{path}: row {r} has {len(row)} cells, the header has {len(header)}")
        vals = []
        for c, cell in enumerate(row):
            if c > 0 and not cell.strip():
                vals.append(math.nan)  # no new set-point for this DoF in this row
                continue
            try:
                v = float(cell)
            except ValueError:
                raise ValueError(f"{path}: row {r}, column '{header[c]}': not a number: {cell!r}") from None
            if not math.isfinite(v):
                raise ValueError(f"{path}: row {r}, column '{header[c]}': value must be finite, got {cell!r}")
            vals.append(v)
        data.append(vals)
        row_numbers.append(r)
    if not data:
        raise ValueError(f"{path}: no set-points after the header")
    arr = np.array(data)
    t = arr[:, 0]
    back = np.flatnonzero(np.diff(t) < 0)
    if back.size:
        k = int(back[0]) + 1
        raise ValueError(
            f"{path}: rows must be sorted by t; row {row_numbers[k]} (t={t[k]:g}) goes back in time"
        )
    return names, t, arr[:, 1:]


MAX_SAMPLES = 1e8  # output rows (a guard against a typo in --rate or in a time column)
# Inputs this close to a sample time (in samples) count as at it: times written as decimals round.
_SAMPLE_TOL = 1e-6


def resample_latest(t: np.ndarray, values: np.ndarray, rate: float) -> tuple[np.ndarray, np.ndarray]:
    """Samples at t0 + k/rate, k = 0..floor((t_last - t0) rate), each the latest set-point per DoF at
    or before it (NaN cells are skipped: the DoF keeps its previous set-point; NaN before its first)."""
    filled = values.copy()
    for j in range(filled.shape[1]):  # forward-fill each column (vectorised along time)
        col = filled[:, j]
        have = ~np.isnan(col)
        last = np.maximum.accumulate(np.where(have, np.arange(col.size), -1))
        filled[:, j] = np.where(last >= 0, col[np.maximum(last, 0)], np.nan)
    count = math.floor((t[-1] - t[0]) * rate + _SAMPLE_TOL) + 1
    ts = t[0] + np.arange(count) / rate
    idx = np.searchsorted(t, ts + _SAMPLE_TOL / rate, side="right") - 1
    return ts, filled[np.clip(idx, 0, len(t) - 1)]


def run(args) -> int:
    from backend.engine.nmf import RATE_MAX, RATE_MIN, MotionFilter, preset  # lazy: a fast `nutty --help`

    if not RATE_MIN <= args.rate <= RATE_MAX:
        return fail(f"--rate must be a number of Hz in [{RATE_MIN:g}, {RATE_MAX:g}], got {args.rate}")
    try:
        names, t, values = read_setpoints(Path(args.input))
    except OSError as exc:
        return fail(f"cannot read '{args.input}': {exc.strerror}")
    except ValueError as exc:  # also a file that is not text (UnicodeDecodeError)
        return fail(str(exc))
    samples = (t[-1] - t[0]) * args.rate
    if samples > MAX_SAMPLES:
        return fail(
            f"{args.input} spans {t[-1] - t[0]:g} s: {samples:.3g} samples at {args.rate:g} Hz "
            f"(at most {MAX_SAMPLES:g}); lower --rate"
        )
    ts, sps = resample_latest(t, values, args.rate)
    try:
        base = preset(args.preset or "W")
    except ValueError as exc:
        return fail(str(exc))
    # σ or ρ given explicitly means "shape with H": it would otherwise be silently ignored under W.
    wants_h = args.sigma is not None or args.rho is not None
    kw: dict[str, Any] = dict(
        sigma=base.sigma,
        rho=base.rho,
        vel_limit=base.vel_limit,
        acc_limit=base.acc_limit,
        jerk_limit=base.jerk_limit,
        bypass=args.bypass or (base.bypass and not wants_h),
    )
    for opt, key in (
        ("sigma", "sigma"),
        ("rho", "rho"),
        ("vel", "vel_limit"),
        ("acc", "acc_limit"),
        ("jerk", "jerk_limit"),
    ):
        if getattr(args, opt) is not None:
            kw[key] = getattr(args, opt)
    try:
        f = MotionFilter(
            len(names),
            args.rate,
            order=args.order,
            limiter=args.limiter,
            pmin=args.pmin,
            pmax=args.pmax,
            beta=args.beta,
            **kw,
        )
    except ValueError as exc:
        return fail(str(exc))
    res = f.run(sps)
    header = ["t"]
    for nm in names:
        header += [nm, f"{nm}.vel", f"{nm}.acc", f"{nm}.jerk"]
    out = np.empty((len(ts), 1 + 4 * len(names)))
    out[:, 0] = ts
    out[:, 1::4], out[:, 2::4], out[:, 3::4], out[:, 4::4] = (
        res.position,
        res.velocity,
        res.acceleration,
        res.jerk,
    )
    try:
        with open(args.output, "w", newline="") as fh:
            w = csv.writer(fh)
            w.writerow(header)
            w.writerows([list(map(repr, row)) for row in out.tolist()])  # shortest exact decimals
    except OSError as exc:
        return fail(f"cannot write '{args.output}': {exc.strerror}")
    return 0
