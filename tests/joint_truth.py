"""The joints a robot's motors get, computed in the tests from the robot's own files, independently of
the code under test: `embodiment.yaml`'s DoFs and `drives`, the URDF's limits (read with the standard
library's XML parser), and the documented defaults (acceleration = 4 x velocity, jerk = 10 x
acceleration; a continuous joint's range is +-2 pi).

A joint's value is its own DoF's channel plus, for each symbolic DoF driving it, coefficient x (the
symbolic channel - its rest value); a joint with no own DoF sits at 0 (or its limit nearest 0) plus the
same sums.
"""

from __future__ import annotations

import math
import xml.etree.ElementTree as ET
from dataclasses import dataclass
from pathlib import Path

import numpy as np
import yaml

ROBOTS = Path(__file__).resolve().parents[1] / "robots"
TEST_ROBOTS = Path(__file__).resolve().parent / "assets" / "robots"
#: Relative slack on the limits (floating-point rounding only).
RECOMPOSE = 1e-9
#: Positions recomposed from channels carry a few ulps of rounding; finite differences amplify an error
#: e in position to 2e*rate, 4e*rate^2 and 8e*rate^3: that much absolute slack (rate in Hz), no more.
ULPS = 8 * np.finfo(float).eps


@dataclass
class JointTruth:
    names: list[str]
    lower: np.ndarray
    upper: np.ndarray
    velocity: np.ndarray
    acceleration: np.ndarray
    jerk: np.ndarray
    own: list[str | None]  # own DoF per joint
    terms: list[list[tuple[str, float]]]  # (symbolic DoF, coefficient) per joint

    def compose(self, emb, positions: np.ndarray) -> np.ndarray:
        """(T, joints) from (T, channels) frames of `emb`."""
        positions = np.atleast_2d(positions)
        q = np.empty((len(positions), len(self.names)))
        for j, _name in enumerate(self.names):
            own = self.own[j]
            col = (
                positions[:, emb.channel_index[own]]
                if own
                else np.full(len(positions), min(max(0.0, self.lower[j]), self.upper[j]))
            )
            for dof, coef in self.terms[j]:
                col = col + coef * (positions[:, emb.channel_index[dof]] - emb.dof(dof).rest)
            q[:, j] = col
        return q

    def worst(self, q: np.ndarray, rate: float, only: np.ndarray | None = None) -> dict[str, float]:
        """Worst ratios |v|/V, |a|/A, |j|/J and the largest excursion outside the range (rad or m), on the
        finite differences of `q` (T, joints) at `rate`; `only`: a mask of the joints `q` holds."""
        sel = np.ones(len(self.names), dtype=bool) if only is None else np.asarray(only, dtype=bool)
        v = np.diff(q, axis=0) * rate
        a = np.diff(v, axis=0) * rate
        j = np.diff(a, axis=0) * rate
        e = ULPS * max(1.0, float(np.abs(q).max(initial=0.0)))
        return {
            "v": float(((np.abs(v) - 2 * e * rate) / self.velocity[sel]).max(initial=0.0)),
            "a": float(((np.abs(a) - 4 * e * rate**2) / self.acceleration[sel]).max(initial=0.0)),
            "j": float(((np.abs(j) - 8 * e * rate**3) / self.jerk[sel]).max(initial=0.0)),
            "outside": float(np.maximum(self.lower[sel] - q, q - self.upper[sel]).max(initial=-1.0)),
        }

    def assert_within(
        self, q: np.ndarray, rate: float, what: str = "", only: np.ndarray | None = None
    ) -> None:
        r = self.worst(q, rate, only)
        assert r["v"] <= 1 + RECOMPOSE and r["a"] <= 1 + RECOMPOSE and r["j"] <= 1 + RECOMPOSE, (what, r)
        assert r["outside"] <= 1e-12, (what, r)


def joint_truth(folder: Path | str) -> JointTruth:
    folder = Path(folder)
    if not folder.is_absolute() and not folder.exists():
        folder = ROBOTS / str(folder)
    cfg = yaml.safe_load((folder / "embodiment.yaml").read_text())
    root = ET.parse(folder / cfg.get("urdf", "robot.urdf")).getroot()
    names, lower, upper, vel = [], [], [], []
    for j in root.findall("joint"):
        if j.get("type") in ("fixed", "floating", "planar") or j.find("mimic") is not None:
            continue
        lim = j.find("limit")
        lo = float(lim.get("lower")) if lim is not None and lim.get("lower") is not None else None
        hi = float(lim.get("upper")) if lim is not None and lim.get("upper") is not None else None
        if j.get("type") == "continuous" or lo is None or hi is None:
            lo, hi = -2 * math.pi, 2 * math.pi
        names.append(j.get("name"))
        lower.append(lo)
        upper.append(hi)
        vel.append(float(lim.get("velocity")) if lim is not None and lim.get("velocity") else 2.0)
    acc = [4.0 * v for v in vel]
    jerk = [10.0 * a for a in acc]
    own: list[str | None] = [None] * len(names)
    terms: list[list[tuple[str, float]]] = [[] for _ in names]
    for entry in cfg.get("stationary", []):
        if entry.get("drives"):
            for joint, coef in entry["drives"].items():
                terms[names.index(joint)].append((entry["name"], float(coef)))
            continue
        k = names.index(entry.get("joint", entry["name"]))
        own[k] = entry["name"]
        if entry.get("velocity") is not None:  # the own DoF's defaults follow its own velocity
            acc[k] = 4.0 * float(entry["velocity"])
            jerk[k] = 10.0 * acc[k]
        if entry.get("acceleration") is not None:
            acc[k] = float(entry["acceleration"])
            jerk[k] = 10.0 * acc[k]
        if entry.get("jerk") is not None:
            jerk[k] = float(entry["jerk"])
    return JointTruth(
        names, np.array(lower), np.array(upper), np.array(vel), np.array(acc), np.array(jerk), own, terms
    )
