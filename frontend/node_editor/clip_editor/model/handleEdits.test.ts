// Handle edits: types switching without the curve jumping, drags turning auto handles aligned with the
// other side mirrored, free handles moving alone — each checked through the curve port (what plays).
import { describe, expect, it } from "vitest";
import { evaluateKeys, resolveHandles } from "./curve";
import { dragHandle, setKeyProps } from "./edits";
import type { Clip, Handle, Keyframe } from "./types";

const doc = (): Clip => ({
  tracks: {
    a: [{ t: 0, v: 0 }, { t: 1, v: 1 }, { t: 2, v: 0.5 }, { t: 3, v: 2 }],
    mouth: [{ t: 0, v: "smile" }],
  },
});
const ref = (index: number) => ({ dof: "a", index });
const samples = (keys: Keyframe[]) => Array.from({ length: 61 }, (_, i) => evaluateKeys(keys, i * 0.05));
const offset = (keys: Keyframe[], i: number, side: "left" | "right"): Handle => {
  const h = resolveHandles(keys)[i][side];
  return [h[0] - keys[i].t, h[1] - Number(keys[i].v)];
};
const direction = (h: Handle) => Math.atan2(h[1], h[0]);

describe("setKeyProps", () => {
  it("sets interp and easing on the selection only, keeping the selection", () => {
    const r = setKeyProps(doc(), [ref(0), ref(2)], { interp: "sine", easing: "out" });
    expect(r.doc.tracks.a.map((k) => k.interp)).toEqual(["sine", undefined, "sine", undefined]);
    expect(r.doc.tracks.a[0].easing).toBe("out");
    expect(r.selection).toEqual([ref(0), ref(2)]);
  });

  it("free/aligned store the handles as shown, so the curve does not change", () => {
    const d: Clip = { tracks: { a: [{ t: 0, v: 0 }, { t: 1, v: 1 }, { t: 2, v: 1.2, left_type: "vector" }, { t: 3, v: 2, right_type: "auto" }] } };
    // auto handles are collinear, so aligned keeps them; a vector corner stays only while free
    const aligned = setKeyProps(d, [ref(0), ref(1), ref(3)], { left_type: "free", right_type: "aligned" });
    const r = setKeyProps(aligned.doc, [ref(2)], { left_type: "free", right_type: "free" });
    const keys = r.doc.tracks.a;
    expect(keys[1].left).not.toBeNull();
    expect(keys[1].right?.[1]).toBeGreaterThan(0); // a sloped (not flat) handle was stored
    const before = samples(d.tracks.a);
    samples(keys).forEach((v, i) => expect(v).toBeCloseTo(before[i], 12));
  });

  it("auto/auto_clamped/vector drop the stored offset of that side", () => {
    const d: Clip = { tracks: { a: [{ t: 0, v: 0, right_type: "free", right: [0.2, 1], left_type: "free", left: [-0.1, 0] }, { t: 1, v: 1 }] } };
    const r = setKeyProps(d, [{ dof: "a", index: 0 }], { right_type: "vector" });
    expect(r.doc.tracks.a[0]).toEqual({ t: 0, v: 0, right_type: "vector", left_type: "free", left: [-0.1, 0] });
  });
});

describe("dragHandle", () => {
  it("turns an auto handle aligned on both sides, mirroring the other side at its length", () => {
    const d = doc();
    const before = offset(d.tracks.a, 1, "left");
    const r = dragHandle(d, ref(1), "right", [1.3, 1.5]);
    const k = r.doc.tracks.a[1];
    expect(k).toMatchObject({ left_type: "aligned", right_type: "aligned", interp: "bezier" });
    expect(k.right).toEqual([0.30000000000000004, 0.5]);
    const left = k.left as Handle;
    expect(Math.hypot(left[0], left[1])).toBeCloseTo(Math.hypot(before[0], before[1]), 12);
    // what the engine evaluates: the handle where it was dropped, the other side exactly opposite
    const shown = resolveHandles(r.doc.tracks.a)[1];
    expect(shown.right[0]).toBeCloseTo(1.3, 12);
    expect(shown.right[1]).toBeCloseTo(1.5, 12);
    const l = offset(r.doc.tracks.a, 1, "left");
    expect(direction(l)).toBeCloseTo(direction([-0.3, -0.5]), 12);
  });

  it("keeps a dragged handle's time on its side", () => {
    const r = dragHandle(doc(), ref(1), "left", [1.4, 2]);
    expect(r.doc.tracks.a[1].left).toEqual([0, 1]);
  });

  it("moves a free handle alone", () => {
    const d: Clip = {
      tracks: { a: [{ t: 0, v: 0 }, { t: 1, v: 1, left_type: "free", right_type: "free", left: [-0.2, 0], right: [0.2, 0] }, { t: 2, v: 0 }] },
    };
    const r = dragHandle(d, ref(1), "left", [0.7, 0.5]);
    expect(r.doc.tracks.a[1].left?.[0]).toBeCloseTo(-0.3, 12);
    expect(r.doc.tracks.a[1].left?.[1]).toBeCloseTo(-0.5, 12);
    expect(r.doc.tracks.a[1].right).toEqual([0.2, 0]);
    expect(r.doc.tracks.a[0].interp).toBe("bezier"); // the segment the left handle shapes
  });

  it("re-mirrors the other side of an aligned pair keeping its stored length", () => {
    const d: Clip = {
      tracks: { a: [{ t: 0, v: 0 }, { t: 1, v: 1, left_type: "aligned", right_type: "aligned", left: [-0.3, -0.4], right: [0.3, 0.4] }, { t: 2, v: 0 }] },
    };
    const r = dragHandle(d, ref(1), "left", [0.9, 1]);
    const right = r.doc.tracks.a[1].right as Handle;
    expect(right[0]).toBeCloseTo(0.5, 12);
    expect(right[1]).toBeCloseTo(0, 12);
    const shownLeft = resolveHandles(r.doc.tracks.a)[1].left;
    expect(shownLeft[0]).toBeCloseTo(0.9, 12);
    expect(shownLeft[1]).toBeCloseTo(1, 12);
  });

  it("the last key's left handle still moves (its right side is clamped to nothing)", () => {
    const r = dragHandle(doc(), ref(3), "left", [2.8, 1.5]);
    const shown = resolveHandles(r.doc.tracks.a)[3].left;
    expect(shown[0]).toBeCloseTo(2.8, 12);
    expect(shown[1]).toBeCloseTo(1.5, 12);
  });

  it("leaves non-numeric keys alone", () => {
    const d = doc();
    expect(dragHandle(d, { dof: "mouth", index: 0 }, "right", [1, 1]).doc).toBe(d);
  });
});
