// The preview's timing, pure (tested): which rendered events fire as the playhead moves from one time
// to the next, which sounds are already under way when a preview starts mid-behaviour, the pose of the
// frame at a time, and the audio each event needs.
import type { Rendered, RenderEvent } from "./behaviourApi";

export type PoseValues = Record<string, number | string | number[]>;

/** Events due while the playhead moves from `from` to `to`: from <= t < to (a tick's end is the next
 * tick's start, so each event fires once). */
export function eventsBetween(events: readonly RenderEvent[], from: number, to: number): RenderEvent[] {
  return events.filter((e) => e.t >= from && e.t < to);
}

/** Audio events started before `t` and still sounding at it, with how far into them `t` is: a preview
 * started mid-behaviour picks them up part-way, as the robot would be heard. */
export function soundingAt(events: readonly RenderEvent[], t: number): { event: RenderEvent; offset: number }[] {
  return events
    .filter((e) => audioUrl(e) !== null && e.t < t && t < e.t + (e.payload.duration ?? 0))
    .map((event) => ({ event, offset: t - event.t }));
}

/** The sound file an event plays (a sound, or recorded speech), or null. */
export function audioUrl(e: RenderEvent): string | null {
  if (e.kind !== "sound" && e.kind !== "say") return null;
  return typeof e.payload.url === "string" ? e.payload.url : null;
}

/** Text the browser speaks for a say without a recording, or null. */
export function spokenText(e: RenderEvent): string | null {
  return e.kind === "say" && !audioUrl(e) && typeof e.payload.text === "string" ? e.payload.text : null;
}

/** Every distinct audio URL of a render (to preload before the playhead starts). */
export function audioUrls(r: Pick<Rendered, "events">): string[] {
  return [...new Set(r.events.map(audioUrl).filter((u): u is string => u !== null))];
}

const isPoseValue = (v: unknown): v is number | string | number[] =>
  typeof v === "number" || typeof v === "string" || (Array.isArray(v) && v.every((x) => typeof x === "number"));

/** The pose of the rendered frame at `t` (the nearest frame, clamped to the render), or null. */
export function frameAt(r: Pick<Rendered, "rate" | "dofs" | "frames">, t: number): PoseValues | null {
  if (!r.frames.length) return null;
  const k = Math.min(r.frames.length - 1, Math.max(0, Math.round(t * r.rate)));
  const frame = r.frames[k];
  const out: PoseValues = {};
  r.dofs.forEach((dof, i) => {
    const v = frame[i];
    if (isPoseValue(v)) out[dof] = v;
  });
  return out;
}
