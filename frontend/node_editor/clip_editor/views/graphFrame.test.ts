import { describe, expect, it } from "vitest";
import type { Clip, DofInfo } from "../model/types";
import { graphFrame } from "./graphFrame";

const info = (name: string): DofInfo => ({ name, group: "Joints", type: "continuous", min: -2, max: 2, rest: 0, velocity: 1 });

describe("graphFrame (Home in the graph editor)", () => {
  const doc: Clip = { tracks: { a: [{ t: 1, v: 0, interp: "linear" }, { t: 3, v: 1 }], b: [{ t: 0, v: 5 }] } };

  it("frames the shown curves' keys in time and their display values", () => {
    const f = graphFrame(doc, [info("a")], { a: 10 }, null);
    expect(f.view.t0).toBeCloseTo(0.9, 9);
    expect(f.view.t1).toBeCloseTo(3.1, 9);
    expect(f.values.v0).toBeCloseTo(10 - 0.08, 9);
    expect(f.values.v1).toBeCloseTo(11 + 0.08, 9);
  });

  it("includes the ghost (absolute values, from time 0 at its rate)", () => {
    const ghost = { engine_rate: 100, params: {}, preset: "A", rate: 1, tracks: { a: [-1, 0, 0, 0, 0, 2] } };
    const f = graphFrame(doc, [info("a")], {}, ghost);
    expect(f.view.t0).toBeCloseTo(-0.25, 9);
    expect(f.view.t1).toBeCloseTo(5.25, 9);
    expect(f.values.v0).toBeLessThan(-1);
    expect(f.values.v1).toBeGreaterThan(2);
  });

  it("falls back to the DoFs' limits when no shown DoF has keys", () => {
    const f = graphFrame(doc, [info("c")], {}, null);
    expect(f.values.v0).toBeLessThan(-2);
    expect(f.values.v1).toBeGreaterThan(2);
  });
});
