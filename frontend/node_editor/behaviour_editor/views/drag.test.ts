// Tests of the bar-drag maths: pixel moves to seconds, clamping at 0, snapping (and Alt's free move),
// and the live positions of the dragged item and the items timed from it.
import { describe, expect, it } from "vitest";
import type { DragState } from "./drag";
import { dragTo, shownAnchors, shownSpan } from "./drag";

const targets = [
  { item: "wave", at: "start" as const, t: 1 },
  { item: "wave", at: "anchor" as const, anchor: "beat", t: 1.6 },
];

describe("drag", () => {
  it("turns pixels into seconds, never before 0", () => {
    expect(dragTo(2, 50, 100, [], false)).toEqual({ start: 2.5, snap: null });
    expect(dragTo(0.2, -100, 100, [], false).start).toBe(0);
  });

  it("snaps within 8 px unless free", () => {
    expect(dragTo(1.5, 7, 100, targets, false)).toEqual({ start: 1.6, snap: targets[1] });
    expect(dragTo(1.5, 7, 100, targets, true)).toEqual({ start: 1.57, snap: null });
    expect(dragTo(1.5, -40, 100, targets, false)).toEqual({ start: 1.1, snap: null });
  });

  it("moves the dragged item and its dependents together", () => {
    const drag: DragState = { id: "wave", from: 1, start: 1.5, snap: null, track: 1, dependents: new Set(["hello"]) };
    expect(shownSpan({ id: "wave", track: 1, kind: "play_clip", start: 1, end: 3 }, drag)).toEqual({ start: 1.5, end: 3.5 });
    expect(shownSpan({ id: "hello", track: 2, kind: "say", start: 1.6, end: 2 }, drag)).toEqual({ start: 2.1, end: 2.5 });
    expect(shownSpan({ id: "look", track: 0, kind: "look_at", start: 0, end: 1 }, drag)).toEqual({ start: 0, end: 1 });
    expect(shownSpan({ id: "look", track: 0, kind: "look_at", start: 0, end: 1 }, null)).toEqual({ start: 0, end: 1 });
    expect(shownAnchors({ id: "wave", track: 1, kind: "play_clip", start: 1, end: 3, anchors: { beat: 1.6 } }, drag)).toEqual({ beat: 2.1 });
  });
});
