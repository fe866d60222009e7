// Walking a behaviour document's items and the timing references between them: finding an item, the
// items timed from one (directly or through others), and the planned time of a reference's moment.
// Shared by the edits, the retiming and the snapping, so they agree on what depends on what.
import type { BehaviourDoc, ItemDoc, Plan, PlannedItem, StartRef } from "./types";
import { isStartRef } from "./types";

export interface Located {
  track: number;
  index: number;
  item: ItemDoc;
}

export const IDENT = /^[A-Za-z_][A-Za-z0-9_]{0,39}$/;

/** Every item with its track and index, track after track (the server's document order). */
export function allItems(doc: BehaviourDoc): Located[] {
  const out: Located[] = [];
  (doc.tracks ?? []).forEach((track, t) => (track.items ?? []).forEach((item, i) => out.push({ track: t, index: i, item })));
  return out;
}

export function findItem(doc: BehaviourDoc, id: string): Located | null {
  return allItems(doc).find((l) => l.item.id === id) ?? null;
}

/** The id an item's start is timed from, or null for an absolute start. */
export function refOf(item: ItemDoc): string | null {
  return isStartRef(item.start) ? item.start.item : null;
}

/** Ids of the items timed from `id`, directly or through others (never `id` itself, even in a cycle). */
export function dependentsOf(doc: BehaviourDoc, id: string): Set<string> {
  const children = new Map<string, string[]>();
  for (const { item } of allItems(doc)) {
    const ref = refOf(item);
    if (ref != null) children.set(ref, [...(children.get(ref) ?? []), item.id]);
  }
  const out = new Set<string>();
  const stack = [...(children.get(id) ?? [])];
  while (stack.length) {
    const next = stack.pop() as string;
    if (next === id || out.has(next)) continue;
    out.add(next);
    stack.push(...(children.get(next) ?? []));
  }
  return out;
}

export function plannedById(plan: Plan | null | undefined): Map<string, PlannedItem> {
  return new Map((plan?.items ?? []).map((p) => [p.id, p]));
}

/** The planned time (s) of the moment a reference names (without its offset), or null when unknown. */
export function refMoment(plan: Plan | null | undefined, ref: StartRef): number | null {
  const base = plannedById(plan).get(ref.item);
  if (!base) return null;
  const at = ref.at ?? "start";
  if (at === "start") return base.start;
  if (at === "end") return base.end;
  const t = ref.anchor != null ? base.anchors?.[ref.anchor] : undefined;
  return t ?? null;
}

/** `t` rounded to 1 ms (the precision documents keep). */
export function roundMs(t: number): number {
  return Math.round(t * 1000) / 1000 + 0;
}
