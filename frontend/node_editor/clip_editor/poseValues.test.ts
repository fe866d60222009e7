import { describe, expect, it } from "vitest";
import type { Clip, DofInfo } from "./model/types";
import { poseAt, previewLabel, samePose, sampleTrack } from "./poseValues";

const dof = (name: string, type: DofInfo["type"], extra: Partial<DofInfo> = {}): DofInfo =>
  ({ name, type, min: -1, max: 1, rest: 0, velocity: 1, group: "Joints", ...extra });
const dofs = new Map<string, DofInfo>([
  ["head", dof("head", "continuous", { rest: 0.25 })],
  ["face", dof("face", "enum", { options: ["neutral", "happy", "sad"] })],
  ["eyes", dof("eyes", "colour")],
]);
const doc: Clip = {
  tracks: {
    head: [{ t: 0, v: 0, interp: "linear" }, { t: 2, v: 1 }],
    face: [{ t: 0, v: "neutral", interp: "linear" }, { t: 1, v: "sad" }],
    eyes: [{ t: 0, v: [0, 0, 0] }, { t: 1, v: [1, 0.5, 2] }],
    unknown_dof: [{ t: 0, v: 3 }],
  },
};

describe("poseAt (what the engine plays)", () => {
  it("evaluates continuous curves, enum options (held: constant) and colours (bezier becomes linear)", () => {
    const p = poseAt(doc, dofs, 0.5);
    expect(p.head).toBeCloseTo(0.25, 12);
    expect(p.face).toBe("neutral");  // enum keys are constant whatever their interp
    expect(p.eyes).toEqual([0.5, 0.25, 0.5].map((x) => expect.closeTo(x, 12)));
    expect(p).not.toHaveProperty("unknown_dof");
    expect(poseAt(doc, dofs, 1.5).face).toBe("sad");
  });

  it("clamps colours to 0..1 and holds values past the ends", () => {
    expect(poseAt(doc, dofs, 5).eyes).toEqual([1, 0.5, 1]);
    expect(poseAt(doc, dofs, -1).head).toBe(0);
  });

  it("adds the rest value to continuous DoFs of a relative clip only", () => {
    const p = poseAt({ ...doc, relative: true }, dofs, 1);
    expect(p.head).toBeCloseTo(0.5 + 0.25, 12);
    expect(p.face).toBe("sad");
    expect(p.eyes).toEqual([1, 0.5, 1]);
  });
});

describe("sampleTrack (the test hook)", () => {
  it("samples the stored curve, plus the rest value when relative", () => {
    expect(sampleTrack(doc, dofs.get("head"), "head", [0, 1, 2])).toEqual([0, 0.5, 1]);
    expect(sampleTrack({ ...doc, relative: true }, dofs.get("head"), "head", [2])).toEqual([1.25]);
    expect(sampleTrack(doc, undefined, "nope", [0]).every(Number.isNaN)).toBe(true);
  });
});

describe("helpers", () => {
  it("labels the preview with the clip and time", () => {
    expect(previewLabel("wave", 1.234)).toBe("wave @ 1.23 s");
  });
  it("compares poses by value", () => {
    expect(samePose({ a: 1, b: [1, 2] }, { b: [1, 2], a: 1 })).toBe(true);
    expect(samePose({ a: 1 }, { a: 2 })).toBe(false);
    expect(samePose({ a: 1 }, null)).toBe(false);
  });
});
