"""The fixed-rate runtime: a clock that ticks the APU and fans Animation Frames out to sinks.

- One AF per tick at a steady rate (30-1000 Hz), whatever the timing of inputs.
- Inputs (commands, exposed inputs, program swaps) are queued thread-safely and applied at tick
  boundaries, in the clock thread, so blocks never see a half-applied change.
- Sinks (drivers) each get frames through their own bounded queue and thread: a slow sink drops
  frames (counted) and never stalls the clock.
- Headless mode (`run_ticks`) steps as fast as possible with the same semantics, for `nutty run`.
- Every frame passes the engine's safety net (backend/engine/safety.py) last: no program, swap or
  shutdown can move a DoF beyond its position, velocity, acceleration or jerk limits. A swap also
  blends the jump between the last output and the new program's out over a short transition.
- Under CPU contention the clock *stretches* time rather than bursting to catch up: frames come
  late, so the robot moves slower, never faster. Ticks that should have run are counted as lost.
- The clock loop reads time and waits through a `Clock` (default `WallClock`); another clock, e.g.
  a simulated one in tests, drives the same loop without real sleeps.
"""

from __future__ import annotations

import logging
import threading
import time
from collections.abc import Callable
from concurrent.futures import Future
from queue import SimpleQueue
from typing import Any

import numpy as np

from backend.engine import clock_loop, parking, runtime_stats, warm_up
from backend.engine.apu import APU, MAX_LEVEL, LevelError
from backend.engine.blocks.base import BlockContext

# The clock and the sinks live in their own modules; they are re-exported here, where callers import them.
from backend.engine.clock import Clock, RingStats, SampledCpu, WallClock
from backend.engine.compiled import default_compiled
from backend.engine.embodiment import Embodiment
from backend.engine.frame_tail import FrameTail
from backend.engine.frames import AnimationFrame
from backend.engine.gil import ClockPriority
from backend.engine.pending import Pending, drain
from backend.engine.profile import WINDOW, CookTimes, sample_every
from backend.engine.safety import SafetyNet
from backend.engine.sinks import FanOut, Sink
from backend.engine.tick_hooks import TickHooks
from backend.engine.transition import Transition
from backend.logs import Throttle

MIN_RATE, MAX_RATE = 30.0, 1000.0

log = logging.getLogger(__name__)
_faults = Throttle(every=10.0)  # a faulty block or listener fails on every tick: logged once per 10 s

__all__ = ["MAX_RATE", "MIN_RATE", "Clock", "Engine", "RingStats", "Sink", "WallClock"]


