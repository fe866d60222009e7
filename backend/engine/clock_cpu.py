"""The clock on a CPU of its own, kept awake between ticks: `nutty serve --clock-cpu N|auto` (Linux).

Why (issue 36, measured on a 2-core VM): a tick after a sleep of the clock's period costs several
times the same tick back to back, and the cause is the CPU's idle state, not the tick's code. Once a
CPU idles, the guest's idle driver halts it after ~200 µs of polling and the core loses what its
caches and TLB held; the next tick reloads all of it. Keeping the CPU polling instead (no idle state
with an exit latency) took the interactive program's tick after 10 ms sleeps from 363 µs to 66-73 µs,
and a Ruckig 25-DoF update from 82 µs to 22 µs (its back-to-back cost). Served at 100 Hz under the
full load, the tick went from 563-574 µs to 184-333 µs. Robot control loops on Linux are set up this
way (a CPU of their own, no deep idle): this does it for the engine's clock, on request.

What `ClockCpu` does, from `open()` to `close()`:

- the clock thread runs on CPU N only; the server's other threads, the threads they start and the
  processes it spawns (the Pre-Viz) run on the other CPUs it may use, so they neither take the clock's
  CPU nor fill its caches between ticks (threads the clock thread starts move off it: `leave()`);
- CPU N's resume-latency limit (PM QoS, `/sys/devices/system/cpu/cpuN/power/pm_qos_resume_latency_us`)
  is set to `n/a`: the CPU never enters an idle state that takes time to leave, i.e. it polls when it
  has nothing to run. The cost: CPU N shows 100 % busy and draws its active power while the server
  runs. Writing the limit needs root (or write access to that file); without it the clock is still
  on its own CPU and `status()` (in /api/status) says why the CPU is not kept awake;
- a guardian process puts the old limit back when the server ends, however it ends: it waits for the
  end of a pipe the server holds, which a crash or `kill -9` closes as well.
"""

from __future__ import annotations

import contextlib
import logging
import os
import subprocess
import sys
from pathlib import Path
from typing import Any

log = logging.getLogger(__name__)

#: Where Linux keeps each CPU's power-management settings.
SYSFS_CPUS = Path("/sys/devices/system/cpu")
#: The resume-latency limit that keeps a CPU out of every idle state with an exit latency.
NO_IDLE = "n/a"

# The guardian: waits for its stdin to end (the server gone), then writes the old limit back. Started
# in a session of its own, so a Ctrl-C sent to the server's process group does not stop it first.
_GUARDIAN = """
import sys
path, old = sys.argv[1], sys.argv[2]
sys.stdin.buffer.read()
try:
    with open(path, "w") as f:
        f.write(old)
except OSError:
    pass
"""

#: The clock CPU in force in this process (None: none): what `leave()` moves a thread off.
_active: ClockCpu | None = None


def allowed_cpus() -> set[int]:
    """The CPUs this process may run on."""
    return set(os.sched_getaffinity(0)) if hasattr(os, "sched_getaffinity") else set()


def choose(spec: str, allowed: set[int] | None = None) -> int | None:
    """The CPU `--clock-cpu` names: "off" -> None, "auto" -> the highest CPU this process may use (None
    when it may use only one: the clock would have no CPU to itself), or a CPU number. ValueError
    saying why for a CPU the process may not use, fewer than two CPUs, or a word it does not know."""
    spec = spec.strip().lower()
    if spec == "off":
        return None
    if not sys.platform.startswith("linux"):
        raise ValueError("--clock-cpu needs Linux (CPU affinity and PM QoS); use --clock-cpu off")
    cpus = allowed_cpus() if allowed is None else set(allowed)
    if spec == "auto":
        return max(cpus) if len(cpus) >= 2 else None
    try:
        cpu = int(spec)
    except ValueError:
        raise ValueError(f"--clock-cpu takes a CPU number, 'auto' or 'off', got {spec!r}") from None
    if cpu not in cpus:
        raise ValueError(f"--clock-cpu {cpu}: this process may run on CPUs {_listed(cpus)} only")
    if len(cpus) < 2:
        raise ValueError(
            f"--clock-cpu {cpu}: the process may use one CPU only; none would be left for the rest"
        )
    return cpu


def _listed(cpus: set[int]) -> str:
    return ", ".join(str(c) for c in sorted(cpus))


