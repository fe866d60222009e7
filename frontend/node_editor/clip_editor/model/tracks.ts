// The one place a track's keys are re-sorted after an edit: entries carry whether the edit changed a key
// (it wins a same-time collision) and whether it is selected afterwards, so the selection follows keys.
import { SAME_TIME } from "./snap";
import type { Clip, Edited, KeyRef, Keyframe } from "./types";

/** The selection as dof -> key indices (references to keys that do not exist are dropped). */
export function selectionMap(doc: Clip, sel: readonly KeyRef[]): Map<string, Set<number>> {
  const out = new Map<string, Set<number>>();
  for (const r of sel) {
    const keys = doc.tracks[r.dof];
    if (!keys || !Number.isInteger(r.index) || r.index < 0 || r.index >= keys.length) continue;
    let s = out.get(r.dof);
    if (!s) out.set(r.dof, (s = new Set()));
    s.add(r.index);
  }
  return out;
}

export interface Entry {
  key: Keyframe;
  /** changed by this edit: wins a collision with an unchanged key at the same time */
  moved: boolean;
  /** selected after the edit */
  sel: boolean;
  order: number;
}

/** Sort a track's keys by time and merge keys at the same time (within SAME_TIME): a moved key replaces
 * an unmoved one there (Blender); of two moved keys the later (in the original order) stays. */
export function settle(entries: Entry[]): Entry[] {
  const sorted = [...entries].sort((a, b) => a.key.t - b.key.t || a.order - b.order);
  const out: Entry[] = [];
  for (const e of sorted) {
    const last = out[out.length - 1];
    if (last && Math.abs(e.key.t - last.key.t) <= SAME_TIME) {
      const eWins = e.moved !== last.moved ? e.moved : e.order > last.order;
      if (eWins) out[out.length - 1] = e;
    } else {
      out.push(e);
    }
  }
  return out;
}

/** Rebuild the tracks named in `changes` (dof -> entries), keep the others as they are, and gather the
 * selection: the entries marked `sel`, plus `keep` (refs into unchanged tracks). */
export function rebuild(doc: Clip, changes: Map<string, Entry[]>, keep: readonly KeyRef[] = []): Edited {
  const tracks: Record<string, Keyframe[]> = {};
  const selection: KeyRef[] = [];
  const keepMap = selectionMap(doc, keep);
  for (const [dof, keys] of Object.entries(doc.tracks)) {
    const entries = changes.get(dof);
    if (!entries) {
      tracks[dof] = keys;
      for (const i of [...(keepMap.get(dof) ?? [])].sort((a, b) => a - b)) selection.push({ dof, index: i });
      continue;
    }
    const settled = settle(entries);
    if (!settled.length) continue; // a track left with no keys is removed
    tracks[dof] = settled.map((e) => e.key);
    settled.forEach((e, index) => e.sel && selection.push({ dof, index }));
  }
  for (const [dof, entries] of changes) {
    if (dof in doc.tracks) continue; // a new track (insert, paste)
    const settled = settle(entries);
    if (!settled.length) continue;
    tracks[dof] = settled.map((e) => e.key);
    settled.forEach((e, index) => e.sel && selection.push({ dof, index }));
  }
  return { doc: { ...doc, tracks }, selection };
}

/** Apply `change` to the selected keys (marked moved and selected) and re-sort their tracks. */
export function mapSelected(doc: Clip, sel: readonly KeyRef[], change: (k: Keyframe, dof: string) => Keyframe): Edited {
  const changes = new Map<string, Entry[]>();
  for (const [dof, idx] of selectionMap(doc, sel)) {
    changes.set(
      dof,
      doc.tracks[dof].map((key, order) =>
        idx.has(order) ? { key: change(key, dof), moved: true, sel: true, order } : { key, moved: false, sel: false, order },
      ),
    );
  }
  return rebuild(doc, changes);
}

