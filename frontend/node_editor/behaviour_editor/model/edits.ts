// Pure edits of a behaviour document: tracks (add, rename, remove) and items (add with sensible defaults,
// remove without leaving references dangling, update, rename with references following, move to another
// track). Each returns a NEW document and never mutates its input; an edit that cannot apply (unknown
// id, name taken, bad index) returns the input unchanged, so callers can compare by identity.
import type { BehaviourDoc, ItemDoc, ItemKind, Plan, TrackDoc } from "./types";
import { isStartRef } from "./types";
import { IDENT, allItems, findItem, plannedById, refMoment, roundMs } from "./refs";

/** The first clip/posture/sound/... names of the robot, for a new item's required fields. */
export interface ItemDefaults {
  clip?: string;
  posture?: string;
  sound?: string;
  /** an exposed input of the running program (ramp) */
  input?: string;
  /** a face expression (an option of the robot's display DoF) */
  expression?: string;
  text?: string;
}

const tracksOf = (doc: BehaviourDoc): TrackDoc[] => doc.tracks ?? [];

function withTracks(doc: BehaviourDoc, tracks: TrackDoc[]): BehaviourDoc {
  return { ...doc, tracks };
}

/** Apply `fn` to every item (a new array per track; items `fn` returns unchanged stay shared). */
function mapItems(doc: BehaviourDoc, fn: (item: ItemDoc) => ItemDoc): BehaviourDoc {
  return withTracks(doc, tracksOf(doc).map((tr) => ({ ...tr, items: (tr.items ?? []).map(fn) })));
}

/** `base`, or `base_2`, `base_3`... whichever is not in `taken` (kept within the 40-character id limit). */
export function uniqueName(base: string, taken: Iterable<string>): string {
  const used = new Set(taken);
  const stem = (IDENT.test(base) ? base : `_${base.replace(/[^A-Za-z0-9_]/g, "_")}`).slice(0, 34);
  if (!used.has(stem)) return stem;
  for (let k = 2; ; k++) if (!used.has(`${stem}_${k}`)) return `${stem}_${k}`;
}

/** The id addItem gives a new item of `kind`: the kind's short name, numbered when taken (`say_2`). */
export function newItemId(doc: BehaviourDoc, kind: ItemKind): string {
  const base = kind.replace(/^(play|set|go)_/, "");
  const ids = allItems(doc).map((l) => l.item.id);
  if (!ids.includes(base)) return base;
  for (let k = 2; ; k++) if (!ids.includes(`${base}_${k}`)) return `${base}_${k}`;
}

export function addTrack(doc: BehaviourDoc, name: string): BehaviourDoc {
  const track: TrackDoc = { name: uniqueName(name || "track", tracksOf(doc).map((t) => t.name)), items: [] };
  return withTracks(doc, [...tracksOf(doc), track]);
}

/** Rename track `index`; unchanged when the name is no identifier or another track has it. */
export function renameTrack(doc: BehaviourDoc, index: number, name: string): BehaviourDoc {
  const tracks = tracksOf(doc);
  if (!tracks[index] || !IDENT.test(name) || tracks.some((t, i) => i !== index && t.name === name)) return doc;
  if (tracks[index].name === name) return doc;
  return withTracks(doc, tracks.map((t, i) => (i === index ? { ...t, name } : t)));
}

/** Remove track `index` and its items; items elsewhere timed from them get absolute starts (see
 * removeItem). */
export function removeTrack(doc: BehaviourDoc, index: number, plan: Plan | null = null): BehaviourDoc {
  const tracks = tracksOf(doc);
  if (!tracks[index]) return doc;
  const gone = new Set((tracks[index].items ?? []).map((i) => i.id));
  const kept = withTracks(doc, tracks.filter((_, i) => i !== index));
  return detach(kept, gone, plan);
}

function newItem(kind: ItemKind, id: string, start: number, d: ItemDefaults): ItemDoc {
  switch (kind) {
    case "play_clip": return { id, kind, start, clip: d.clip ?? "" };
    case "go_posture": return { id, kind, start, posture: d.posture ?? "" };
    case "look_at": return { id, kind, start, target: [1, 0, 0.35], duration: 1 };
    case "say": return { id, kind, start, text: d.text ?? "Hello!" };
    case "play_sound": return { id, kind, start, sound: d.sound ?? "" };
    case "set_led": return { id, kind, start, colour: [1, 1, 1] };
    case "set_face": return { id, kind, start, expression: d.expression ?? "neutral" };
    case "set_emotion": return { id, kind, start, valence: 0.5, arousal: 0 };
    case "ramp": return { id, kind, start, input: d.input ?? "", to: 0, duration: 1 };
    case "wait": return { id, kind, start, duration: 1 };
  }
}

