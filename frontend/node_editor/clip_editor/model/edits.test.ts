// Key edits: moving (with frame and key snapping, replacement and the selection following re-sorting),
// scaling, deleting, inserting, single-key time/value edits, and never mutating the input.
import { describe, expect, it } from "vitest";
import { evaluateKeys } from "./curve";
import { deleteKeys, insertKeys, keyPose, moveDelta, moveKeys, scaleKeys, setKeyTime, setKeyValue } from "./edits";
import type { Clip, DofInfo, KeyRef } from "./types";

const clip = (): Clip => ({
  format: "nutty-clip/1",
  name: "t",
  fps: 10,
  tracks: {
    a: [{ t: 0, v: 0 }, { t: 1, v: 1 }, { t: 2, v: 0 }],
    b: [{ t: 0.5, v: 2 }, { t: 1.5, v: 3 }],
    mouth: [{ t: 0, v: "smile" }, { t: 1, v: "frown" }],
    led: [{ t: 0, v: [1, 0, 0] }],
  },
});
const times = (c: Clip, dof: string) => c.tracks[dof].map((k) => k.t);
const ref = (dof: string, index: number): KeyRef => ({ dof, index });

describe("moveKeys", () => {
  it("moves in time and value, leaving the input alone and other tracks' arrays shared", () => {
    const doc = clip();
    const before = JSON.stringify(doc);
    const r = moveKeys(doc, [ref("a", 1)], 0.2, 0.5, { snap: "none" });
    expect(r.doc.tracks.a[1]).toEqual({ t: 1.2, v: 1.5 });
    expect(r.selection).toEqual([ref("a", 1)]);
    expect(JSON.stringify(doc)).toBe(before);
    expect(r.doc.tracks.b).toBe(doc.tracks.b);
  });

  it("applies dv only to numbers", () => {
    const r = moveKeys(clip(), [ref("mouth", 1), ref("led", 0)], 0, 1, { snap: "none" });
    expect(r.doc.tracks.mouth[1].v).toBe("frown");
    expect(r.doc.tracks.led[0].v).toEqual([1, 0, 0]);
  });

  it("re-sorts past neighbours and the selection follows the keys", () => {
    const r = moveKeys(clip(), [ref("a", 0), ref("b", 0)], 1.3, 0, { snap: "none" });
    expect(times(r.doc, "a")).toEqual([1, 1.3, 2]);
    expect(times(r.doc, "b")).toEqual([1.5, 1.8]);
    expect(r.selection).toEqual([ref("a", 1), ref("b", 1)]);
  });

  it("replaces an unselected key it lands on (within 1e-6 s)", () => {
    const r = moveKeys(clip(), [ref("a", 0)], 1 + 5e-7, 0, { snap: "none" });
    expect(r.doc.tracks.a).toEqual([{ t: 1 + 5e-7, v: 0 }, { t: 2, v: 0 }]);
    expect(r.selection).toEqual([ref("a", 0)]);
  });

  it("snaps each moved key to the clip's frames by default", () => {
    const r = moveKeys(clip(), [ref("a", 1)], 0.234, 0);
    expect(r.doc.tracks.a[1].t).toBe(1.2);
    const r2 = moveKeys(clip(), [ref("a", 1)], 0.234, 0, { fps: 100 });
    expect(r2.doc.tracks.a[1].t).toBeCloseTo(1.23, 12);
  });

  it("snaps the group to the nearest unselected key time with snap 'keys'", () => {
    // a@1 moved by 0.47 lands at 1.47, 0.03 from b@1.5: the whole group shifts by 0.5
    const sel = [ref("a", 0), ref("a", 1)];
    const r = moveKeys(clip(), sel, 0.47, 0, { snap: "keys", tolerance: 0.05 });
    expect(times(r.doc, "a")).toEqual([0.5, 1.5, 2]);
    expect(moveDelta(clip(), sel, 0.47, { snap: "keys", tolerance: 0.05 })).toBeCloseTo(0.5, 12);
    const far = moveKeys(clip(), sel, 0.4, 0, { snap: "keys", tolerance: 0.05 });
    expect(times(far.doc, "a")).toEqual([0.4, 1.4, 2]);
  });

  it("keeps times at or above 0 by limiting the group's shift", () => {
    const r = moveKeys(clip(), [ref("a", 1), ref("a", 2)], -5, 0, { snap: "none" });
    expect(times(r.doc, "a")).toEqual([0, 1]);
    expect(r.doc.tracks.a[0].v).toBe(1); // the moved key replaced the one at 0
    expect(r.selection).toEqual([ref("a", 0), ref("a", 1)]);
  });

  it("merges two selected keys frame snapping puts on one frame (the later stays)", () => {
    const doc: Clip = { fps: 10, tracks: { a: [{ t: 0, v: 1 }, { t: 0.02, v: 2 }, { t: 1, v: 3 }] } };
    const r = moveKeys(doc, [ref("a", 0), ref("a", 1)], 0, 0);
    expect(r.doc.tracks.a).toEqual([{ t: 0, v: 2 }, { t: 1, v: 3 }]);
    expect(r.selection).toEqual([ref("a", 0)]);
  });
});

