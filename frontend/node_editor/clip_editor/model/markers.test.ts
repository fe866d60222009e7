// Markers (anchors kept within the clip, events by index), the clip's end, and a new clip.
import { describe, expect, it } from "vitest";
import { addAnchor, clipEnd, moveMarker, newClip, removeMarker } from "./edits";
import type { Clip } from "./types";

const doc = (): Clip => ({
  tracks: { a: [{ t: 0, v: 0 }, { t: 2, v: 1 }], b: [{ t: 2.5, v: 0 }] },
  anchors: { beat: 1 },
  events: [{ t: 0.5, dof: "speech", kind: "say", payload: { text: "hi" } }, { t: 1, dof: "sound", kind: "sound" }],
});

describe("markers", () => {
  it("moves an anchor within 0..end and an event at or after 0, without mutating", () => {
    const d = doc();
    expect(moveMarker(d, { kind: "anchor", name: "beat" }, 1.7).anchors).toEqual({ beat: 1.7 });
    expect(moveMarker(d, { kind: "anchor", name: "beat" }, 9).anchors).toEqual({ beat: 2.5 });
    const e = moveMarker(d, { kind: "event", index: 1 }, -1);
    expect(e.events?.[1].t).toBe(0);
    expect(e.events?.[0]).toBe(d.events?.[0]);
    expect(d.anchors).toEqual({ beat: 1 });
    expect(moveMarker(d, { kind: "anchor", name: "nope" }, 1)).toBe(d);
  });

  it("adds and removes anchors and events", () => {
    const d = addAnchor(doc(), "up", 0.25);
    expect(d.anchors).toEqual({ beat: 1, up: 0.25 });
    expect(removeMarker(d, { kind: "anchor", name: "beat" }).anchors).toEqual({ up: 0.25 });
    expect(removeMarker(d, { kind: "event", index: 0 }).events?.map((e) => e.kind)).toEqual(["sound"]);
  });

  it("clipEnd is the duration, else the last key", () => {
    expect(clipEnd(doc())).toBe(2.5);
    expect(clipEnd({ ...doc(), duration: 4 })).toBe(4);
    expect(clipEnd({ tracks: {} })).toBe(0);
  });

  it("newClip starts empty with the format, robot and fps", () => {
    expect(newClip("wave", "nutty_desk", 30)).toEqual({
      format: "nutty-clip/1", name: "wave", robot: "nutty_desk", fps: 30, tracks: {}, anchors: {}, events: [],
    });
  });
});