/** Append a new item of `kind` to track `trackIndex` at `start` (s, rounded to 1 ms, at least 0), with
 * the id `newItemId(doc, kind)` and the kind's required fields filled from `defaults`. */
export function addItem(
  doc: BehaviourDoc,
  trackIndex: number,
  kind: ItemKind,
  start: number,
  defaults: ItemDefaults = {},
): BehaviourDoc {
  const tracks = tracksOf(doc);
  if (!tracks[trackIndex]) return doc;
  const item = newItem(kind, newItemId(doc, kind), roundMs(Math.max(0, start)), defaults);
  return withTracks(doc, tracks.map((t, i) => (i === trackIndex ? { ...t, items: [...(t.items ?? []), item] } : t)));
}

/** Give every item timed from one of `gone` an absolute start: its planned start, else the removed
 * item's planned moment plus its offset, else 0, so nothing is left pointing at a missing item. */
function detach(doc: BehaviourDoc, gone: Set<string>, plan: Plan | null): BehaviourDoc {
  const planned = plannedById(plan);
  return mapItems(doc, (item) => {
    if (!isStartRef(item.start) || !gone.has(item.start.item)) return item;
    const own = planned.get(item.id)?.start;
    const moment = refMoment(plan, item.start);
    const t = own ?? (moment != null ? moment + (item.start.offset ?? 0) : 0);
    return { ...item, start: roundMs(Math.max(0, t)) };
  });
}

/** Remove item `id`; items timed from it keep their place (from the last plan) as absolute starts. */
export function removeItem(doc: BehaviourDoc, id: string, plan: Plan | null = null): BehaviourDoc {
  if (!findItem(doc, id)) return doc;
  const kept = withTracks(doc, tracksOf(doc).map((t) => ({ ...t, items: (t.items ?? []).filter((i) => i.id !== id) })));
  return detach(kept, new Set([id]), plan);
}

/** A partial item: the fields to set; a field given as undefined is removed (back to its default). */
export type ItemPatch = { [K in string]?: unknown };

/** Merge `patch` into item `id` (its `id` and `kind` stay: use renameItem to rename). */
export function updateItem(doc: BehaviourDoc, id: string, patch: ItemPatch): BehaviourDoc {
  if (!findItem(doc, id)) return doc;
  return mapItems(doc, (item) => {
    if (item.id !== id) return item;
    const next: Record<string, unknown> = { ...item };
    for (const [k, v] of Object.entries(patch)) {
      if (k === "id" || k === "kind") continue;
      if (v === undefined) delete next[k];
      else next[k] = v;
    }
    return next as unknown as ItemDoc;
  });
}

/** Rename item `oldId` to `newId`; every start timed from it follows. Unchanged when `newId` is no
 * identifier or another item has it. */
export function renameItem(doc: BehaviourDoc, oldId: string, newId: string): BehaviourDoc {
  if (oldId === newId || !IDENT.test(newId) || !findItem(doc, oldId) || findItem(doc, newId)) return doc;
  return mapItems(doc, (item) => {
    let next = item;
    if (item.id === oldId) next = { ...next, id: newId };
    if (isStartRef(item.start) && item.start.item === oldId) next = { ...next, start: { ...item.start, item: newId } };
    return next;
  });
}

/** Move item `id` to the end of track `trackIndex` (its timing is unchanged). */
export function moveItemToTrack(doc: BehaviourDoc, id: string, trackIndex: number): BehaviourDoc {
  const at = findItem(doc, id);
  const tracks = tracksOf(doc);
  if (!at || !tracks[trackIndex] || at.track === trackIndex) return doc;
  return withTracks(doc, tracks.map((t, i) => {
    if (i === at.track) return { ...t, items: (t.items ?? []).filter((x) => x.id !== id) };
    if (i === trackIndex) return { ...t, items: [...(t.items ?? []), at.item] };
    return t;
  }));
}
