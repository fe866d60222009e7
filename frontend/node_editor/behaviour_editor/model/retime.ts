// Retiming an item (what dragging its bar does): free, keeping the kind of start it has (an absolute
// time, or the same reference with a new offset), or snapped onto another item's start, end or anchor.
// Refuses (returns the document unchanged) what would time an item from itself or start it before 0.
import type { BehaviourDoc, ItemDoc, Plan, SnapTarget, StartRef } from "./types";
import { isStartRef } from "./types";
import { dependentsOf, findItem, plannedById, refMoment, roundMs } from "./refs";

const EPS = 1e-9;

function setStart(doc: BehaviourDoc, id: string, start: ItemDoc["start"]): BehaviourDoc {
  return {
    ...doc,
    tracks: (doc.tracks ?? []).map((t) => ({
      ...t,
      items: (t.items ?? []).map((item) => (item.id === id ? { ...item, start } : item)),
    })),
  };
}

/** True when timing `id` from `target` would make a circle: `target` is `id` or is timed from it. */
export function wouldCycle(doc: BehaviourDoc, id: string, target: string): boolean {
  return target === id || dependentsOf(doc, id).has(target);
}

/**
 * Item `id` starting at `newStart` (s from the behaviour's start). With `snap` null the start keeps its
 * kind: an absolute start becomes `newStart` rounded to 1 ms; a relative one keeps its reference and
 * gets the offset that lands it there (rounded to 1 ms). With a snap target, the start becomes
 * {item, at, anchor?, offset: 0} on it.
 */
export function retime(
  doc: BehaviourDoc,
  plan: Plan | null,
  id: string,
  newStart: number,
  snap: SnapTarget | null,
): BehaviourDoc {
  const found = findItem(doc, id);
  if (!found) return doc;
  if (snap) {
    if (wouldCycle(doc, id, snap.item) || !findItem(doc, snap.item)) return doc;
    if (snap.at === "anchor" && !snap.anchor) return doc;
    const ref: StartRef = snap.at === "anchor"
      ? { item: snap.item, at: "anchor", anchor: snap.anchor, offset: 0 }
      : { item: snap.item, at: snap.at, offset: 0 };
    return setStart(doc, id, ref);
  }
  if (!Number.isFinite(newStart) || newStart < -EPS) return doc;
  const start = found.item.start;
  if (!isStartRef(start)) {
    const t = roundMs(Math.max(0, newStart));
    return t === start ? doc : setStart(doc, id, t);
  }
  // The reference's moment from the plan; else back it out of this item's planned start and offset.
  const own = plannedById(plan).get(id);
  const moment = refMoment(plan, start) ?? (own ? own.start - (start.offset ?? 0) : null);
  if (moment == null) return doc;
  const offset = roundMs(newStart - moment);
  if (offset === (start.offset ?? 0)) return doc;
  return setStart(doc, id, { ...start, offset });
}
