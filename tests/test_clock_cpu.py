"""`nutty serve --clock-cpu`: the clock on a CPU of its own, kept awake, and the CPU's idle states given
back however the server ends (backend/engine/clock_cpu.py). The PM QoS file is a stand-in under
tmp_path, except in the last test: a real `nutty serve --clock-cpu auto` sets the machine's own limit
(where it may: root), and the test checks that the server puts it back."""

from __future__ import annotations

import contextlib
import os
import signal
import subprocess
import sys
import textwrap
import threading
import time
from pathlib import Path
from types import SimpleNamespace

import httpx
import pytest

from backend.engine import clock_cpu
from backend.engine.clock_cpu import NO_IDLE, ClockCpu, choose
from backend.engine.embodiment import load_embodiment
from backend.engine.warm_up import OnceInBackground
from backend.session import EngineSession

ROOT = Path(__file__).resolve().parents[1]
ALLOWED = clock_cpu.allowed_cpus()

needs_two_cpus = pytest.mark.skipif(
    not sys.platform.startswith("linux") or len(ALLOWED) < 2, reason="needs Linux and two CPUs"
)


def fake_sysfs(root: Path, cpu: int, value: str = "0") -> Path:
    """A stand-in for /sys/devices/system/cpu with CPU `cpu`'s resume-latency limit at `value`."""
    path = root / f"cpu{cpu}" / "power" / "pm_qos_resume_latency_us"
    path.parent.mkdir(parents=True)
    path.write_text(value)
    return path


def affinity_of(thread: threading.Thread) -> set[int]:
    assert thread.native_id is not None
    return set(os.sched_getaffinity(thread.native_id))


@needs_two_cpus
def test_choose_reads_off_auto_and_numbers_and_says_what_is_wrong():
    assert choose("off") is None
    assert choose("auto", {0, 1, 2}) == 2
    assert choose("auto", {3}) is None  # one CPU: nothing to keep the clock's own
    assert choose(" 1 ", {0, 1}) == 1
    with pytest.raises(ValueError, match=r"--clock-cpu 5: this process may run on CPUs 0, 1 only"):
        choose("5", {0, 1})
    with pytest.raises(ValueError, match="one CPU only"):
        choose("0", {0})
    with pytest.raises(ValueError, match="a CPU number, 'auto' or 'off', got 'fast'"):
        choose("fast", {0, 1})


@needs_two_cpus
def test_the_clock_gets_its_cpu_alone_kept_awake_and_everything_back_on_close(tmp_path):
    cpu = max(ALLOWED)
    limit = fake_sysfs(tmp_path, cpu)
    stop = threading.Event()
    other = threading.Thread(target=stop.wait, daemon=True)  # a server thread running before `open`
    other.start()
    held = ClockCpu(cpu, sysfs=tmp_path).open()
    try:
        assert limit.read_text() == NO_IDLE
        assert held.kept_awake and held.isolated and held.note is None
        assert cpu not in affinity_of(other) and affinity_of(other) == ALLOWED - {cpu}
        assert cpu not in os.sched_getaffinity(0)  # this thread too: the clock's CPU is the clock's

        seen: dict[str, set[int]] = {}

        def clock_thread() -> None:
            held.pin()
            seen["clock"] = set(os.sched_getaffinity(0))
            # a thread the clock thread starts (a kernel's loading, a warm-up) moves off its CPU
            loader = OnceInBackground(lambda: seen.update(loader=set(os.sched_getaffinity(0))), "t")
            loader.wait(10)

        t = threading.Thread(target=clock_thread)
        t.start()
        t.join(10)
        assert seen["clock"] == {cpu} and held.pinned
        assert seen["loader"] == ALLOWED - {cpu}
        assert held.status() == {
            "cpu": cpu,
            "pinned": True,
            "isolated": True,
            "kept_awake": True,
            "note": None,
        }
        held.close()
        assert limit.read_text() == "0"  # the old limit back
        assert affinity_of(other) == ALLOWED and set(os.sched_getaffinity(0)) == ALLOWED
        assert not held.kept_awake
    finally:
        held.close()  # (again, harmless: after a failed assertion above)
        stop.set()


@needs_two_cpus
def test_without_the_pm_qos_file_the_clock_still_gets_its_cpu_and_says_why_not_awake(tmp_path):
    cpu = max(ALLOWED)
    held = ClockCpu(cpu, sysfs=tmp_path / "missing").open()
    try:
        assert not held.kept_awake and held.isolated
        assert held.note is not None and f"CPU {cpu} is not kept awake" in held.note
    finally:
        held.close()
    assert set(os.sched_getaffinity(0)) == ALLOWED


