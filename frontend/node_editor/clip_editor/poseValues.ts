// What the engine plays of a clip at a time, as a pose: continuous DoFs the curve (plus the rest value
// when the clip is relative), enum DoFs the option name, colours [r, g, b]. The same rules as
// backend/engine/clips.py compile_clip, through the model's exact curve port. Pure (tested).
import { evaluateKeys, numericKeys } from "./model/curve";
import type { Clip, DofInfo, Keyframe } from "./model/types";
import type { PoseValues } from "./clipApi";

const clamp01 = (x: number) => Math.min(1, Math.max(0, x));

/** One DoF's played value at `t`, or null when the track has no keys. */
export function valueAt(doc: Clip, dof: DofInfo, keys: Keyframe[], t: number): Keyframe["v"] | null {
  if (!keys.length) return null;
  const channels = numericKeys(keys, dof);
  if (dof.type === "colour") return channels.map((c) => clamp01(evaluateKeys(c, t)));
  const x = evaluateKeys(channels[0], t);
  if (dof.type === "enum") {
    const options = dof.options ?? [];
    if (!options.length) return null;
    return options[Math.min(options.length - 1, Math.max(0, Math.round(x)))];
  }
  return doc.relative ? x + dof.rest : x;
}

/** The pose the clip plays at `t` for every track the robot has a DoF for. */
export function poseAt(doc: Clip, dofs: ReadonlyMap<string, DofInfo>, t: number): PoseValues {
  const out: PoseValues = {};
  for (const [name, keys] of Object.entries(doc.tracks)) {
    const dof = dofs.get(name);
    if (!dof) continue;
    const v = valueAt(doc, dof, keys, t);
    if (v !== null) out[name] = v;
  }
  return out;
}

/** A continuous track's played values at `times` (the test hook's `sample`); NaN for a missing track. */
export function sampleTrack(doc: Clip, dof: DofInfo | undefined, name: string, times: number[]): number[] {
  const keys = doc.tracks[name];
  if (!keys?.length) return times.map(() => Number.NaN);
  const info: DofInfo = dof ?? { name, type: "continuous", min: -Infinity, max: Infinity, rest: 0, velocity: 0, group: "" };
  const channel = numericKeys(keys, info)[0];
  const rest = doc.relative && info.type === "continuous" ? info.rest : 0;
  return times.map((t) => evaluateKeys(channel, t) + rest);
}

/** The preview's label: "<clip> @ 1.23 s". */
export const previewLabel = (name: string, t: number): string => `${name} @ ${t.toFixed(2)} s`;

/** Whether two poses are the same (so an unchanged pose is not sent again before its keep-alive). */
export function samePose(a: PoseValues | null, b: PoseValues | null): boolean {
  if (a === b) return true;
  if (!a || !b) return false;
  const ka = Object.keys(a);
  if (ka.length !== Object.keys(b).length) return false;
  return ka.every((k) => JSON.stringify(a[k]) === JSON.stringify(b[k]));
}

/** A DoF's slider range: its limits, or rest ± π (rad) on a side without one. */
export function sliderRange(d: Pick<DofInfo, "min" | "max" | "rest">): [number, number] {
  const min = Number.isFinite(d.min) ? d.min : d.rest - Math.PI;
  const max = Number.isFinite(d.max) ? d.max : d.rest + Math.PI;
  return [min, max];
}
