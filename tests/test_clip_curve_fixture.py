"""The clip editor's curve port (frontend/node_editor/clip_editor/model/curve.ts) must draw what the engine
plays. This test owns the shared fixture: ~50 varied curves (every interpolation and easing mode, every
handle type, given aligned/free handles, 1- and 2-key curves, tiny and huge spans) with the values
`CurveSet.evaluate_reference` gives at ~50 times each. The committed JSON must equal what Python
generates now, so a change to backend/engine/curves.py fails here until the fixture is regenerated
(`REGENERATE_CURVE_CASES=1`) — and then the vitest test (curve.test.ts) checks the TypeScript port
against the new values within 1e-9.
"""

from __future__ import annotations

import json
import math
import os
import random
from pathlib import Path
from typing import Any

import numpy as np

from backend.engine.curves import EASINGS, INTERPS, CurveSet, Key

ROOT = Path(__file__).resolve().parents[1]
FIXTURE = ROOT / "frontend" / "node_editor" / "clip_editor" / "model" / "curveCases.json"
SEED = 20260530
HANDLE_TYPES = ("auto", "auto_clamped", "vector", "aligned", "free")
MODES = ("in", "out", "in_out")


def _key(t: float, v: float, **extra: Any) -> dict[str, Any]:
    return {"t": t, "v": v, **extra}


def _to_key(d: dict[str, Any]) -> Key:
    left, right = d.get("left"), d.get("right")
    return Key(
        d["t"],
        d["v"],
        d.get("interp", "bezier"),
        d.get("easing", "in_out"),
        d.get("left_type", "auto_clamped"),
        d.get("right_type", "auto_clamped"),
        tuple(left) if left is not None else None,
        tuple(right) if right is not None else None,
    )


def _random_curve(rng: random.Random, n: int, gap_range: tuple[float, float]) -> list[dict[str, Any]]:
    keys = []
    t = rng.uniform(0.0, 1.0)
    for _ in range(n):
        k = _key(t, rng.uniform(-2.0, 2.0))
        if rng.random() < 0.7:
            k["interp"] = rng.choice(INTERPS)
        if rng.random() < 0.6:
            k["easing"] = rng.choice(MODES)
        for side, sign in (("left", -1.0), ("right", 1.0)):
            if rng.random() < 0.7:
                k[f"{side}_type"] = rng.choice(HANDLE_TYPES)
            if rng.random() < 0.5:  # given offsets, sometimes reaching past the segment (clamped)
                k[side] = [sign * rng.uniform(0.0, 1.5) * gap_range[1], rng.uniform(-3.0, 3.0)]
        keys.append(k)
        lo, hi = gap_range
        t += math.exp(rng.uniform(math.log(lo), math.log(hi)))
    return keys