@needs_two_cpus
def test_a_cpu_another_server_keeps_awake_is_left_to_it(tmp_path):
    """Two servers on one CPU: the second neither takes the limit over nor restores it later (which
    would leave the CPU polling after the first put its old limit back)."""
    cpu = max(ALLOWED)
    limit = fake_sysfs(tmp_path, cpu, NO_IDLE)
    held = ClockCpu(cpu, sysfs=tmp_path).open()
    try:
        assert not held.kept_awake and held.note is not None and "another process" in held.note
    finally:
        held.close()
    assert limit.read_text() == NO_IDLE  # still the other server's


@needs_two_cpus
@pytest.mark.parametrize("end", ["exit", "kill"])
def test_the_old_limit_comes_back_however_the_server_ends(tmp_path, end):
    """A crash or kill -9 never leaves a CPU polling for good: the guardian puts the old limit back."""
    cpu = max(ALLOWED)
    limit = fake_sysfs(tmp_path, cpu, "25")
    script = textwrap.dedent(
        f"""
        import os, sys, time
        from pathlib import Path
        from backend.engine.clock_cpu import ClockCpu
        held = ClockCpu({cpu}, sysfs=Path({str(tmp_path)!r})).open()
        print(held.kept_awake, flush=True)
        if {end!r} == "exit":
            os._exit(3)  # no close(), no atexit: as a crash
        time.sleep(60)
        """
    )
    proc = subprocess.Popen(
        [sys.executable, "-c", script], cwd=ROOT, stdout=subprocess.PIPE, text=True,
        env={**os.environ, "PYTHONPATH": str(ROOT)},
    )  # fmt: skip
    assert proc.stdout is not None and proc.stdout.readline().strip() == "True"
    assert limit.read_text() == NO_IDLE
    if end == "kill":
        proc.send_signal(signal.SIGKILL)
    proc.wait(30)
    deadline = time.monotonic() + 10
    while limit.read_text() != "25" and time.monotonic() < deadline:
        time.sleep(0.05)
    assert limit.read_text() == "25"


@needs_two_cpus
def test_the_engine_clock_moves_to_its_cpu_and_status_reports_it(tmp_path):
    cpu = max(ALLOWED)
    fake_sysfs(tmp_path, cpu)
    session = EngineSession.create(load_embodiment("nutty_desk"), rate=100)
    engine = session.engine
    assert engine.clock_priority is not None
    assert engine.stats()["clock_cpu"] is None  # not asked for: the OS places the clock
    engine.clock_priority.cpu = held = ClockCpu(cpu, sysfs=tmp_path).open()
    try:
        engine.start()
        deadline = time.monotonic() + 10
        while engine.ticks < 5 and time.monotonic() < deadline:
            time.sleep(0.02)
        clock = engine._thread
        assert clock is not None and affinity_of(clock) == {cpu}
        assert engine.stats()["clock_cpu"] == held.status()
        assert engine.stats()["clock_cpu"]["pinned"] is True
    finally:
        engine.close()
        held.close()


def test_serve_refuses_a_clock_cpu_it_cannot_have_before_loading_anything():
    from backend.commands.serve import check_options

    args = SimpleNamespace(
        host="127.0.0.1", token=None, shutdown_timeout=5.0, unsafe_no_limits=False, clock_cpu="9999",
        ros2=False,
    )  # fmt: skip
    problem = check_options(args)
    assert problem is not None and "--clock-cpu" in problem


@pytest.mark.server
@needs_two_cpus
def test_nutty_serve_runs_its_clock_on_its_own_cpu_and_gives_the_cpu_back(tmp_path):
    """The real server: the clock thread alone on the CPU /api/status names, and that CPU's idle limit
    as it was once the server has stopped (kept awake only where the machine lets it: root, /sys
    writable; else the status says why)."""
    from server_process import server_process

    cpu = max(ALLOWED)
    limit = clock_cpu.SYSFS_CPUS / f"cpu{cpu}" / "power" / "pm_qos_resume_latency_us"
    before = limit.read_text().strip() if limit.exists() else None
    with server_process("--no-previz", "--clock-cpu", "auto") as srv:
        own = httpx.get(f"{srv.url}/api/status", timeout=10).json()["clock_cpu"]
        assert own["cpu"] == cpu and own["pinned"] and own["isolated"]
        assert own["kept_awake"] or own["note"]
        if own["kept_awake"]:
            assert limit.read_text().strip() == NO_IDLE
        tasks = Path(f"/proc/{srv.proc.pid}/task")
        on_cpu = []
        for task in tasks.iterdir():
            with contextlib.suppress(FileNotFoundError, ProcessLookupError):
                allowed = os.sched_getaffinity(int(task.name))
                if cpu in allowed:
                    on_cpu.append((task / "comm").read_text().strip() if allowed == {cpu} else "shared")
        assert len(on_cpu) == 1 and on_cpu[0] != "shared", on_cpu  # the clock thread, alone on it
    if before is not None:
        deadline = time.monotonic() + 10
        while limit.read_text().strip() != before and time.monotonic() < deadline:
            time.sleep(0.05)
        assert limit.read_text().strip() == before
