import { describe, expect, it } from "vitest";
import * as H from "../history";
import { GESTURE_STALE_MS, gestureTime, steppedThrough, type Gesture } from "./syncTiming";

describe("undo bursts", () => {
  it("tells an undo or a redo from an edit", () => {
    const a = H.init("a");
    const b = H.push(a, "b");
    const c = H.push(b, "c");
    expect(steppedThrough(b, c)).toBe(false);  // an edit
    const undone = H.undo(c);
    expect(steppedThrough(c, undone)).toBe(true);
    expect(steppedThrough(undone, H.redo(undone))).toBe(true);
    expect(steppedThrough(null, c)).toBe(false);
    expect(steppedThrough(c, c)).toBe(false);
  });
});

describe("a drag is one undo step", () => {
  it("gives a drag's steps and its end the time of its first step", () => {
    const g: { current: Gesture | null } = { current: null };
    expect(gestureTime(g, "wave", true, 100)).toBe(100);
    expect(gestureTime(g, "wave", true, 900)).toBe(100);  // a pause longer than the coalescing
    expect(gestureTime(g, "wave", false, 1500)).toBe(100);  // the drag's end
    expect(g.current).toBeNull();
    expect(gestureTime(g, "wave", false, 2000)).toBe(2000);  // a typed value: its own time
  });
  it("starts afresh on another node", () => {
    const g: { current: Gesture | null } = { current: { node: "wave", at: 5, last: 5 } };
    expect(gestureTime(g, "shape", true, 50)).toBe(50);
  });
  it("forgets a drag that never ended", () => {
    const g: { current: Gesture | null } = { current: { node: "wave", at: 5, last: 5 } };
    expect(gestureTime(g, "wave", false, 5 + GESTURE_STALE_MS)).toBe(5 + GESTURE_STALE_MS);
  });
});
