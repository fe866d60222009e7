"""`nutty serve --hardware FILE`: real servos, as a robot's hardware.yaml describes them.

Start (`prepare`, before the clock's first tick): open every bus, ping every configured servo (any
missing: one line per servo naming joint, id and port, and nothing is powered), read where the robot
stands, refuse a joint measured far outside its URDF range, enable torque, and start the engine from
the measured pose (`Engine.start_from`): the first frames blend to the program within every limit.

Run: each frame's joint vector (the safety net's output: what the motors must get) goes to one
`BusWorker` per bus (backend.hardware.worker), which writes the goals and reads the servos back. A
servo fault holds that servo, fades the rest of the robot to rest (the program is dropped; the held
joint's channel is pinned where it stands) and is reported: the log, a `servo_fault` event, status.

Stop (`close`, after the server's shutdown has parked the robot): the last goals are written, the
servos are given a moment to arrive, and torque goes off unless `torque_on_exit: true`.
"""

from __future__ import annotations

import logging
import threading
import time
from pathlib import Path
from typing import Any

import numpy as np

from backend.drivers.registry import DriverOption
from backend.engine.embodiment import Embodiment
from backend.engine.frames import AnimationFrame
from backend.engine.runtime import Engine, Sink
from backend.engine.start_pose import START_SECONDS, channels_at, outside_range
from backend.hardware.bus import HardwareError, ServoBus
from backend.hardware.config import Hardware, load_hardware
from backend.hardware.mapping import JointMap
from backend.hardware.registry import BUSES
from backend.hardware.worker import BusWorker

log = logging.getLogger(__name__)

#: A joint measured beyond its URDF range by more than this at start stops the start (rad or m): the
#: calibration is wrong, or the robot was bent by hand; either way moving it is not safe.
START_RANGE_TOLERANCE = 0.1
#: After the park, how long the servos get to reach their last goals before torque goes off (s).
SETTLE_SECONDS = 1.0
#: Within this of their goals the servos count as arrived (rad or m).
SETTLED = 0.02


