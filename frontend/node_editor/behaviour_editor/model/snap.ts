// Snapping a dragged item's start: the moments of the other items it may be timed from (their starts,
// ends and clip anchors, from the plan) and the one nearest the pointer within a few pixels.
import type { BehaviourDoc, Plan, SnapTarget } from "./types";
import { dependentsOf } from "./refs";

/**
 * Every other planned item's start, end and anchors, in plan order. Never the moving item's own, nor
 * (given the document, which holds the references the plan lacks) those of the items timed from it,
 * directly or not: snapping to them would time the item from itself.
 */
export function snapTargets(plan: Plan | null, movingId: string, doc?: BehaviourDoc): SnapTarget[] {
  const skip = doc ? dependentsOf(doc, movingId) : new Set<string>();
  skip.add(movingId);
  const out: SnapTarget[] = [];
  for (const p of plan?.items ?? []) {
    if (skip.has(p.id)) continue;
    out.push({ item: p.id, at: "start", t: p.start });
    if (p.end > p.start) out.push({ item: p.id, at: "end", t: p.end });
    for (const [anchor, t] of Object.entries(p.anchors ?? {})) out.push({ item: p.id, at: "anchor", anchor, t });
  }
  return out;
}

/** The target nearest `t` (s) within `radiusPx` on screen at `pxPerSecond`, or null. Ties go to the
 * first (an item's start before its end, earlier items first). */
export function nearestSnap(targets: SnapTarget[], t: number, pxPerSecond: number, radiusPx = 8): SnapTarget | null {
  let best: SnapTarget | null = null;
  let bestPx = radiusPx;
  for (const target of targets) {
    const px = Math.abs(target.t - t) * pxPerSecond;
    if (px <= bestPx && (best === null || px < bestPx)) {
      best = target;
      bestPx = px;
    }
  }
  return best;
}
