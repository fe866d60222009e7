// What the editor keeps of the telemetry stream: the live value and short history of every
// subscribed output, the mixers' layer states, the safety net's totals, and the last minute of frames
// for the curve panel (what the program asked, what the robot got, what the safety net changed, what the
// motors read when a driver reads them).
// Pure functions of the previous state and one message (tested with vitest).
import type { LayerState, NetTotals, Profile, SignalRef, Telemetry, TelemetrySubscribe } from "./api";

export const TELEMETRY_HZ = 30;
/** The frames the curve panel can pause on and scrub through (s). */
export const CURVE_SECONDS = 60;
const SPARKLINE_POINTS = 60;

export interface Live {
  values: Record<string, unknown>;
  history: Record<string, number[]>;
  layers: Record<string, LayerState[]>;
  /** The engine time of the last message (s). */
  t: number;
  /** The last per-node cook times (they come about once a second). */
  profile: Profile | null;
  /** The engine's safety net: its counts since the engine started (null: none sent, or a draft). */
  net: NetTotals | null;
}

/** Limit codes of the net's corrections (the trajectory-helper's classes, then position). */
export const LIMIT_CODE = { velocity: 1, acceleration: 2, jerk: 3, position: 4 } as const;

/** A series of the curve panel: a DoF's channel (`dof:<name>`) or an actuated joint (`joint:<name>`). */
export const dofKey = (name: string) => `dof:${name}`;
export const jointKey = (name: string) => `joint:${name}`;

export interface Samples {
  t: number[];
  /** Delivered (after the safety net) by series key (`dof:` channels and `joint:` joints). */
  final: Record<string, (number | null)[]>;
  /** What the program asked (before the net) by series key: the delivered value where the net passed it. */
  requested: Record<string, (number | null)[]>;
  /** The stage-1 pose (the ghost) by series key (DoFs only). */
  stage1: Record<string, (number | null)[]>;
  /** The server's classification of each sampled delivered frame (exact, from the full-rate frames). */
  classes: Record<string, number>[];
  /** Per sample, the net's corrections: series key -> [limit code (LIMIT_CODE), |requested - delivered|]. */
  net: Record<string, [number, number]>[];
  /** Read at the motors, by joint key, when a driver reads them (servos, a physics preview); null where
   * a sample had no reading (a gap: a missed read is not a position of zero). */
  measured: Record<string, (number | null)[]>;
  /** The tracking error at the motors (commanded - read) by joint key; null where not read. */
  error: Record<string, (number | null)[]>;
  /** Whether the motor was at its torque (or speed) limit, by joint key; null where no reading came. */
  saturated: Record<string, (boolean | null)[]>;
}

export const emptyLive: Live = { values: {}, history: {}, layers: {}, t: 0, profile: null, net: null };
export const emptySamples: Samples = {
  t: [], final: {}, requested: {}, stage1: {}, classes: [], net: [], measured: {}, error: {}, saturated: {},
};

export function subscription(signals: SignalRef[]): TelemetrySubscribe {
  return { type: "subscribe", signals, frames: true, rate: TELEMETRY_HZ };
}

/** A number to plot for a signal value: the number itself, or a frame's first channel. */
function plottable(v: unknown): number | undefined {
  if (typeof v === "number") return v;
  if (v && typeof v === "object" && "values" in v) return Object.values((v as { values: Record<string, number> }).values)[0];
  return undefined;
}

/** The live values: the histories are those of the subscribed signals only (a signal no longer
 * subscribed, e.g. of the running program while a draft is edited, keeps no sparkline). */
export function nextLive(prev: Live, msg: Telemetry): Live {
  const history: Record<string, number[]> = {};
  for (const [k, v] of Object.entries(msg.signals ?? {})) {
    const num = plottable(v);
    const before = prev.history[k] ?? [];
    history[k] = typeof num === "number" ? [...before.slice(-(SPARKLINE_POINTS - 1)), num] : before;
  }
  return {
    values: msg.signals ?? {}, history, layers: msg.layers ?? {}, t: msg.t, profile: msg.profile ?? prev.profile,
    net: msg.frame?.net_totals ?? prev.net,
  };
}

/** Append `value` to `list` (in place), dropping the oldest beyond `keep`. */
function push<T>(list: T[], value: T, keep: number) {
  list.push(value);
  if (list.length > keep) list.splice(0, list.length - keep);
}

/** Append each series' value of this sample (in place); a series first seen now starts with gaps, one
 * missing now gets a gap, so every series stays aligned with `t`. */
function pushAll<T>(series: Record<string, (T | null)[]>, values: Record<string, T | null>, n: number, keep: number) {
  for (const [k, v] of Object.entries(values)) {
    series[k] ??= new Array<T | null>(Math.max(0, Math.min(n, keep) - 1)).fill(null);
    push(series[k], v, keep);
  }
  for (const [k, list] of Object.entries(series)) if (!(k in values)) push(list, null, keep);
}

function keyed(values: Record<string, number>, key: (n: string) => string): Record<string, number> {
  const out: Record<string, number> = {};
  for (const [k, v] of Object.entries(values)) out[key(k)] = v;
  return out;
}

/** The samples with `msg`'s frame appended, keeping the last `keep`. The arrays are extended in place
 * (a minute of every series at 30 Hz would be copied 30 times a second otherwise): the result is a new
 * object; hold a `snapshot` to keep the samples as they are now. */
export function nextSamples(prev: Samples, msg: Telemetry, keep = CURVE_SECONDS * TELEMETRY_HZ): Samples {
  const frame = msg.frame;
  if (!frame) return prev;
  const s = prev === emptySamples ? snapshot(emptySamples) : { ...prev };
  push(s.t, msg.t, keep);
  const n = s.t.length;
  const delivered = { ...keyed(frame.position, dofKey), ...keyed(frame.joints ?? {}, jointKey) };
  const requested: Record<string, number | null> = { ...delivered };
  const net: Record<string, [number, number]> = {};
  const corrections = [
    ...Object.entries(frame.net?.channels ?? {}).map(([k, c]) => [dofKey(k), c] as const),
    ...Object.entries(frame.net?.joints ?? {}).map(([k, c]) => [jointKey(k), c] as const),
  ];
  for (const [key, c] of corrections) {
    requested[key] = c.requested;
    net[key] = [LIMIT_CODE[c.limit], c.amount];
  }
  pushAll(s.final, delivered, n, keep);
  pushAll(s.requested, requested, n, keep);
  pushAll(s.stage1, keyed(frame.stage1, dofKey), n, keep);
  push(s.classes, frame.classes ?? {}, keep);
  push(s.net, net, keep);
  const readings = Object.entries(msg.measured ?? {});
  pushAll(s.measured, Object.fromEntries(readings.map(([j, r]) => [jointKey(j), r.measured])), n, keep);
  pushAll(s.error, Object.fromEntries(readings.map(([j, r]) => [jointKey(j), r.error])), n, keep);
  pushAll(s.saturated, Object.fromEntries(readings.map(([j, r]) => [jointKey(j), r.saturated])), n, keep);
  return s;
}

/** A copy of the samples that later messages do not change (the curve panel's pause). */
export function snapshot(s: Samples): Samples {
  const copy = <T>(r: Record<string, T[]>) => Object.fromEntries(Object.entries(r).map(([k, v]) => [k, [...v]]));
  return {
    t: [...s.t], final: copy(s.final), requested: copy(s.requested), stage1: copy(s.stage1), classes: [...s.classes], net: [...s.net],
    measured: copy(s.measured), error: copy(s.error), saturated: copy(s.saturated),
  };
}