class HardwareDriver(Sink[AnimationFrame]):
    option = DriverOption(
        "hardware",
        metavar="FILE",
        help="drive real servos (Dynamixel, Feetech, PCA9685) as FILE says, e.g. robots/<robot>/hardware.yaml "
        "(docs/hardware.md); the robot starts from where it stands",
        needs_engine=True,
    )

    def __init__(self, embodiment: Embodiment, hardware: Hardware, buses: list[ServoBus] | None = None):
        self.emb, self.hardware = embodiment, hardware
        self.buses = buses if buses is not None else [BUSES[c.driver](c) for c in hardware.buses]
        self.maps = [JointMap(c, embodiment) for c in hardware.buses]
        self.workers: list[BusWorker] = []
        self.state = "starting"
        self.faults: list[dict[str, Any]] = []
        self._engine: Engine | None = None
        self._opened: list[ServoBus] = []
        self._lock = threading.Lock()
        super().__init__("hardware", max_queue=2)

    @classmethod
    def from_option(cls, embodiment: Embodiment, path: str) -> HardwareDriver:
        return cls(embodiment, load_hardware(path, embodiment))

    # --- start ------------------------------------------------------------------------------------
    def prepare(self, engine: Engine) -> None:
        """Connect and start `engine` (not yet ticked) from the measured pose; HardwareError saying why
        not (the servos' torque is then left as it was: off)."""
        for bus in self.buses:
            try:
                bus.open()
            except HardwareError:
                raise
            except Exception as exc:  # an SDK's own error type: one line naming the port
                raise HardwareError(f"cannot open {bus.kind} bus {bus.where}: {exc}") from exc
            self._opened.append(bus)
        raw = self._ping_all()
        measured = np.full(len(self.emb.joint_names), np.nan)
        for jmap, positions in zip(self.maps, raw):
            measured[jmap.index] = jmap.to_joints(positions)
        joints = engine.safety.joints
        beyond = outside_range(joints, measured, START_RANGE_TOLERANCE)
        if beyond:
            raise HardwareError(
                "; ".join(
                    f"{name} stands at {value:.3f}, outside its URDF range "
                    f"[{joints.lower[joints.names.index(name)]:g}, {joints.upper[joints.names.index(name)]:g}]"
                    for name, value in beyond
                )
                + ": check zero and direction in the hardware file (`nutty hardware calibrate`), "
                "or move the joint into its range by hand"
            )
        blind = [n for bus, m in zip(self.buses, self.maps) if not bus.reads_position for n in m.names]
        if blind:
            log.warning(
                "%s cannot report where they stand: they go to their start pose at their own speed",
                ", ".join(blind),
            )
        for bus, jmap, positions in zip(self.buses, self.maps, raw):
            if bus.reads_position:  # a servo powers up towards its goal register: make that where it stands
                bus.write_goals(jmap.ids, positions)
            bus.torque(jmap.ids, True)
        engine.start_from(channels_at(self.emb, joints, measured), joints=measured, seconds=START_SECONDS)
        self._engine = engine
        no_answer = self.hardware.file.no_answer_ms / 1e3
        for bus, jmap, positions in zip(self.buses, self.maps, raw):
            worker = BusWorker(bus, jmap, self.hardware.file.read_hz, no_answer, self._on_fault)
            worker.seed(positions)
            self.workers.append(worker)
        self.state = "running"
        log.info(
            "hardware: %d servos on %d buses, starting from the measured pose", len(measured), len(self.buses)
        )

    def _ping_all(self) -> list[np.ndarray]:
        """Each bus's present positions (raw, bus order; NaN where the servo cannot report); a
        HardwareError with one line per servo that did not answer."""
        missing: list[str] = []
        raw: list[np.ndarray] = []
        for bus, jmap in zip(self.buses, self.maps):
            lo, hi = jmap.urdf_span()
            found = bus.ping(jmap.ids)
            positions = np.full(len(jmap.ids), np.nan)
            for k, servo in enumerate(jmap.ids):
                info = found.get(servo)
                if info is None:
                    missing.append(f"{jmap.names[k]}: no answer from id {servo} on {bus.where}")
                    continue
                if lo[k] < info.raw_min - 0.5 or hi[k] > info.raw_max + 0.5:
                    raise HardwareError(
                        f"{jmap.describe(k)} on {bus.where}: its URDF range needs {bus.raw_unit} "
                        f"[{lo[k]:.0f}, {hi[k]:.0f}], but the {info.model_name} accepts only "
                        f"[{info.raw_min:.0f}, {info.raw_max:.0f}] (its position limits): widen them on the "
                        "servo, or check zero, direction and gear"
                    )
                if info.position is not None:
                    positions[k] = info.position
            if bus.reads_position:  # a ping's position may be stale or absent: read them all at once
                reading = bus.read_state(jmap.ids)
                positions = np.where(np.isfinite(reading.position), reading.position, positions)
            raw.append(positions)
        if missing:
            raise HardwareError("\n".join(missing))
        for bus, jmap, positions in zip(self.buses, self.maps, raw):
            unread = [jmap.describe(int(k)) for k in np.flatnonzero(~np.isfinite(positions))]
            if bus.reads_position and unread:
                raise HardwareError(f"could not read the position of {', '.join(unread)} on {bus.where}")
        return raw

    # --- run --------------------------------------------------------------------------------------
    def consume(self, frame: AnimationFrame) -> None:
        joints = frame.joint_values(self.emb)
        for worker in self.workers:
            worker.offer((frame.t, joints))

    def _on_fault(self, worker: BusWorker, k: int, fault: str, t: float) -> None:
        """A servo faulted (on its bus's thread): hold it, take the rest of the robot to rest, report."""
        joint = worker.map.names[k]
        entry = {
            "joint": joint,
            "servo": worker.map.ids[k],
            "bus": worker.bus.where,
            "fault": fault,
            "t": round(t, 4),
        }
        with self._lock:
            self.faults.append(entry)
            self.state = "faulted"
        log.error(
            "servo fault on %s (id %d, %s): %s; holding it, the rest of the robot goes to rest",
            joint,
            entry["servo"],
            entry["bus"],
            fault,
        )
        engine = self._engine
        if engine is None:
            return
        hold = worker.measured[k] if np.isfinite(worker.measured[k]) else worker.commanded[k]
        engine.call_soon(lambda: self._hold_and_rest(engine, joint, float(hold), entry))

    def _hold_and_rest(self, engine: Engine, joint: str, value: float, entry: dict[str, Any]) -> None:
        """On the clock thread: drop the program (the robot fades to rest within its limits), pin the
        faulted joint's own channel where the joint stands, and emit the `servo_fault` event."""
        emb, joints = self.emb, engine.safety.joints
        j = joints.names.index(joint)
        own = int(joints.own[j])
        engine.load_soon(None, adopt=False)
        if np.isfinite(value) and own >= 0:
            measured = np.full(len(joints.names), np.nan)
            measured[j] = value
            mask = np.zeros(emb.n_channels, dtype=bool)
            mask[own] = True
            engine.set_override(mask, channels_at(emb, joints, measured))
        engine.ctx.events.append({"event": "servo_fault", **entry})

    # --- what it reports --------------------------------------------------------------------------
    def joint_readings(self) -> dict[str, dict[str, Any]]:
        out: dict[str, dict[str, Any]] = {}
        for worker in self.workers:
            out.update(worker.readings())
        return out

    def hardware_status(self) -> dict[str, Any]:
        path = self.hardware.path
        with self._lock:
            faults, state = list(self.faults), self.state
        return {
            "file": str(path) if isinstance(path, Path) else None,
            "state": state,
            "buses": [w.status() for w in self.workers],
            "faults": faults,
            "torque_on_exit": self.hardware.torque_on_exit,
        }

    def stats(self) -> dict[str, Any]:
        base = super().stats()
        base["hardware_state"] = self.state
        return base

    # --- stop -------------------------------------------------------------------------------------
    def close(self, timeout: float = 2.0) -> None:
        """Deliver the last frames (the parked pose), let the servos arrive, then torque off (unless
        `torque_on_exit`) and close the ports."""
        super().close(timeout)
        with self._lock:
            if self.state != "stopped":
                self.state = "parking"
        for worker in self.workers:
            worker.close(timeout)
        self._settle()
        for bus, jmap in zip(self._opened, self.maps):
            try:
                if not self.hardware.torque_on_exit:
                    bus.torque(jmap.ids, False)
            except Exception as exc:  # noqa: BLE001 (any SDK error: one bus failing must not keep the others powered)
                log.error("hardware: could not switch torque off on %s: %s", bus.where, exc)
            finally:
                bus.close()
        if self.workers:  # torque was switched on: say how it was left
            log.info(
                "hardware: stopped; torque %s",
                "kept on (torque_on_exit)" if self.hardware.torque_on_exit else "off",
            )
        self._opened = []
        with self._lock:
            self.state = "stopped"

    def _settle(self) -> None:
        """Read the servos until each driven one is within SETTLED of its last goal, or SETTLE_SECONDS."""
        deadline = time.monotonic() + SETTLE_SECONDS
        pending = [w for w in self.workers if w.bus.reads_position and w.active.any()]
        while pending and time.monotonic() < deadline:
            for worker in list(pending):
                worker.read(time.monotonic())
                gap = np.abs(worker.commanded - worker.measured)[worker.active]
                if np.all(gap <= SETTLED):
                    pending.remove(worker)
            time.sleep(0.02)
        for worker in pending:
            gap = np.nanmax(np.abs(worker.commanded - worker.measured)[worker.active])
            log.warning("hardware: %s still %.3f from its rest goals at torque off", worker.bus.where, gap)
