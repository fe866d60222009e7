// When the editor's edits reach the server (../hooks/useProgramSync): structural edits shortly after the
// last one, an undo or redo only once a burst of them has ended (one hot swap for a dozen quick Ctrl+Z),
// and the steps of one drag as one undo step.
import { useCallback, useEffect, useRef } from "react";
import type { History } from "../history";

/** Edits closer together than this (ms) go to the server as one program. */
export const SYNC_DELAY_MS = 90;
/** Undo and redo steps closer together than this (ms) are one burst: one hot swap when it ends. */
export const UNDO_QUIET_MS = 400;

/** Whether `now` is `before` stepped back or forward in its history (an undo or a redo). */
export function steppedThrough<T>(before: History<T> | null, now: History<T>): boolean {
  return !!before && before !== now
    && (now.present === before.past[before.past.length - 1] || now.present === before.future[0]);
}

/** How long to wait before syncing `history`'s present: longer while undo/redo steps keep coming. */
export function useSyncDelay<T>(history: History<T>): () => number {
  const seen = useRef<History<T> | null>(null);
  const lastStep = useRef(-Infinity);
  useEffect(() => {
    if (steppedThrough(seen.current, history)) lastStep.current = performance.now();
    seen.current = history;
  }, [history]);
  return useCallback(() => (performance.now() - lastStep.current < UNDO_QUIET_MS ? UNDO_QUIET_MS : SYNC_DELAY_MS), []);
}

/** A drag in progress on one node: since `at`, its last step at `last`. */
export interface Gesture { node: string; at: number; last: number }

/** A drag whose steps stop for this long (ms) without an end (its field went away) is over. */
export const GESTURE_STALE_MS = 10000;

/** The time an edit of `id` carries to the reducer: a drag's steps and its end carry the time of its
 * first step, so the reducer (which folds edits of one node closer than COALESCE_MS into one undo step)
 * makes a drag of any length, pauses included, one step. */
export function gestureTime(gesture: { current: Gesture | null }, id: string, inProgress: boolean, now: number): number {
  const g = gesture.current;
  const at = g && g.node === id && now - g.last < GESTURE_STALE_MS ? g.at : now;
  gesture.current = inProgress ? { node: id, at, last: now } : null;
  return at;
}
