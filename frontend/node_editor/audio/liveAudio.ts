// The live robot's speech and sounds, heard in the browser in step with the motion the editor shows:
// telemetry lists each frame's events for a couple of seconds (every message repeats them, as a sampled
// stream can skip frames), so each event is played once, identified by its frame's seq and index.
// An event arrives a little after its frame (the stream's rate, the network); a sound then starts that
// far into itself (plus the audio output's own delay), so what is heard lines up with what is seen.
import { audioRunning, isMuted, loadSound, outputLatency, playBuffer, speak } from "./soundPlayer";

/** An event as telemetry lists it (FrameEventEntry). */
export interface LiveEvent {
  seq: number;
  index: number;
  t: number;
  dof: string;
  kind: string;
  payload: { [k: string]: unknown };
}

/** Events this much older than the newest frame are not started (e.g. those listed when a page opens). */
export const STALE_SECONDS = 0.5;
const SEEN_MAX = 512;

/** Where the engine's frame time stands against the page's clock, from telemetry arrivals. */
export interface EngineClock {
  /** performance.now()/1000 minus frame time, at the latest message */
  offset: number;
}

const seen = new Set<string>();
const clock: EngineClock = { offset: NaN };
/** (frame time, arrival in ms) of recent messages: the browser tests read it to measure the sync */
const arrivals: [number, number][] = [];
(globalThis as { __nuttyTelemetryArrivals?: [number, number][] }).__nuttyTelemetryArrivals = arrivals;

/** The engine's frame time now, as far as the page can tell (s). */
export function engineNow(): number {
  return performance.now() / 1000 - clock.offset;
}

/** Which of `events` have not been handled yet (and mark them handled). */
export function fresh(events: readonly LiveEvent[], done: Set<string> = seen): LiveEvent[] {
  const out = events.filter((e) => !done.has(`${e.seq}:${e.index}`));
  for (const e of out) done.add(`${e.seq}:${e.index}`);
  if (done.size > SEEN_MAX) {
    const keep = [...done].slice(-SEEN_MAX / 2);
    done.clear();
    keep.forEach((k) => done.add(k));
  }
  return out;
}

/** Play the events of one telemetry message (frame time `t`) that are new and not stale. */
export function onTelemetry(t: number, events: readonly LiveEvent[] | null | undefined): void {
  const now = performance.now();
  clock.offset = now / 1000 - t;
  arrivals.push([t, now]);
  if (arrivals.length > 600) arrivals.splice(0, 300);
  if (!events?.length) return;
  for (const ev of fresh(events)) {
    if (t - ev.t > STALE_SECONDS || isMuted() || !audioRunning()) continue;
    void play(ev);
  }
}

async function play(ev: LiveEvent): Promise<void> {
  const p = ev.payload;
  const url = typeof p.url === "string" ? p.url : null;
  if (url) {
    const name = typeof p.sound === "string" ? p.sound : url;
    const buffer = await loadSound(url);
    // how far the engine has gone on since the event's frame, plus the speakers' delay
    playBuffer(buffer, name, engineNow() - ev.t + outputLatency(), ev.t);
  } else if (ev.kind === "say" && typeof p.text === "string") {
    speak(p.text, ev.t);
  }
}

/** Decode the robot's sounds ahead of time, so the first play of each is not late. */
export function preload(urls: readonly string[]): void {
  for (const url of urls) loadSound(url).catch(() => undefined);
}
