// Time snapping for key edits: the clip's frame grid (clips are authored at `fps`, playback ignores it)
// and the nearest other key time.
import type { Clip } from "./types";
import { DEFAULT_FPS } from "./types";

/** Two key times closer than this are the same time (a moved key replaces the key it lands on). */
export const SAME_TIME = 1e-6;

/** The frame rate a clip's keys snap to. */
export const clipFps = (doc: Clip, fps?: number): number => fps ?? doc.fps ?? DEFAULT_FPS;

/** The time (s) of frame number `frame` (may be fractional) at `fps`. */
export const frameTime = (frame: number, fps: number): number => frame / fps;

/** The frame number at time `t` (s), fractional: round it for the nearest frame. */
export const timeFrame = (t: number, fps: number): number => t * fps;

/** `t` rounded to the nearest frame (division, not multiplication by 1/fps, so 0.1 at 30 fps is 0.1). */
export const snapToFrames = (t: number, fps: number): number => Math.round(t * fps) / fps;

/** The candidate nearest to `t` within `tol` (s), or null. */
export function nearestTime(t: number, candidates: Iterable<number>, tol: number): number | null {
  let best: number | null = null;
  let dist = tol;
  for (const c of candidates) {
    const d = Math.abs(c - t);
    if (d <= dist) {
      best = c;
      dist = d;
    }
  }
  return best;
}

/** The correction to add to a group of moved times so the one nearest to a candidate lands on it (the
 * smallest correction within `tol`), or 0 when none is close enough. */
export function snapDelta(moved: Iterable<number>, candidates: readonly number[], tol: number): number {
  let best = 0;
  let dist = Infinity;
  for (const t of moved) {
    const c = nearestTime(t, candidates, Math.min(tol, dist));
    if (c !== null && Math.abs(c - t) < dist) {
      dist = Math.abs(c - t);
      best = c - t;
    }
  }
  return best;
}

export const clampTime = (t: number): number => Math.min(3600, Math.max(0, t));
