"""What the motors would make of a motion, in physics: `nutty sim report`, and the physics part of the
import report and of Check limits (POST /api/analyze with `physics: true`).

A motion is the joint goals (rad or m) a robot's motors get at each engine tick. `physics_report` runs
two of them through the same MuJoCo model (backend.sim.model): the *raw* motion (the program's stage 1,
or the clip as keyed) and the *filtered* one (through the program's stage 2 and the safety net: what the
robot is really sent), so the difference says what the motion filter buys in physics. Per joint:

- `peak_error`, `rms_error` (rad or m): goal minus simulated position at each tick (a goal outside the
  joint's range counts from the range's end, where the motor stops);
- `peak_effort` (fraction of the effort limit), `peak_torque` and `effort_limit` (N·m, or N);
- `saturated` (s): time spent at the effort limit (|effort| >= SATURATED_EFFORT, as for servos).

Contacts: each pair of links that touched (not parent and child; "floor"/"table" for the planes), when
first (s), for how long (s) and how deep (m).
"""

from __future__ import annotations

from typing import Any

import numpy as np

from backend.drivers.readings import SATURATED_EFFORT
from backend.sim.model import SimModel
from backend.sim.world import SimWorld


def simulate(sim: SimModel, goals: np.ndarray, rate: float) -> dict[str, Any]:
    """Follow `goals` (T, J: sim.joints order, one row per tick at `rate` Hz) from standing still at the
    first row; the per-joint figures and contacts (see the module's docstring)."""
    goals = np.asarray(goals, dtype=float)
    world = SimWorld(sim)
    world.reset(goals[0])
    ticks, n = goals.shape
    error = np.empty((ticks, n))
    effort = np.empty((ticks, n))
    torque = np.empty((ticks, n))
    low, high = world.joint_range
    contacts: dict[tuple[str, str], dict[str, Any]] = {}
    dt = 1.0 / rate
    for k in range(ticks):
        hits = world.follow(goals[k], dt)
        error[k] = np.clip(goals[k], low, high) - world.positions()
        effort[k] = world.efforts()
        torque[k] = world.torques()
        t = round(k * dt, 4)
        for hit in hits:
            c = contacts.setdefault(
                hit.links, {"links": list(hit.links), "first": t, "ticks": 0, "depth": 0.0}
            )
            c["ticks"] += 1
            c["depth"] = max(c["depth"], hit.depth)
    saturated = np.abs(effort) >= SATURATED_EFFORT
    joints = {}
    for j, name in enumerate(sim.joints):
        joints[name] = {
            "peak_error": round(float(np.max(np.abs(error[:, j]))), 5),
            "rms_error": round(float(np.sqrt(np.mean(error[:, j] ** 2))), 5),
            "peak_effort": round(float(np.max(np.abs(effort[:, j]))), 4),
            "peak_torque": round(float(np.max(np.abs(torque[:, j]))), 4),
            "effort_limit": round(float(sim.effort[j]), 4),
            "saturated": round(float(np.count_nonzero(saturated[:, j]) * dt), 4),
        }
    touched = [
        {
            "links": c["links"],
            "first": c["first"],
            "seconds": round(c["ticks"] * dt, 4),
            "depth": round(c["depth"], 5),
        }
        for c in sorted(contacts.values(), key=lambda c: c["first"])
    ]
    return {"joints": joints, "contacts": touched, **_summary(joints, touched)}


def _summary(joints: dict[str, dict[str, Any]], contacts: list[dict[str, Any]]) -> dict[str, Any]:
    worst = max(joints, key=lambda n: joints[n]["peak_error"]) if joints else None
    return {
        "worst_joint": worst,
        "peak_error": joints[worst]["peak_error"] if worst else 0.0,
        "saturated_joints": sorted(n for n, j in joints.items() if j["saturated"] > 0),
    }


def physics_report(
    sim: SimModel, raw: np.ndarray, filtered: np.ndarray, rate: float, gains: str = "urdf"
) -> dict[str, Any]:
    """The raw and the filtered motion (each (T, J) joint goals at `rate` Hz) in physics, side by side
    (api_types.PhysicsReport); `gains`: where the motors' gains came from (a hardware.yaml, or "urdf")."""
    return {
        "rate": rate,
        "physics_rate": round(1 / sim.model.opt.timestep, 3),
        "seconds": round(len(filtered) / rate, 4),
        "gains": gains,
        "notes": list(sim.notes),
        "raw": simulate(sim, raw, rate),
        "filtered": simulate(sim, filtered, rate),
    }


def format_report(name: str, report: dict[str, Any]) -> str:
    """A report as the terminal shows it: one row per joint, raw then filtered, then the contacts."""
    lines = [
        f"{name}: {report['seconds']:g} s at {report['rate']:g} Hz, physics at {report['physics_rate']:g} Hz "
        f"(gains: {report['gains']})",
        "",
        f"{'joint':<16} {'':<9} {'peak err':>9} {'rms err':>9} {'peak effort':>12} {'torque/limit':>14} "
        f"{'saturated':>10}",
    ]
    raw, filtered = report["raw"]["joints"], report["filtered"]["joints"]
    for joint in filtered:
        for label, figures in (("raw", raw[joint]), ("filtered", filtered[joint])):
            lines.append(
                f"{joint if label == 'raw' else '':<16} {label:<9} {figures['peak_error']:>9.4f} "
                f"{figures['rms_error']:>9.4f} {figures['peak_effort'] * 100:>11.0f}% "
                f"{figures['peak_torque']:>6.2f}/{figures['effort_limit']:<7.2f} {figures['saturated']:>9.2f}s"
            )
    for label in ("raw", "filtered"):
        contacts = report[label]["contacts"]
        lines.append("")
        if not contacts:
            lines.append(f"contacts ({label}): none")
            continue
        lines.append(f"contacts ({label}):")
        for c in contacts:
            a, b = c["links"]
            lines.append(
                f"  {a} / {b}: from {c['first']:.2f} s for {c['seconds']:.2f} s, {c['depth'] * 1000:.1f} mm deep"
            )
    return "\n".join(lines)
