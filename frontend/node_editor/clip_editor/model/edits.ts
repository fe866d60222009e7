// Pure edits on a clip document: every function returns a new document (never mutating its input; an
// untouched track keeps its array, so prepared curves stay cached) and the selection after the edit.
// Keys stay strictly increasing in time per track (as the format requires) and the selection follows
// keys through re-sorting (tracks.ts). Handle edits live in handleEdits.ts, markers in markers.ts; this
// module re-exports them, so it is the one import for the views.
import { evaluateKeys } from "./curve";
import { SAME_TIME, clampTime, clipFps, snapDelta, snapToFrames } from "./snap";
import { mapSelected, rebuild, selectionMap } from "./tracks";
import type { Entry } from "./tracks";
import type { Clip, DofInfo, Edited, KeyRef, Keyframe } from "./types";

export type SnapMode = "frames" | "keys" | "none";

export interface SnapOptions {
  /** frame rate to snap to (default: the clip's fps, else DEFAULT_FPS) */
  fps?: number;
  /** "frames" (default): each moved key to its nearest frame; "keys": the group so its key nearest to
   * another (unselected) key lands on it; "none" */
  snap?: SnapMode;
  /** how near (s) a key must come to another key's time to snap to it ("keys"; default 0.05 s) */
  tolerance?: number;
  /** further times "keys" snaps to (the playhead, markers) */
  extraTimes?: readonly number[];
}

/** Key times of every key not in the selection (what "keys" snapping aims at). */
function unselectedTimes(doc: Clip, sel: Map<string, Set<number>>): number[] {
  const out: number[] = [];
  for (const [dof, keys] of Object.entries(doc.tracks)) {
    const s = sel.get(dof);
    keys.forEach((k, i) => s?.has(i) || out.push(k.t));
  }
  return out;
}

function selectedTimes(doc: Clip, sel: Map<string, Set<number>>): number[] {
  return [...sel].flatMap(([dof, idx]) => [...idx].map((i) => doc.tracks[dof][i].t));
}

const DEFAULT_TOL = 0.05;

// ---------------------------------------------------------------------------------------------------
// Moving, scaling, deleting
// ---------------------------------------------------------------------------------------------------

/** The time shift `moveKeys` applies to the group for a requested `dt` (kept within 0..3600 s, plus the
 * "keys" snap), before "frames" rounds each key: what a grab hint should show. */
export function moveDelta(doc: Clip, sel: readonly KeyRef[], dt: number, opts: SnapOptions = {}): number {
  const map = selectionMap(doc, sel);
  const times = selectedTimes(doc, map);
  if (!times.length) return 0;
  const lo = Math.min(...times);
  const hi = Math.max(...times);
  const clampDt = (d: number) => Math.min(Math.max(d, -lo), 3600 - hi);
  let d = clampDt(dt);
  if (opts.snap === "keys") {
    const candidates = [...unselectedTimes(doc, map), ...(opts.extraTimes ?? [])];
    d = clampDt(d + snapDelta(times.map((t) => t + d), candidates, opts.tolerance ?? DEFAULT_TOL));
  }
  return d;
}

/** Move the selected keys by dt (s) in time and dv in value (numbers only: continuous DoFs), snapping
 * as `opts` says. During a drag call it with the PRE-drag document and the total offsets. */
export function moveKeys(doc: Clip, sel: readonly KeyRef[], dt: number, dv: number, opts: SnapOptions = {}): Edited {
  const fps = clipFps(doc, opts.fps);
  const snap = opts.snap ?? "frames";
  const d = moveDelta(doc, sel, dt, { ...opts, snap });
  return mapSelected(doc, sel, (k) => {
    let t = k.t + d;
    if (snap === "frames") t = snapToFrames(t, fps);
    const v = typeof k.v === "number" && dv !== 0 ? k.v + dv : k.v;
    return { ...k, t: clampTime(t), v };
  });
}

/** Scale the selected keys' times about `pivot` (s) by `factor` (S in Blender); handle offsets scale
 * in time with them. Same snapping as moveKeys ("keys" adjusts the factor). */
export function scaleKeys(
  doc: Clip,
  sel: readonly KeyRef[],
  pivot: number,
  factor: number,
  opts: SnapOptions = {},
): Edited {
  const fps = clipFps(doc, opts.fps);
  const snap = opts.snap ?? "frames";
  let f = factor;
  if (snap === "keys") {
    const map = selectionMap(doc, sel);
    const candidates = [...unselectedTimes(doc, map), ...(opts.extraTimes ?? [])];
    let dist = opts.tolerance ?? DEFAULT_TOL;
    for (const t of selectedTimes(doc, map)) {
      if (Math.abs(t - pivot) <= SAME_TIME) continue;
      const scaled = pivot + (t - pivot) * factor;
      for (const c of candidates) {
        if (Math.abs(c - scaled) <= dist) {
          dist = Math.abs(c - scaled);
          f = (c - pivot) / (t - pivot);
        }
      }
    }
  }
  const s = Math.abs(f);
  const scaleHandle = (h: Keyframe["left"]): Keyframe["left"] =>
    h == null ? h : [Number(h[0]) * s, Number(h[1])];
  return mapSelected(doc, sel, (k) => {
    let t = pivot + (k.t - pivot) * f;
    if (snap === "frames") t = snapToFrames(t, fps);
    const out: Keyframe = { ...k, t: clampTime(t) };
    if (k.left != null) out.left = scaleHandle(k.left);
    if (k.right != null) out.right = scaleHandle(k.right);
    return out;
  });
}

