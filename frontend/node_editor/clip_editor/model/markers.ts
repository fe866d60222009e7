// Markers (anchors and events), the clip's end, and a new clip. Marker edits leave the keys (and so the
// key selection) alone, so they return just the new document: the caller pairs it with its selection.
import { clampTime } from "./snap";
import type { Clip, MarkerRef } from "./types";

/** The clip's length: `duration`, else its last key's time (0 without keys). */
export function clipEnd(doc: Clip): number {
  if (doc.duration != null) return doc.duration;
  let end = 0;
  for (const keys of Object.values(doc.tracks)) if (keys.length) end = Math.max(end, keys[keys.length - 1].t);
  return end;
}

/** An empty clip to start from. It has no tracks yet, and the server refuses to save (PUT) a clip
 * without at least one track: key something (insertKeys/keyPose) first. */
export function newClip(name: string, robot: string | null, fps: number): Clip {
  return { format: "nutty-clip/1", name, robot, fps, tracks: {}, anchors: {}, events: [] };
}

/** Anchors must lie within the clip (0..end), events at or after 0. */
const anchorTime = (doc: Clip, t: number) => Math.min(Math.max(0, t), clipEnd(doc));

/** Move an anchor or event to time t (s). Events keep their index (the engine sorts them). */
export function moveMarker(doc: Clip, ref: MarkerRef, t: number): Clip {
  if (ref.kind === "anchor") {
    if (!doc.anchors || !(ref.name in doc.anchors)) return doc;
    return { ...doc, anchors: { ...doc.anchors, [ref.name]: anchorTime(doc, t) } };
  }
  const events = doc.events ?? [];
  if (!events[ref.index]) return doc;
  const next = events.map((e, i) => (i === ref.index ? { ...e, t: clampTime(t) } : e));
  return { ...doc, events: next };
}

/** Add (or move) the anchor `name` at time t (kept within the clip). */
export function addAnchor(doc: Clip, name: string, t: number): Clip {
  return { ...doc, anchors: { ...(doc.anchors ?? {}), [name]: anchorTime(doc, t) } };
}

/** Remove an anchor or an event (later events' indices shift down by one). */
export function removeMarker(doc: Clip, ref: MarkerRef): Clip {
  if (ref.kind === "anchor") {
    if (!doc.anchors || !(ref.name in doc.anchors)) return doc;
    const anchors = { ...doc.anchors };
    delete anchors[ref.name];
    return { ...doc, anchors };
  }
  const events = doc.events ?? [];
  if (!events[ref.index]) return doc;
  return { ...doc, events: events.filter((_, i) => i !== ref.index) };
}
