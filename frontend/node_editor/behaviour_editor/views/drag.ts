// The maths of dragging a bar, pure so it is unit-tested: the start a horizontal move asks for (never
// before 0), snapped to the nearest other item's moment unless Alt is held, and where every bar shows
// while the drag is live (the items timed from the dragged one move with it).
import type { PlannedItem, SnapTarget } from "../model/types";
import { nearestSnap } from "../model/snap";

export interface DragState {
  id: string;
  /** the item's planned start when the drag began */
  from: number;
  /** the start it would get now (the snap target's time when snapped) */
  start: number;
  snap: SnapTarget | null;
  /** the lane the pointer is over */
  track: number;
  /** ids of the items timed from the dragged one (they move with it) */
  dependents: Set<string>;
}

/** The start (s) and snap for a bar planned at `from` moved `dxPx` px at `pxPerSecond`. */
export function dragTo(
  from: number,
  dxPx: number,
  pxPerSecond: number,
  targets: SnapTarget[],
  free: boolean,
): { start: number; snap: SnapTarget | null } {
  const start = Math.max(0, from + dxPx / Math.max(pxPerSecond, 1e-9));
  const snap = free ? null : nearestSnap(targets, start, pxPerSecond);
  return snap ? { start: snap.t, snap } : { start, snap: null };
}

/** Where planned item `p` shows during `drag` (its plan when no drag moves it). */
export function shownSpan(p: PlannedItem, drag: DragState | null): { start: number; end: number } {
  if (!drag || (p.id !== drag.id && !drag.dependents.has(p.id))) return { start: p.start, end: p.end };
  const dt = drag.start - drag.from;
  return { start: p.start + dt, end: p.end + dt };
}

/** Anchors of `p` shifted with it during `drag`. */
export function shownAnchors(p: PlannedItem, drag: DragState | null): Record<string, number> {
  const { start } = shownSpan(p, drag);
  const dt = start - p.start;
  return Object.fromEntries(Object.entries(p.anchors ?? {}).map(([k, t]) => [k, t + dt]));
}
