// What the editor keeps of the telemetry stream: the live value and short history of every
// subscribed output, the mixers' layer states, and the last seconds of frames for the curve panel.
// Pure functions of the previous state and one message (tested with vitest).
import type { LayerState, Profile, SignalRef, Telemetry, TelemetrySubscribe } from "./api";

export const TELEMETRY_HZ = 30;
export const CURVE_SECONDS = 8;
const SPARKLINE_POINTS = 60;

export interface Live {
  values: Record<string, unknown>;
  history: Record<string, number[]>;
  layers: Record<string, LayerState[]>;
  /** The engine time of the last message (s). */
  t: number;
  /** The last per-node cook times (they come about once a second). */
  profile: Profile | null;
}

export interface Samples {
  t: number[];
  final: Record<string, number[]>;
  stage1: Record<string, number[]>;
  /** The server's classification of each sampled frame (exact, from the full-rate frames). */
  classes: Record<string, number>[];
}

export const emptyLive: Live = { values: {}, history: {}, layers: {}, t: 0, profile: null };
export const emptySamples: Samples = { t: [], final: {}, stage1: {}, classes: [] };

export function subscription(signals: SignalRef[]): TelemetrySubscribe {
  return { type: "subscribe", signals, frames: true, rate: TELEMETRY_HZ };
}

/** A number to plot for a signal value: the number itself, or a frame's first channel. */
function plottable(v: unknown): number | undefined {
  if (typeof v === "number") return v;
  if (v && typeof v === "object" && "values" in v) return Object.values((v as { values: Record<string, number> }).values)[0];
  return undefined;
}

export function nextLive(prev: Live, msg: Telemetry): Live {
  const history = { ...prev.history };
  for (const [k, v] of Object.entries(msg.signals ?? {})) {
    const num = plottable(v);
    if (typeof num === "number") history[k] = [...(history[k] ?? []).slice(-(SPARKLINE_POINTS - 1)), num];
  }
  return { values: msg.signals ?? {}, history, layers: msg.layers ?? {}, t: msg.t, profile: msg.profile ?? prev.profile };
}

const appended = <T,>(list: T[], item: T, keep: number) => [...list.slice(-keep + 1), item];

function appendAll(prev: Record<string, number[]>, values: Record<string, number>, keep: number) {
  const out = { ...prev };
  for (const [k, v] of Object.entries(values)) out[k] = appended(out[k] ?? [], v, keep);
  return out;
}

export function nextSamples(prev: Samples, msg: Telemetry, keep = CURVE_SECONDS * TELEMETRY_HZ): Samples {
  if (!msg.frame) return prev;
  return {
    t: appended(prev.t, msg.t, keep),
    final: appendAll(prev.final, msg.frame.position, keep),
    stage1: appendAll(prev.stage1, msg.frame.stage1, keep),
    classes: appended(prev.classes, msg.frame.classes ?? {}, keep),
  };
}
