"""`nutty serve --sim mujoco`: the robot in MuJoCo, following the frames the drivers receive.

A driver like the others (an engine `Sink` on its own thread, never the clock's), usable beside real
ones: each frame's joints (the safety net's output, what a servo bus gets) are held as the position
actuators' goals while the physics steps at 1 kHz up to the frame's time. It reports what the motors
would do — per joint {commanded, measured, error, effort, saturated} like the servo drivers, plus the
motor torque in N·m — and contacts between links that are not parent and child, or with the floor or
table plane: in `/api/status` (`simulation`), as `sim_contact` events, and to the Pre-Viz's physics
ghost. With `--sim-stop-on-contact` a new contact stops the program's motion the way a servo fault
does: the program is dropped and the robot fades to rest within its limits.
"""

from __future__ import annotations

import argparse
import logging
import threading
import time
from collections import deque
from typing import TYPE_CHECKING, Any

import numpy as np

from backend.drivers.registry import DriverArgs, DriverOption, DriverSetting
from backend.engine.embodiment import Embodiment
from backend.engine.frames import AnimationFrame
from backend.engine.kinematics import yaw_pitch_roll_quat
from backend.engine.runtime import Engine, Sink
from backend.sim.availability import require_mujoco

if TYPE_CHECKING:
    from backend.sim.model import SimModel
    from backend.sim.world import Contact, Snapshot

log = logging.getLogger(__name__)

ENGINES = ("mujoco",)
#: A contact pair not seen for this long (s) is over; seeing it again is a new contact (and event).
CONTACT_GAP = 0.25
#: How many past contacts status keeps.
RECENT_CONTACTS = 20


def _engine(text: str) -> str:
    if text not in ENGINES:
        raise argparse.ArgumentTypeError(f"unknown simulator '{text}' (known: {', '.join(ENGINES)})")
    return text


def _height(text: str) -> float:
    try:
        value = float(text)
    except ValueError:
        raise argparse.ArgumentTypeError(f"expected a height in m, got '{text}'") from None
    if not -10.0 <= value <= 10.0:
        raise argparse.ArgumentTypeError(f"the table height must be within -10..10 m, got {value:g}")
    return value


