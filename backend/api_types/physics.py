"""The physics preview's report (backend/sim/report.py): `nutty sim report --json`, and the `physics`
part of POST /api/analyze and of the import report."""

from __future__ import annotations

from typing import Literal

from pydantic import Field

from backend.api_types.base import Shape


class PhysicsJoint(Shape):
    """One joint of one simulated motion."""

    peak_error: float = Field(..., description="largest |goal - simulated position| (rad or m)")
    rms_error: float = Field(..., description="root-mean-square tracking error (rad or m)")
    peak_effort: float = Field(..., description="largest |motor force| as a fraction of its limit (0..1)")
    peak_torque: float = Field(..., description="largest |motor force| (N·m, or N for a slide joint)")
    effort_limit: float = Field(..., description="the motor's limit (N·m or N)")
    saturated: float = Field(..., description="time spent at the effort limit (s)")


class PhysicsContact(Shape):
    """Two links that touched during a simulated motion."""

    links: list[str] = Field(..., description="the two links, sorted ('floor' or 'table' for a plane)")
    first: float = Field(..., description="when they first touched (s from the start)")
    seconds: float = Field(..., description="for how long they touched, in all (s)")
    depth: float = Field(..., description="the deepest penetration (m)")


class PhysicsRun(Shape):
    """One motion (raw or filtered) in physics."""

    joints: dict[str, PhysicsJoint] = Field(..., description="URDF joint -> figures")
    contacts: list[PhysicsContact] = Field(..., description="by first touch")
    worst_joint: str | None = Field(..., description="the joint with the largest peak error")
    peak_error: float = Field(..., description="that joint's peak error (rad or m)")
    saturated_joints: list[str] = Field(..., description="joints that reached their effort limit")


class PhysicsReport(Shape):
    """A motion raw (before stage 2 and the safety net) and filtered (what the motors get), in MuJoCo."""

    rate: float = Field(..., description="engine ticks per second of both motions (Hz)")
    physics_rate: float = Field(..., description="physics steps per second (Hz)")
    seconds: float = Field(..., description="how long was simulated (s)")
    gains: str = Field(..., description="where the motors' gains came from: a hardware.yaml, or 'urdf'")
    notes: list[str] = Field(
        ..., description="what the model guessed (inertia from geometry, visual shapes colliding)"
    )
    raw: PhysicsRun
    filtered: PhysicsRun
    robot: str | None = Field(default=None, description="`nutty sim report`: the robot")
    target: str | None = Field(default=None, description="`nutty sim report`: the clip or program file")
    kind: Literal["clip", "program"] | None = Field(default=None, description="`nutty sim report`: what ran")
