"""The add-on's copy of the engine's curve rules (blender/nutty_blender/curve_math.py, plain Python so
that it runs inside Blender) against the engine's own (backend/engine/curves.py): Import clip puts
Bezier handles where the engine resolves them and bakes the easings Blender computes differently from
the engine's formulas, so the two must agree for every handle type and easing."""

from __future__ import annotations

import importlib.util
import random
from pathlib import Path

import numpy as np
import pytest

from backend.engine.curves import INTERPS, Key, ease, resolve_handles

PATH = Path(__file__).resolve().parents[1] / "blender" / "nutty_blender" / "curve_math.py"
_spec = importlib.util.spec_from_file_location("nutty_curve_math", PATH)
assert _spec is not None and _spec.loader is not None
curve_math = importlib.util.module_from_spec(_spec)
_spec.loader.exec_module(curve_math)  # (no package import: the add-on's __init__ needs Blender)

HANDLE_TYPES = ("auto", "auto_clamped", "vector", "aligned", "free")


def random_keys(rng: random.Random, n: int) -> list[dict]:
    """n keys at increasing times, random values, handle types and (sometimes) handle offsets."""
    t, keys = 0.0, []
    for _ in range(n):
        t += rng.uniform(0.05, 1.0)
        key = {"t": t, "v": rng.uniform(-1.0, 1.0)}
        for side, sign in (("left", -1.0), ("right", 1.0)):
            key[f"{side}_type"] = rng.choice(HANDLE_TYPES)
            if rng.random() < 0.7:  # a given offset, sometimes longer than its segment
                key[side] = [sign * rng.uniform(0.0, 1.2), rng.uniform(-0.8, 0.8)]
        keys.append(key)
    return keys


@pytest.mark.parametrize("seed", range(40))
def test_handles_resolve_as_in_the_engine(seed):
    rng = random.Random(seed)
    keys = random_keys(rng, rng.randint(1, 7))
    engine = resolve_handles(
        [
            Key(
                k["t"],
                k["v"],
                left_type=k["left_type"],
                right_type=k["right_type"],
                left=tuple(k["left"]) if "left" in k else None,
                right=tuple(k["right"]) if "right" in k else None,
            )
            for k in keys
        ]
    )
    ours = curve_math.resolve_handles(keys)
    assert np.allclose(np.array(ours), np.array(engine), atol=1e-12, rtol=0.0)


@pytest.mark.parametrize("name", INTERPS[3:])
@pytest.mark.parametrize("mode", ["in", "out", "in_out"])
def test_easings_compute_as_in_the_engine(name, mode):
    u = np.linspace(-0.1, 1.1, 241)
    ours = [curve_math.ease(name, mode, float(x)) for x in u]
    assert np.allclose(ours, ease(name, mode, u), atol=1e-12, rtol=0.0)