class Engine:
    """Runs an APU on an embodiment at a fixed rate and emits Animation Frames.

    rate: ticks per second, 30..1000. max_level: the highest APU level accepted (0..3).
    clock: what the running clock (`start()`) reads time from and waits on (default: a `WallClock`).
    compiled: blocks use their compiled kernels (False: their numpy references; default: True unless
    the environment sets NUTTY_REFERENCE=1, see backend.engine.compiled).
    priority: while the clock runs, other threads hand the interpreter lock over quickly and the clock
    thread runs at a higher priority where the OS permits (backend.engine.gil.ClockPriority).
    """

    def __init__(
        self,
        embodiment: Embodiment,
        rate: float = 100.0,
        max_level: int = MAX_LEVEL,
        resources: Any = None,
        seed: int = 0,
        safety: bool = True,
        clock: Clock | None = None,
        compiled: bool | None = None,
        priority: bool = True,
    ):
        if not (isinstance(rate, (int, float)) and MIN_RATE <= rate <= MAX_RATE):
            raise ValueError(f"rate must be within [{MIN_RATE:g}, {MAX_RATE:g}] Hz, got {rate}")
        if max_level not in (0, 1, 2, 3):
            raise ValueError(f"max_level must be 0, 1, 2 or 3, got {max_level}")
        self.embodiment = embodiment
        self.rate = float(rate)
        self.dt = 1.0 / self.rate
        self.max_level = max_level
        self.clock: Clock = clock if clock is not None else WallClock(spin=min(0.0003, self.dt / 10))
        self.ctx = BlockContext(
            embodiment=embodiment,
            rate=self.rate,
            resources=resources,
            seed=seed,
            compiled=default_compiled() if compiled is None else bool(compiled),
        )
        self.apu: APU | None = None
        self.seq = 0
        self.t = 0.0
        self._pending: SimpleQueue[Pending] = SimpleQueue()
        self._sinks: list[Sink] = []
        self._sinks_lock = threading.Lock()
        self._fan_out: FanOut | None = None  # the sinks' one hand-over per tick (from the first sink on)
        self._listeners: list[Callable[[dict[str, Any]], None]] = []
        self._observers: list[Callable[[AnimationFrame], None]] = []  # see add_frame_observer
        self._event_observers: list[Callable[[AnimationFrame], None]] = []  # (events only)
        self.hooks = TickHooks()  # see add_tick_hook
        #: what carries each tick's events on (e.g. sounds get their file's URL); see set_event_stamp
        self._stamp: Callable[[list, float], list] | None = None
        self._ticking: int | None = None  # the thread inside `tick` (calls from it run at once)
        self._pos = embodiment.rest.copy()
        self._vel = np.zeros(embodiment.n_channels)
        self._acc = np.zeros(embodiment.n_channels)
        self.last_frame: AnimationFrame | None = None
        self.tick_cost = RingStats()
        self.tick_cpu = RingStats()  # the clock thread's CPU time in a tick (tick_cost minus waits), sampled
        self.started_at: float | None = None  # wall-clock time (s since the epoch) the clock first started
        self.period = RingStats()
        self.lateness = RingStats()
        self.ticks = 0
        self.overruns = 0
        self.lost_ticks = 0
        self.recent_overruns = runtime_stats.overrun_ring()  # the last overruns: when, how late, how long
        self.swaps = 0
        #: The last step before every sink; `safety=False` only through an explicit, logged opt-out.
        self.safety = SafetyNet(embodiment, self.rate, enabled=safety)
        self._transition: Transition | None = None
        self._injected: list = []  # events added by commands for the next frame
        self._override_mask = np.zeros(embodiment.n_channels, dtype=bool)  # display values set by commands
        self._override_values = np.zeros(embodiment.n_channels)
        #: The running clock's claim on the interpreter lock and the CPU (None: none; see backend.engine.gil).
        self.clock_priority: ClockPriority | None = ClockPriority() if priority else None
        #: Ticks between two timed ticks of the program's cook times (1: every tick, for `nutty run --profile`).
        self.profile_every, self.profile_window = sample_every(self.rate), WINDOW
        self._cpu = SampledCpu(self.tick_cpu, self.profile_every)
        self._overriding = False  # whether any channel is overridden (so a tick need not look)
        #: The net and the frame's derivatives (one compiled call on a plain tick: backend/engine/frame_tail.py).
        self.tail = FrameTail(self.safety, self.ctx.compiled)
        self._thread: threading.Thread | None = None
        self._stop = threading.Event()
        self.tick_lock = threading.Lock()  # held for a whole tick: readers of live frames take it too

    # --- inputs (thread-safe; applied at the next tick boundary) ---------------------------------
    def call_soon(self, fn: Callable[[], Any]) -> Future:
        """Run `fn` in the clock thread at the next tick boundary; the Future gets its result or error."""
        fut: Future = Future()
        self._pending.put(Pending(fn, fut))
        return fut

    def call(self, fn: Callable[[], Any], timeout: float = 10.0) -> Any:
        """`call_soon` and wait. When the clock is not running, runs `fn` at once (under the tick lock).

        `timeout` (s) only bounds a wait on a clock that is stuck: the next tick boundary normally comes
        within one period, but a machine under heavy load can hold the clock thread off for a while.
        Called from inside a tick or another call (a tick hook, a listener, a command a behaviour runs),
        `fn` runs at once: that thread holds the tick lock already."""
        if self._ticking == threading.get_ident():
            return fn()
        if not self.running:
            with self.tick_lock:
                self._ticking = threading.get_ident()
                try:
                    drain(self._pending)
                    return fn()
                finally:
                    self._ticking = None
        return self.call_soon(fn).result(timeout)

    def load(
        self,
        apu: APU | None,
        *,
        adopt: bool = True,
        transition: float | None = None,
        also: Callable[[], Any] | None = None,
    ) -> list[str]:
        """Swap in a compiled program at a tick boundary (the only way a program is swapped).

        adopt: blocks keeping id and type keep their state. transition: seconds over which the jump
        between the last output and the new program's is blended out (None: as short as the robot's
        limits allow; 0: none — the safety net still bounds the motion). `apu=None` runs no program:
        the robot goes to its rest pose. `also` runs in the same tick boundary (e.g. installing the
        program's inputs), so no tick runs the new program without it.
        Raises LevelError (changing nothing) if the program needs a level above `max_level`.
        Returns the ids of the blocks that kept their state, once the swap is done.
        """
        return self.call(self._swap(apu, adopt, transition, also))

    def load_soon(
        self,
        apu: APU | None,
        *,
        adopt: bool = True,
        transition: float | None = None,
        also: Callable[[], Any] | None = None,
    ) -> Future:
        """`load` without waiting: the swap happens at the next tick boundary; a Future of the kept ids."""
        return self.call_soon(self._swap(apu, adopt, transition, also))

    def _swap(
        self, apu: APU | None, adopt: bool, transition: float | None, also: Callable[[], Any] | None
    ) -> Callable[[], list[str]]:
        """The checked swap, to run at a tick boundary (LevelError/ValueError at once, changing nothing)."""
        if apu is not None:
            if apu.level > self.max_level:
                raise LevelError(
                    f"program needs APU level {apu.level} but this engine allows at most {self.max_level}"
                )
            if apu.steps and apu.steps[apu.output].block.emb is not self.embodiment:
                raise ValueError("program was compiled for another embodiment")

        def swap() -> list[str]:
            kept = (
                apu.adopt_state_from(self.apu) if (adopt and apu is not None and self.apu is not None) else []
            )
            if apu is not None:
                runtime_stats.retime(apu, self.profile_every, self.profile_window)
            self.apu = apu
            self.swaps += 1
            if also is not None:
                also()
            if self.seq:  # nothing has been sent yet: the safety net alone starts from rest
                self._transition = Transition.start(
                    self.embodiment, self._pos, self._vel, self.rate, transition
                )
            return kept

        return swap

    def start_from(
        self, position: np.ndarray, joints: np.ndarray | None = None, seconds: float | None = None
    ) -> None:
        """Before the first tick: the robot stands at `position` (C,) with its joints at `joints` (over
        `joint_names`, NaN: not measured; backend.engine.start_pose). The first frames blend from there
        to the program over at least `seconds` (None: as fast as the limits allow), within every limit."""
        if self.seq:
            raise RuntimeError("start_from is for an engine that has not ticked yet")
        self.safety.reset(position, joints)
        self._pos = np.array(position, dtype=float)
        self.tail.restart(self._pos)
        self._transition = Transition.start(
            self.embodiment, self._pos, np.zeros_like(self._pos), self.rate, seconds
        )

    def park(self, timeout: float = 3.0) -> dict[str, Any]:
        """Bring the robot to its exact rest pose within its limits (`backend.engine.parking.park`)."""
        return parking.park(self, timeout)

    def at_rest(self) -> bool:
        """Whether the last frame is the rest pose exactly, standing still, with no program running."""
        return parking.at_rest(
            self.apu, self._transition, self.seq, self._pos, self._vel, self._acc, self.embodiment
        )

    @property
    def position(self) -> np.ndarray:
        """The last frame's channel values (what the robot was last sent; a copy)."""
        return self._pos.copy()

    def set_input(self, name: str, value: Any) -> Future:
        """Set an exposed input at the next tick boundary."""
        return self.call_soon(lambda: self.ctx.inputs.__setitem__(name, value))

    def inject_event(self, event) -> Future:
        """Emit a FrameEvent (speech, sound) on the next frame, without a block."""
        return self.call_soon(lambda: self._injected.append(event))

    def set_override(self, mask: np.ndarray, values: np.ndarray) -> None:
        """Hold some channels (display DoFs set by a command) at fixed values on top of the program.
        Call in the clock thread (via `call`)."""
        self._override_mask = self._override_mask | mask
        self._override_values = np.where(mask, values, self._override_values)
        self._overriding = bool(self._override_mask.any())

    def release_override(self, mask: np.ndarray) -> None:
        """Give the channels of `mask` back to the program (clock thread)."""
        self._override_mask = self._override_mask & ~mask
        self._overriding = bool(self._override_mask.any())

    def clear_overrides(self) -> None:
        self._override_mask = np.zeros_like(self._override_mask)
        self._overriding = False

    def add_listener(self, fn: Callable[[dict[str, Any]], None]) -> None:
        """Receive block notifications (clip started/completed, …) from the clock thread; keep it quick."""
        self._listeners.append(fn)

    def add_tick_hook(self, fn: Callable[[float], Any]) -> None:
        """Call `fn(t)` on the clock thread as every tick starts, after queued inputs, with the time (s) of
        the frame it is about to make: what a hook starts shows in that frame. Quick; an exception is
        logged (throttled) and the tick goes on. `fn` may return `IDLE` (backend/engine/tick_hooks.py)."""
        self.hooks.add(fn)

    def wake_tick_hook(self, fn: Callable[[float], Any]) -> None:
        """Call a hook that returned `IDLE` again from the next tick (from any thread)."""
        self.call(lambda: self.hooks.wake(fn))

    def set_event_stamp(self, fn: Callable[[list, float], list] | None) -> None:
        """`fn(events, t)` returns a tick's events as they go out (called only on ticks with events)."""
        self._stamp = fn

    def add_frame_observer(self, fn: Callable[[AnimationFrame], None], events_only: bool = False) -> None:
        """Call `fn(frame)` on the clock thread after every frame's notes (`events_only`: only frames with
        events); it must be quick and not raise."""
        (self._event_observers if events_only else self._observers).append(fn)

    # --- sinks ----------------------------------------------------------------------------------
    def add_sink(self, sink: Sink) -> Sink:
        """Feed `sink` every frame from the next tick on (through the fan-out's thread: sinks.FanOut)."""
        with self._sinks_lock:
            if self._fan_out is None:
                self._fan_out = FanOut(lambda: self._sinks)
            self._sinks = [*self._sinks, sink]
        return sink

    def remove_sink(self, sink: Sink) -> None:
        """Stop feeding `sink` once it has had every frame made so far, then close it."""
        if self._fan_out is not None:
            self._fan_out.flush()
        with self._sinks_lock:
            self._sinks = [s for s in self._sinks if s is not sink]
        sink.close(timeout=0.5)

    def fan_out_stats(self) -> dict[str, Any] | None:
        """The fan-out's counts (`Sink.stats`; None before the first sink)."""
        fan_out = self._fan_out
        return None if fan_out is None else fan_out.stats()

    def flush_sinks(self, timeout: float = 2.0) -> bool:
        """Wait until every frame made so far has been offered to the sinks (their own queues may still
        hold it); whether that happened within `timeout` s."""
        return self._fan_out is None or self._fan_out.flush(timeout)

    @property
    def sinks(self) -> list[Sink]:
        return list(self._sinks)

    # --- ticking --------------------------------------------------------------------------------
    def tick(self) -> AnimationFrame:
        """Apply queued inputs, run the program once, pass the safety net and emit one Animation Frame."""
        with self.tick_lock:
            cpu = self._cpu
            cpu.due -= 1  # (`SampledCpu.start` only on a tick due to be read: a plain tick makes no call)
            t0 = time.perf_counter()
            cpu0 = -1.0 if cpu.due > 0 else cpu.start(None if self.apu is None else self.apu.plain_next)
            self._ticking = threading.get_ident()
            try:
                return self._tick(t0, cpu0)
            finally:
                self._ticking = None

    def _tick(self, t0: float, cpu0: float) -> AnimationFrame:
        if self.seq == 1:  # code the clock reaches now and then, loaded beside it (warm_up.py)
            warm_up.start()
        if not self._pending.empty():  # (most ticks: nothing queued)
            drain(self._pending)
        if self.hooks.awake:
            self.hooks.run(self.t)
        dt = self.dt
        if self.apu is not None:
            try:
                final, stage1, events = self.apu.tick(dt)
            except Exception as exc:  # a faulty block holds the last pose rather than killing the clock
                message = f"{type(exc).__name__}: {exc}"
                self._notify({"event": "error", "message": message})
                skipped = _faults.due(type(exc).__name__)
                if skipped is not None:
                    again = f" ({skipped} more of its kind since the last report)" if skipped else ""
                    log.error("a block failed; holding the last pose: %s%s", message, again, exc_info=exc)
                final, stage1, events = self._pos, self._pos, []
        else:
            final, stage1, events = self.embodiment.rest, self.embodiment.rest, []
        requested = self._requested(final) if self._overriding or self._transition is not None else None
        last = (self._pos, self._vel, self._acc)
        program, target, pos, vel, acc, jerk, stage1 = self.tail.run(
            final, stage1, last, dt, self.seq, requested
        )
        if self._injected:
            events, self._injected = [*events, *self._injected], []
        if events and self._stamp is not None:
            events = self._stamp(events, self.t)
        self._pos, self._vel, self._acc = pos, vel, acc
        frame = AnimationFrame(
            embodiment=self.embodiment.name,
            t=self.t,
            dt=dt,
            seq=self.seq,
            position=pos,
            velocity=vel,
            acceleration=acc,
            jerk=jerk,
            events=list(events),
            stage1=stage1,
            corrected=self.safety.corrected.copy() if self.safety.corrected_any else None,
            program=program,
            joints=self.safety.joint_out,
            requested=target,
            made=time.time(),
        )
        if frame.corrected is not None:
            self.tail.explain(frame)  # what the net changed, and which limits
        self.last_frame = frame
        self.seq += 1
        self.t = self.seq * dt
        self.ticks += 1
        if self.ctx.events:
            notes, self.ctx.events = self.ctx.events, []
            for note in notes:
                self._notify(note)
        for fn in (*self._observers, *self._event_observers) if frame.events else self._observers:
            fn(frame)
        fan_out = self._fan_out
        if fan_out is not None and self._sinks:
            fan_out.offer(frame)
        self.tick_cost.add(time.perf_counter() - t0)
        if cpu0 >= 0.0:
            self._cpu.stop(cpu0)
        return frame

    def _requested(self, final: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        """The program's frame with the overridden channels set (program), then the swap transition
        applied (what the net is handed): new arrays."""
        program = np.array(final, dtype=float)
        if self._overriding:
            np.copyto(program, self._override_values, where=self._override_mask)
        target = program
        if self._transition is not None:
            target = program.copy()
            if self._transition.apply(target):
                self._transition = None
        return program, target

    def _notify(self, note: dict[str, Any]) -> None:
        for fn in self._listeners:
            try:
                fn(note)
            except Exception as exc:  # a listener's bug must not stop the clock or the other listeners
                skipped = _faults.due(f"listener {fn!r}: {type(exc).__name__}")
                if skipped is not None:
                    log.error("an engine listener failed on a %r note", note.get("event"), exc_info=exc)

    def run_ticks(self, n: int) -> list[AnimationFrame]:
        """Headless: run `n` ticks as fast as possible (no sleeping) and return the frames."""
        return [self.tick() for _ in range(n)]

    # --- the clock --------------------------------------------------------------------------------
    @property
    def running(self) -> bool:
        return self._thread is not None and self._thread.is_alive()

    def start(self) -> None:
        if self.running:
            return
        self._stop.clear()
        self._thread = threading.Thread(target=self._clock, name="nutty-clock", daemon=True)
        self._thread.start()

    def stop(self, timeout: float = 2.0) -> None:
        self._stop.set()
        if self._thread is not None:
            self._thread.join(timeout)
        self._thread = None

    def close(self) -> None:
        """Stop the clock and close every sink (delivering every frame made)."""
        self.stop()
        fan_out, self._fan_out = self._fan_out, None  # (a sink added later makes a new one)
        if fan_out is not None:
            fan_out.close()
        for sink in self.sinks:
            sink.close()

    def _clock(self) -> None:
        priority = self.clock_priority
        if priority is not None:
            priority.apply()
        try:
            clock_loop.run(self, self._stop)
        finally:
            if priority is not None:
                priority.restore()

    def set_profiling(self, every: int, window: int = WINDOW) -> None:
        """Time one tick in `every` block by block, keeping the last `window` timed ticks (for this
        program and the ones loaded after it). `nutty run --profile` times every tick."""
        self.profile_every, self.profile_window = int(every), int(window)
        self.call(lambda: runtime_stats.retime(self.apu, self.profile_every, self.profile_window))

    def reset_stats(self) -> None:
        """Start a new measurement window: tick cost, period, lateness and the program's cook times
        forget their samples (the counters of ticks, overruns and lost ticks go on)."""
        runtime_stats.reset(self)

    def profile(self) -> dict[str, Any]:
        """Per-node cook times of the running program (`backend.engine.profile.CookTimes.summary`)."""
        return (self.apu.cook if self.apu is not None else CookTimes([], [])).summary()

    def stats(self) -> dict[str, Any]:
        """The clock's statistics (`backend.engine.runtime_stats.engine_stats`)."""
        return runtime_stats.engine_stats(self)