class ClockCpu:
    """The clock's own CPU (see the module doc). `open()` on the main thread before the clock starts,
    `pin()` on the clock thread, `close()` when the server stops. `sysfs` stands in for
    /sys/devices/system/cpu (tests)."""

    def __init__(self, cpu: int, keep_awake: bool = True, sysfs: Path = SYSFS_CPUS):
        self.cpu = cpu
        self.allowed = allowed_cpus()
        others = self.allowed - {cpu}
        if not others:
            raise ValueError(f"CPU {cpu} is the only one this process may use")
        self.others = others
        self.keep_awake = keep_awake
        self.limit_path = sysfs / f"cpu{cpu}" / "power" / "pm_qos_resume_latency_us"
        self.kept_awake = False
        self.isolated = False
        self.pinned = False
        self.note: str | None = None  # why the CPU is not kept awake, or what else went wrong
        self._old: str | None = None
        self._guardian: subprocess.Popen[bytes] | None = None

    def open(self) -> ClockCpu:
        """Move this process's threads off the CPU and keep the CPU awake (where permitted)."""
        global _active
        _active = self
        self.isolated = self._isolate()
        if self.keep_awake:
            self._hold_awake()
        return self

    def _isolate(self) -> bool:
        try:
            _set_every_thread(self.others)
        except OSError as exc:
            self.note = f"could not move the server's threads off CPU {self.cpu}: {exc}"
            log.warning("%s", self.note)
            return False
        return True

    def _hold_awake(self) -> None:
        try:
            old = self.limit_path.read_text().strip()
            if old == NO_IDLE:  # another process keeps it awake (another server): its guardian restores it
                self.note = f"CPU {self.cpu} is already kept awake by another process; left to it"
                log.warning("%s", self.note)
                return
            self._old = old
            # The guardian first: the limit is never changed without something to put it back.
            self._guardian = subprocess.Popen(
                [sys.executable, "-c", _GUARDIAN, str(self.limit_path), self._old],
                stdin=subprocess.PIPE,
                stdout=subprocess.DEVNULL,
                stderr=subprocess.DEVNULL,
                start_new_session=True,
                close_fds=True,
            )
            self.limit_path.write_text(NO_IDLE)
            self.kept_awake = True
        except OSError as exc:  # no such file (not Linux's PM QoS), not root, a read-only /sys
            self.note = f"CPU {self.cpu} is not kept awake (its PM QoS limit could not be set: {exc})"
            log.warning("%s; the clock still runs on it alone", self.note)
            self._end_guardian()

    def pin(self) -> None:
        """On the clock thread: run on the clock's CPU only."""
        try:
            os.sched_setaffinity(0, {self.cpu})
            self.pinned = True
        except OSError as exc:
            self.note = f"the clock thread could not be moved to CPU {self.cpu}: {exc}"
            log.warning("%s", self.note)

    def close(self) -> None:
        """Put the CPU's old limit back, let go of the guardian, and let every thread of the process run
        on every CPU it could before `open` (the clock thread has ended by now, or moves too)."""
        global _active
        if _active is self:
            _active = None
        if self.isolated:
            with contextlib.suppress(OSError):
                _set_every_thread(self.allowed)
            self.isolated = False
        if self.kept_awake and self._old is not None:
            with contextlib.suppress(OSError):
                self.limit_path.write_text(self._old)
            self.kept_awake = False
        self._end_guardian()

    def _end_guardian(self) -> None:
        guardian, self._guardian = self._guardian, None
        if guardian is None:
            return
        if guardian.stdin is not None:
            with contextlib.suppress(OSError):
                guardian.stdin.close()  # the guardian writes the old limit (again) and exits
        try:
            guardian.wait(5)
        except subprocess.TimeoutExpired:
            guardian.kill()

    def status(self) -> dict[str, Any]:
        """What /api/status reports (`clock_cpu`)."""
        return {
            "cpu": self.cpu,
            "pinned": self.pinned,
            "isolated": self.isolated,
            "kept_awake": self.kept_awake,
            "note": self.note,
        }


def _set_every_thread(cpus: set[int]) -> None:
    for tid in os.listdir("/proc/self/task"):
        with contextlib.suppress(ProcessLookupError):  # a thread that ended meanwhile
            os.sched_setaffinity(int(tid), cpus)


def leave() -> None:
    """Move the calling thread off the clock's CPU (a thread the clock thread started inherits it)."""
    cpu = _active
    if cpu is not None:
        with contextlib.suppress(OSError):
            os.sched_setaffinity(0, cpu.others)