/** Delete the selected keys; a track left without keys is removed (a clip needs >= 1 track to save). */
export function deleteKeys(doc: Clip, sel: readonly KeyRef[]): Edited {
  const changes = new Map<string, Entry[]>();
  for (const [dof, idx] of selectionMap(doc, sel)) {
    changes.set(
      dof,
      doc.tracks[dof].flatMap((key, order) => (idx.has(order) ? [] : [{ key, moved: false, sel: false, order }])),
    );
  }
  return { doc: rebuild(doc, changes).doc, selection: [] };
}

/** Set the value of one key (`sel`: the selection to keep, default that key). */
export function setKeyValue(doc: Clip, ref: KeyRef, v: Keyframe["v"], sel: readonly KeyRef[] = [ref]): Edited {
  const keys = doc.tracks[ref.dof];
  if (!keys?.[ref.index]) return { doc, selection: [...sel] };
  const next = keys.map((k, i) => (i === ref.index ? { ...k, v } : k));
  return { doc: { ...doc, tracks: { ...doc.tracks, [ref.dof]: next } }, selection: [...sel] };
}

/** Move one key to time t (s, clamped to 0..3600); a key already at t in its track is replaced. The
 * selection (`sel`, default that key) follows the re-sorting. */
export function setKeyTime(doc: Clip, ref: KeyRef, t: number, sel: readonly KeyRef[] = [ref]): Edited {
  const keys = doc.tracks[ref.dof];
  if (!keys?.[ref.index]) return { doc, selection: [...sel] };
  const map = selectionMap(doc, sel);
  const inTrack = map.get(ref.dof) ?? new Set<number>();
  const entries = keys.map((key, order) =>
    order === ref.index
      ? { key: { ...key, t: clampTime(t) }, moved: true, sel: inTrack.has(order), order }
      : { key, moved: false, sel: inTrack.has(order), order },
  );
  return rebuild(doc, new Map([[ref.dof, entries]]), sel.filter((r) => r.dof !== ref.dof));
}

// ---------------------------------------------------------------------------------------------------
// Inserting keys
// ---------------------------------------------------------------------------------------------------

export interface InsertOptions {
  /** frame rate whose half frame decides "a key already there" (default the clip's) */
  fps?: number;
}

const copyValue = (v: Keyframe["v"]): Keyframe["v"] => (Array.isArray(v) ? [...v] : v);

/** The value a new key of this DoF gets when none is given: the curve at t for numeric tracks, the
 * key at or before t for enum and colour tracks, the rest value (0 offset in a relative clip) for a
 * DoF without a track (0 when only the name is known). */
function currentValue(doc: Clip, name: string, info: DofInfo | undefined, t: number): Keyframe["v"] {
  const keys = doc.tracks[name] ?? [];
  if (keys.length) {
    const numeric = info ? info.type === "continuous" : typeof keys[0].v === "number";
    if (numeric) return evaluateKeys(keys, t);
    let i = 0;
    while (i + 1 < keys.length && keys[i + 1].t <= t) i++;
    return copyValue(keys[i].v);
  }
  if (!info) return 0;
  if (info.type === "continuous") return doc.relative ? 0 : info.rest;
  if (info.type === "enum") {
    const options = info.options ?? [];
    return options[Math.round(info.rest)] ?? options[0] ?? 0;
  }
  return copyValue(info.restValue ?? [info.rest, info.rest, info.rest]);
}

/** A key at time t in each DoF's track (the track is created if missing), with `values[dof]` or the
 * DoF's current value there; a key within half a frame of t is updated instead (its time, interp and
 * handles kept). Pass DofInfo (not just the name) so a new track gets the right kind of rest value.
 * The new or updated keys come back selected. */
export function insertKeys(
  doc: Clip,
  dofs: readonly (string | DofInfo)[],
  t: number,
  values?: Readonly<Record<string, Keyframe["v"]>>,
  opts: InsertOptions = {},
): Edited {
  const time = clampTime(t);
  const half = 0.5 / clipFps(doc, opts.fps);
  const changes = new Map<string, Entry[]>();
  for (const d of dofs) {
    const name = typeof d === "string" ? d : d.name;
    const info = typeof d === "string" ? undefined : d;
    if (changes.has(name)) continue;
    const v = values && name in values ? copyValue(values[name]) : currentValue(doc, name, info, time);
    const keys = doc.tracks[name] ?? [];
    let near = -1;
    keys.forEach((k, i) => {
      if (Math.abs(k.t - time) <= half && (near < 0 || Math.abs(k.t - time) < Math.abs(keys[near].t - time))) near = i;
    });
    const entries: Entry[] = keys.map((key, order) =>
      order === near ? { key: { ...key, v }, moved: true, sel: true, order } : { key, moved: false, sel: false, order },
    );
    if (near < 0) entries.push({ key: { t: time, v }, moved: true, sel: true, order: keys.length });
    changes.set(name, entries);
  }
  return rebuild(doc, changes);
}

/** Key exactly the DoFs of `pose` at t (Key pose): insertKeys with those values. */
export function keyPose(
  doc: Clip,
  pose: Readonly<Record<string, Keyframe["v"]>>,
  t: number,
  opts: InsertOptions = {},
): Edited {
  return insertKeys(doc, Object.keys(pose), t, pose, opts);
}

export { dragHandle, setKeyProps } from "./handleEdits";
export type { KeyProps } from "./handleEdits";
export { addAnchor, clipEnd, moveMarker, newClip, removeMarker } from "./markers";
