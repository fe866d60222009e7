import { describe, expect, it } from "vitest";
import { validClipName } from "./ClipBrowser";
import type { RecordResult } from "./clipApi";
import type { DofInfo } from "./model/types";
import { asPose, restOf } from "./PoseField";
import { sliderRange } from "./poseValues";
import { reportSummary } from "./RecordControls";
import { clipKeyOf } from "./useClipKeys";
import { advance } from "./usePlayback";
import { axisValue, DEADZONE } from "./usePoseInputs";

describe("playback", () => {
  it("runs in real time from the playhead and stops at the end", () => {
    expect(advance(0.5, 0.25, 2, false)).toEqual({ t: 0.75, done: false });
    expect(advance(1.5, 1, 2, false)).toEqual({ t: 2, done: true });
  });
  it("wraps when looping", () => {
    const r = advance(1.5, 1, 2, true);
    expect(r.done).toBe(false);
    expect(r.t).toBeCloseTo(0.5, 12);
  });
  it("has nothing to play in an empty clip", () => {
    expect(advance(0, 1, 0, true)).toEqual({ t: 0, done: true });
  });
});

describe("keys", () => {
  const k = (key: string, m: { ctrlKey?: boolean; shiftKey?: boolean; metaKey?: boolean; altKey?: boolean } = {}) =>
    clipKeyOf({ key, ctrlKey: false, metaKey: false, shiftKey: false, altKey: false, ...m });
  it("undo, redo (both ways), save and play", () => {
    expect(k("z", { ctrlKey: true })).toBe("undo");
    expect(k("Z", { ctrlKey: true, shiftKey: true })).toBe("redo");
    expect(k("y", { ctrlKey: true })).toBe("redo");
    expect(k("s", { metaKey: true })).toBe("save");
    expect(k(" ")).toBe("togglePlay");
    expect(k("z")).toBeNull();
    expect(k(" ", { altKey: true })).toBeNull();
  });
});

describe("gamepad", () => {
  const dof = { min: -1, max: 0.5, rest: 0 };
  it("maps full deflection to the limit on that side, about the base", () => {
    expect(axisValue(1, 0, dof)).toBe(0.5);
    expect(axisValue(-1, 0, dof)).toBe(-1);
    expect(axisValue(0.5, 0, dof)).toBeCloseTo(0.25, 12);
    expect(axisValue(-0.5, 0.5, dof)).toBeCloseTo(-0.25, 12);
  });
  it("ignores a stick at rest and stays within limits", () => {
    expect(axisValue(DEADZONE / 2, 0.1, dof)).toBe(0.1);
    expect(axisValue(3, 0, dof)).toBe(0.5);
  });
  it("uses rest ± π for a DoF without limits", () => {
    expect(sliderRange({ min: -Infinity, max: Infinity, rest: 1 })).toEqual([1 - Math.PI, 1 + Math.PI]);
  });
});

describe("record report", () => {
  const result = (ok: boolean): RecordResult => ({
    saved: "wave-take-1", clip: { tracks: {} }, samples: 120, keys: { head_pitch: 4, neck_pitch: 2 }, duration: 1.2, max_error: 0.0012,
    report: { ok, colours: {}, dofs: {}, engine_rate: 100, rate: 100, samples: 120,
      ranges: ok ? [] : [{ dof: "head_pitch", kind: "velocity", start: 3, end: 9, limits: { velocity: 1.4 } } as never] },
  });
  it("sums up keys per DoF, the error and the limits", () => {
    const s = reportSummary(result(true));
    expect(s.keys).toBe("head_pitch: 4, neck_pitch: 2");
    expect(s.error).toContain("0.0012 rad");
    expect(s.limits).toBe("limits ok");
    expect(reportSummary(result(false)).limits).toBe("over the limits: head_pitch velocity");
  });
});

describe("library names", () => {
  it("accepts what the server's library accepts", () => {
    expect(validClipName("wave_2.v1-b")).toBe(true);
    expect(validClipName("has space")).toBe(false);
    expect(validClipName("")).toBe(false);
    expect(validClipName("-lead")).toBe(false);
  });
});

describe("pose field", () => {
  it("keeps only pose values of a parameter", () => {
    expect(asPose({ a: 1, b: "happy", c: [1, 0, 0], d: { x: 1 }, e: null })).toEqual({ a: 1, b: "happy", c: [1, 0, 0] });
    expect(asPose(null)).toEqual({});
    expect(asPose([1, 2])).toEqual({});
  });
  it("adds a DoF at its rest value", () => {
    const base: DofInfo = { name: "x", type: "continuous", min: -1, max: 1, rest: 0.2, velocity: 1, group: "Joints" };
    expect(restOf(base)).toBe(0.2);
    expect(restOf({ ...base, type: "enum", options: ["a", "b"], restValue: "b" })).toBe("b");
    expect(restOf({ ...base, type: "enum", options: ["a", "b"] })).toBe("a");
    expect(restOf({ ...base, type: "colour", rest: 1 })).toEqual([1, 1, 1]);
  });
});