class MujocoDriver(Sink[AnimationFrame]):
    option = DriverOption(
        "sim",
        metavar="ENGINE",
        help="simulate the robot in physics (mujoco: gravity, motor strength, tracking, self-collision; "
        "docs/simulation.md), beside or instead of real motors",
        parse=_engine,
        settings=(
            DriverSetting(
                "sim-hardware",
                "FILE",
                "the simulated motors' kp, kd and effort from this hardware.yaml (default: --hardware's file)",
            ),
            DriverSetting(
                "sim-table",
                "HEIGHT",
                "add a table plane HEIGHT m above the floor that links other than the base touch (contacts count)",
                _height,
            ),
            DriverSetting(
                "sim-stop-on-contact",
                None,
                "a new contact in the simulation stops the program's motion (the robot fades to rest), as a "
                "servo fault does",
                flag=True,
            ),
        ),
    )
    #: Its readings are a model's: a real driver's readings of the same joint take precedence.
    simulated = True

    def __init__(
        self, embodiment: Embodiment, sim: SimModel, stop_on_contact: bool = False, source: str = "urdf"
    ):
        from backend.sim.world import SimWorld  # lazy: MuJoCo is an optional extra (see from_option)

        self.emb, self.sim = embodiment, sim
        self.world = SimWorld(sim)
        self.stop_on_contact = bool(stop_on_contact)
        self.gain_source = source
        self.state = "waiting"
        self._engine: Engine | None = None
        self._lock = threading.Lock()
        self._last_t: float | None = None
        self._seen: dict[tuple[str, str], float] = {}  # pair -> sim time last seen
        self._active: list[dict[str, Any]] = []
        self.recent: deque[dict[str, Any]] = deque(maxlen=RECENT_CONTACTS)
        self.contacts_total = 0
        self.stops = 0
        self._snapshot: Snapshot | None = None  # the motors after the last frame (never written after)
        self._touching: tuple[str, ...] = ()
        self._cpu = deque(maxlen=500)  # CPU seconds per frame followed
        self._frame_dt = deque(maxlen=500)  # frame periods (s)
        super().__init__("sim", max_queue=4)

    @classmethod
    def from_option(cls, embodiment: Embodiment, value: DriverArgs) -> MujocoDriver:
        require_mujoco()
        from backend.hardware.config import load_hardware  # lazy: only a hardware file needs the servo models
        from backend.sim.model import build, gains_for  # lazy: MuJoCo is an optional extra

        path = value.settings.get("sim_hardware") or getattr(value.args, "hardware", None)
        hardware = load_hardware(path, embodiment) if path else None
        sim = build(embodiment, gains_for(embodiment, hardware), table=value.settings.get("sim_table"))
        log.info(
            "sim: MuJoCo %s, %d joints at %g Hz; floor at z=%.3f m%s",
            embodiment.name,
            len(sim.joints),
            1 / sim.model.opt.timestep,
            sim.floor_z,
            f", table at z={sim.table_z:.3f} m" if sim.table_z is not None else "",
        )
        return cls(
            embodiment, sim, bool(value.settings.get("sim_stop_on_contact")), str(path) if path else "urdf"
        )

    def prepare(self, engine: Engine) -> None:
        """Given the engine (`nutty serve`): contacts become events, and may stop the program."""
        self._engine = engine

    # --- run (on the sink's thread) ---------------------------------------------------------------
    def consume(self, frame: AnimationFrame) -> None:
        start = time.thread_time()
        goals = frame.joint_values(self.emb)
        base = self.emb.base_pose(frame.position)
        if base:
            self.world.place_base(*_base_transform(base))
        if self._last_t is None or frame.t <= self._last_t:  # the first frame, or time restarted
            self.world.reset(goals)
            dt = 0.0
        else:
            dt = frame.t - self._last_t
        self._last_t = frame.t
        hits = self.world.follow(goals, dt) if dt > 0 else []
        snapshot = self.world.snapshot()
        new = self._note_contacts(hits, frame.t)
        with self._lock:
            self._snapshot = snapshot
            self._touching = tuple(sorted({name for c in self._active for name in c["links"]}))
            self.state = "running"
        self._cpu.append(time.thread_time() - start)
        if dt > 0:
            self._frame_dt.append(dt)
        for contact in new:
            self._report(contact)

    def _note_contacts(self, hits: list[Contact], t: float) -> list[dict[str, Any]]:
        """Update the active contacts; the ones that are new (not seen within CONTACT_GAP)."""
        now = self.world.time
        new = []
        for hit in hits:
            last = self._seen.get(hit.links)
            if last is None or now - last > CONTACT_GAP:
                new.append(
                    {
                        "links": list(hit.links),
                        "t": round(t, 4),
                        "depth": round(hit.depth, 5),
                        "position": [round(x, 4) for x in hit.position],
                    }
                )
            self._seen[hit.links] = now
        active = {pair for pair, seen in self._seen.items() if now - seen <= CONTACT_GAP}
        self._seen = {pair: self._seen[pair] for pair in active}
        depth = {hit.links: hit.depth for hit in hits}
        with self._lock:
            kept = {tuple(c["links"]): c for c in self._active}
            self._active = [
                {**kept.get(pair, {"links": list(pair)}), "depth": round(depth.get(pair, 0.0), 5)}
                for pair in sorted(active)
            ]
            for c in new:
                self.recent.append(c)
            self.contacts_total += len(new)
        return new

    def _report(self, contact: dict[str, Any]) -> None:
        a, b = contact["links"]
        stop = self.stop_on_contact and self._engine is not None
        log.warning(
            "sim: contact %s / %s at t=%.2f s, %.1f mm deep%s",
            a,
            b,
            contact["t"],
            contact["depth"] * 1000,
            "; stopping the program's motion" if stop else "",
        )
        engine = self._engine
        if engine is None:
            return
        event = {"event": "sim_contact", **contact, "stopped": stop}
        if stop:
            with self._lock:
                self.stops += 1
            engine.call_soon(lambda: self._stop(engine, event))
        else:
            engine.call_soon(lambda: engine.ctx.events.append(event))

    @staticmethod
    def _stop(engine: Engine, event: dict[str, Any]) -> None:
        """On the clock thread: drop the program (the robot fades to rest within its limits), report."""
        engine.load_soon(None, adopt=False)
        engine.ctx.events.append(event)

    # --- what it reports --------------------------------------------------------------------------
    def joint_readings(self) -> dict[str, dict[str, Any]]:
        with self._lock:
            snapshot = self._snapshot
        return {} if snapshot is None else self.world.readings(snapshot)

    def physics_pose(self) -> tuple[np.ndarray, tuple[str, ...]] | None:
        """The simulated joints (emb.joint_names order, rad or m) and the links now in contact; None
        before the first frame."""
        with self._lock:
            if self._snapshot is None:
                return None
            return self._snapshot[1], self._touching

    def physics_model(self) -> tuple[SimModel, str]:
        """The compiled model (read-only: MuJoCo data is per user) and where its gains came from, so an
        offline analysis on this server simulates the same motors."""
        return self.sim, self.gain_source

    def simulation_status(self) -> dict[str, Any]:
        """api_types.SimulationStatus."""
        cpu = np.array(self._cpu) if self._cpu else np.zeros(1)
        period = float(np.mean(self._frame_dt)) if self._frame_dt else 0.0
        with self._lock:
            return {
                "engine": "mujoco",
                "state": self.state,
                "rate": round(1 / self.sim.model.opt.timestep, 3),
                "time": round(self.world.time, 4),
                "steps": self.world.steps,
                "gains": self.gain_source,
                "cpu_per_frame_ms": round(float(np.median(cpu)) * 1000, 4),
                "cpu_share": round(float(np.mean(cpu)) / period, 4) if period > 0 else 0.0,
                "contacts": [dict(c) for c in self._active],
                "recent_contacts": list(self.recent),
                "contacts_total": self.contacts_total,
                "stop_on_contact": self.stop_on_contact,
                "stops": self.stops,
                "floor_z": round(self.sim.floor_z, 5),
                "table_z": None if self.sim.table_z is None else round(self.sim.table_z, 5),
                "notes": list(self.sim.notes),
            }

    def stats(self) -> dict[str, Any]:
        base = super().stats()
        base["sim_state"] = self.state
        return base


def _base_transform(
    base: dict[str, float],
) -> tuple[tuple[float, float, float], tuple[float, float, float, float]]:
    """Position (m) and orientation (w, x, y, z) of the base from its spatial axes."""
    get = base.get
    return (get("x", 0.0), get("y", 0.0), get("z", 0.0)), yaw_pitch_roll_quat(
        get("yaw", 0.0), get("pitch", 0.0), get("roll", 0.0)
    )