def _curves(rng: random.Random) -> list[tuple[str, list[dict[str, Any]]]]:
    out: list[tuple[str, list[dict[str, Any]]]] = []
    out.append(("one key", [_key(0.5, 0.3)]))
    out.append(
        (
            "one key, free handles",
            [_key(0.0, -1.0, left_type="free", right_type="free", left=[-1, 2], right=[1, 2])],
        )
    )
    for interp in INTERPS:
        mode = MODES[len(out) % 3]
        out.append(
            (f"two keys {interp} {mode}", [_key(0.25, -0.4, interp=interp, easing=mode), _key(1.4, 0.9)])
        )
    for name in EASINGS:
        keys = [
            _key(0.0, 0.0, interp=name, easing="in"),
            _key(0.6, 1.0, interp=name, easing="out"),
            _key(1.1, -0.5, interp=name, easing="in_out"),
            _key(2.0, 0.2),
        ]
        out.append((f"{name} in/out/in_out", keys))
    zigzag = [(0.0, 0.0), (0.4, 1.0), (0.7, 1.0), (1.0, 0.2), (1.6, 0.5), (2.0, 1.5), (2.2, -0.7)]
    for kind in HANDLE_TYPES:
        out.append((f"zigzag {kind}", [_key(t, v, left_type=kind, right_type=kind) for t, v in zigzag]))
    out.append(
        (
            "aligned given right",
            [
                _key(0.0, 0.0),
                _key(0.5, 1.0, left_type="aligned", right_type="aligned", right=[0.2, -0.3]),
                _key(1.5, 0.0),
            ],
        )
    )
    out.append(
        (
            "aligned given left, free right",
            [
                _key(0.0, 0.0),
                _key(0.5, 1.0, left_type="free", right_type="aligned", left=[-0.1, 0.4], right=[0.3, 0.0]),
                _key(1.5, 0.0),
            ],
        )
    )
    out.append(
        (
            "aligned zero-length given",
            [
                _key(0.0, 0.0, right_type="aligned", left_type="aligned", right=[0.0, 0.0], left=[-0.2, 0.1]),
                _key(
                    1.0, 1.0, left_type="aligned", right_type="aligned", left=[-0.3, -0.2], right=[0.0, 0.0]
                ),
                _key(2.0, 0.0),
            ],
        )
    )
    out.append(
        (
            "free handles past the segment",
            [
                _key(0.0, 0.0, right_type="free", right=[3.0, 2.0]),
                _key(1.0, 1.0, left_type="free", left=[-5.0, -1.0], right_type="free", right=[-0.2, 0.5]),
                _key(2.0, 0.5, left_type="free", left=[0.4, 0.4]),
            ],
        )
    )
    out.append(
        (
            "anticipation dip",
            [
                _key(0.0, 0.0, right_type="aligned", left_type="aligned", right=[0.3, -0.4]),
                _key(1.0, 1.0, left_type="vector", right_type="auto"),
                _key(1.2, 1.0, interp="constant"),
                _key(1.8, 0.4),
            ],
        )
    )
    out.append(
        (
            "tiny spans",
            [_key(1.0, 0.0), _key(1.0001, 0.5), _key(1.0002, -0.5, interp="linear"), _key(1.00025, 1.0)],
        )
    )
    out.append(("huge spans", [_key(0.0, 0.0), _key(1000.0, 3.0, interp="sine"), _key(3600.0, -3.0)]))
    out.append(
        (
            "mixed",
            [
                _key(0.0, 0.0, interp="linear"),
                _key(0.3, 1.0, interp="back", easing="out"),
                _key(0.9, 0.0, interp="elastic", easing="in_out"),
                _key(1.6, 0.8, interp="bounce", easing="out"),
                _key(2.1, 0.1, interp="constant"),
                _key(2.4, 0.5),
            ],
        )
    )
    for n in range(14):
        gaps = [(1e-3, 0.05), (0.05, 1.0), (0.5, 20.0)][n % 3]
        out.append((f"random {n}", _random_curve(rng, 2 + n % 6, gaps)))
    return out


def _times(rng: random.Random, keys: list[dict[str, Any]], count: int = 50) -> list[float]:
    ts = [k["t"] for k in keys]
    first, last = ts[0], ts[-1]
    span = max(last - first, 1e-3)
    out = {first - span, first - 1e-9, last + 1e-9, last + span, *ts}
    for t in ts:
        out.update((t - 1e-12, t + 1e-12))
    while len(out) < count:
        out.add(rng.uniform(first, last) if last > first else rng.uniform(first - 1.0, first + 1.0))
    return sorted(out)


def generate() -> dict[str, Any]:
    rng = random.Random(SEED)
    cases = []
    for name, keys in _curves(rng):
        times = _times(rng, keys)
        cs = CurveSet([[_to_key(k) for k in keys]])
        values = [float(cs.evaluate_reference(t)[0]) for t in times]
        assert all(math.isfinite(v) for v in values), name
        cases.append({"name": name, "keys": keys, "times": times, "values": values})
    return {"about": "generated by tests/test_clip_curve_fixture.py; do not edit", "cases": cases}


def _dump(doc: dict[str, Any]) -> str:
    # one case per line: small, and a change shows as a readable diff
    lines = [json.dumps(c, separators=(",", ":")) for c in doc["cases"]]
    return '{"about": ' + json.dumps(doc["about"]) + ',\n"cases": [\n' + ",\n".join(lines) + "\n]}\n"


def test_fixture_matches_python_curves():
    doc = generate()
    if os.environ.get("REGENERATE_CURVE_CASES") == "1":
        FIXTURE.write_text(_dump(doc), encoding="utf-8")
    committed = json.loads(FIXTURE.read_text(encoding="utf-8"))
    assert committed == doc, (
        "curveCases.json is stale: backend/engine/curves.py changed; regenerate it with "
        "REGENERATE_CURVE_CASES=1 and run the frontend's curve.test.ts"
    )
    assert len(doc["cases"]) >= 40
    assert FIXTURE.stat().st_size < 200_000


def test_the_compiled_engine_plays_the_fixture_curves():
    """What the editor draws is the reference; the engine's compiled kernel must agree with it."""
    doc = json.loads(FIXTURE.read_text(encoding="utf-8"))
    for case in doc["cases"]:
        cs = CurveSet([[_to_key(k) for k in case["keys"]]])
        played = np.array([cs.evaluate(t)[0] for t in case["times"]])
        np.testing.assert_allclose(played, case["values"], rtol=0, atol=1e-9, err_msg=case["name"])
