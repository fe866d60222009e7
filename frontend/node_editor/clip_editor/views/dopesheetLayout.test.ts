import { describe, expect, it } from "vitest";
import type { Clip, DofInfo } from "../model/types";
import { keysInBox, layoutHeight, layoutRows, ROW_H, summaryTimes, unionRefs, visibleKeys } from "./dopesheetLayout";

const info = (name: string, group: string): DofInfo => ({ name, group, type: "continuous", min: -1, max: 1, rest: 0, velocity: 1 });
const rows = [
  { group: "Joints", dofs: [info("head_pan", "Joints"), info("head_tilt", "Joints")] },
  { group: "Display", dofs: [info("eyes", "Display")] },
];
const doc: Clip = {
  tracks: {
    head_pan: [{ t: 0, v: 0 }, { t: 1, v: 0.5 }],
    ghost_dof: [{ t: 0.5, v: 1 }],
  },
};

describe("dopesheet layout", () => {
  it("lists every DoF of the rows, greys those without a track, and adds unknown tracks as Other", () => {
    const l = layoutRows(doc, rows, new Set());
    expect(l.map((r) => (r.kind === "group" ? `[${r.group}]` : r.dof))).toEqual(
      ["[Joints]", "head_pan", "head_tilt", "[Display]", "eyes", "[Other]", "ghost_dof"],
    );
    const tilt = l.find((r) => r.kind === "dof" && r.dof === "head_tilt");
    expect(tilt?.kind === "dof" && tilt.hasTrack).toBe(false);
    expect(l.map((r) => r.y)).toEqual([0, 1, 2, 3, 4, 5, 6].map((i) => i * ROW_H));
    expect(layoutHeight(l)).toBe(7 * ROW_H);
  });

  it("hides a collapsed group's DoFs and their keys", () => {
    const l = layoutRows(doc, rows, new Set(["Joints"]));
    expect(l.filter((r) => r.kind === "dof").map((r) => (r.kind === "dof" ? r.dof : ""))).toEqual(["eyes", "ghost_dof"]);
    expect(visibleKeys(doc, l)).toEqual([{ dof: "ghost_dof", index: 0 }]);
  });

  it("box-selects keys whose centres lie inside, any corner order", () => {
    const l = layoutRows(doc, rows, new Set());
    const view = { t0: 0, t1: 2 };
    // head_pan row centre at 1.5 rows; t=1 -> x=100 at width 200
    const hit = keysInBox(doc, l, view, 200, { x0: 150, y0: ROW_H * 2, x1: 50, y1: ROW_H });
    expect(hit).toEqual([{ dof: "head_pan", index: 1 }]);
    const all = keysInBox(doc, l, view, 200, { x0: -5, y0: 0, x1: 205, y1: 1000 });
    expect(all).toEqual([{ dof: "head_pan", index: 0 }, { dof: "head_pan", index: 1 }, { dof: "ghost_dof", index: 0 }]);
  });

  it("summarises a group's key times", () => {
    const d: Clip = { tracks: { a: [{ t: 0, v: 0 }, { t: 1, v: 0 }], b: [{ t: 1, v: 0 }, { t: 0.5, v: 0 }] } };
    expect(summaryTimes(d, ["a", "b", "c"])).toEqual([0, 0.5, 1]);
  });

  it("unions selections without duplicates", () => {
    expect(unionRefs([{ dof: "a", index: 0 }], [{ dof: "a", index: 0 }, { dof: "b", index: 1 }])).toEqual([
      { dof: "a", index: 0 },
      { dof: "b", index: 1 },
    ]);
  });
});