describe("scaleKeys", () => {
  it("scales times about the pivot, and stored handle offsets with them", () => {
    const doc: Clip = { tracks: { a: [{ t: 0, v: 0 }, { t: 1, v: 1, left_type: "free", left: [-0.2, 0.1] }, { t: 2, v: 0 }] } };
    const r = scaleKeys(doc, [ref("a", 1), ref("a", 2)], 0, 2, { snap: "none" });
    expect(times(r.doc, "a")).toEqual([0, 2, 4]);
    expect(r.doc.tracks.a[1].left).toEqual([-0.4, 0.1]);
  });

  it("snaps to frames and to other keys", () => {
    const r = scaleKeys(clip(), [ref("a", 2)], 0, 0.77);
    expect(r.doc.tracks.a[2].t).toBe(1.5);
    // 2 scaled about 1 by 0.52 lands at 1.52, near b@1.5: the factor becomes 0.5
    const k = scaleKeys(clip(), [ref("a", 2)], 1, 0.52, { snap: "keys", tolerance: 0.05 });
    expect(k.doc.tracks.a[2].t).toBeCloseTo(1.5, 12);
  });
});

describe("deleteKeys", () => {
  it("removes keys and a track left empty", () => {
    const r = deleteKeys(clip(), [ref("a", 1), ref("led", 0)]);
    expect(times(r.doc, "a")).toEqual([0, 2]);
    expect("led" in r.doc.tracks).toBe(false);
    expect(r.selection).toEqual([]);
  });
});

describe("insertKeys", () => {
  const info = (name: string, type: DofInfo["type"], extra: Partial<DofInfo> = {}): DofInfo => ({
    name, type, min: 0, max: 1, rest: 0.25, velocity: 1, group: "Joints", ...extra,
  });

  it("keys the current curve value, in order, and selects the new keys", () => {
    const doc = clip();
    const r = insertKeys(doc, ["a", "b"], 0.5);
    expect(r.doc.tracks.a[1]).toEqual({ t: 0.5, v: evaluateKeys(doc.tracks.a, 0.5) });
    expect(r.doc.tracks.b[0]).toEqual({ t: 0.5, v: 2 });
    expect(r.selection).toEqual([ref("a", 1), ref("b", 0)]);
  });

  it("updates a key within half a frame, keeping its time and handles", () => {
    const doc: Clip = { fps: 10, tracks: { a: [{ t: 0, v: 0 }, { t: 1, v: 1, interp: "linear", right_type: "free", right: [0.1, 0] }] } };
    const r = insertKeys(doc, ["a"], 1.04, { a: 5 });
    expect(r.doc.tracks.a).toEqual([{ t: 0, v: 0 }, { t: 1, v: 5, interp: "linear", right_type: "free", right: [0.1, 0] }]);
    expect(r.selection).toEqual([ref("a", 1)]);
  });

  it("steps enum and colour values from the key before, and creates tracks from DofInfo rest values", () => {
    const r = insertKeys(clip(), [info("mouth", "enum"), info("led", "colour")], 0.9);
    expect(r.doc.tracks.mouth[1]).toEqual({ t: 0.9, v: "smile" });
    expect(r.doc.tracks.led[1]).toEqual({ t: 0.9, v: [1, 0, 0] });
    const fresh = insertKeys(clip(), [
      info("yaw", "continuous"),
      info("eyes", "colour", { restValue: [0.1, 0.2, 0.3] }),
      info("face", "enum", { rest: 1, options: ["x", "y"] }),
    ], 0.3);
    expect(fresh.doc.tracks.yaw).toEqual([{ t: 0.3, v: 0.25 }]);
    expect(fresh.doc.tracks.eyes).toEqual([{ t: 0.3, v: [0.1, 0.2, 0.3] }]);
    expect(fresh.doc.tracks.face).toEqual([{ t: 0.3, v: "y" }]);
    const relative = insertKeys({ ...clip(), relative: true }, [info("yaw", "continuous")], 0.3);
    expect(relative.doc.tracks.yaw).toEqual([{ t: 0.3, v: 0 }]);
  });

  it("keyPose keys exactly the pose's DoFs", () => {
    const doc = clip();
    const r = keyPose(doc, { b: 7, new_dof: 1 }, 1);
    expect(r.doc.tracks.b).toEqual([{ t: 0.5, v: 2 }, { t: 1, v: 7 }, { t: 1.5, v: 3 }]);
    expect(r.doc.tracks.new_dof).toEqual([{ t: 1, v: 1 }]);
    expect(r.doc.tracks.a).toBe(doc.tracks.a);
    expect(r.selection).toEqual([ref("b", 1), ref("new_dof", 0)]);
  });
});

describe("setKeyTime / setKeyValue", () => {
  it("moves one key, re-sorts and keeps the rest of the selection pointing at the same keys", () => {
    const doc = clip();
    const r = setKeyTime(doc, ref("a", 0), 1.5, [ref("a", 0), ref("a", 1), ref("b", 1)]);
    expect(times(r.doc, "a")).toEqual([1, 1.5, 2]);
    expect(r.selection).toEqual([ref("a", 0), ref("a", 1), ref("b", 1)]);
    expect(r.doc.tracks.a[1].v).toBe(0);
    const replaced = setKeyTime(doc, ref("a", 0), 2);
    expect(replaced.doc.tracks.a).toEqual([{ t: 1, v: 1 }, { t: 2, v: 0 }]);
    expect(replaced.selection).toEqual([ref("a", 1)]);
  });

  it("sets a value without touching other keys", () => {
    const doc = clip();
    const r = setKeyValue(doc, ref("mouth", 0), "grin");
    expect(r.doc.tracks.mouth[0].v).toBe("grin");
    expect(doc.tracks.mouth[0].v).toBe("smile");
    expect(r.selection).toEqual([ref("mouth", 0)]);
  });
});
