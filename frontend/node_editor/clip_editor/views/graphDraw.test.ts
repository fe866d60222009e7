import { describe, expect, it } from "vitest";
import type { Plot } from "./graphDraw";
import {
  curvePath, extent, frameValues, groupSpans, sampleTimes, samplesPath, spansPath, valueTicks, valueToY, yToValue, zoomValues,
} from "./graphDraw";

const plot: Plot = { view: { t0: 0, t1: 1 }, values: { v0: -1, v1: 1 }, width: 100, height: 50 };

/** [x, y] points of an M/L path (one sub-path per entry). */
function points(d: string): [number, number][][] {
  return d.split("M").filter(Boolean).map((sub) => sub.split("L").map((p) => p.trim().split(" ").map(Number) as [number, number]));
}

describe("graphDraw", () => {
  it("maps values to y (up is larger) and back", () => {
    expect(valueToY(plot, 1)).toBe(0);
    expect(valueToY(plot, -1)).toBe(50);
    expect(yToValue(plot, 25)).toBe(0);
  });

  it("zooms values about a value", () => {
    const z = zoomValues({ v0: -1, v1: 1 }, 1, 0.5);
    expect(z).toEqual({ v0: 0, v1: 1 });
  });

  it("frames values with margins and widens flat ranges", () => {
    const f = frameValues(0, 1);
    expect(f.v0).toBeCloseTo(-0.08, 12);
    expect(f.v1).toBeCloseTo(1.08, 12);
    expect(frameValues(2, 2)).toEqual({ v0: 1.5, v1: 2.5 });
    expect(frameValues(NaN, 1)).toEqual({ v0: -1, v1: 1 });
  });

  it("samples every 2 px and around key times", () => {
    const ts = sampleTimes(plot, -Infinity, Infinity, [0.5]);
    expect(ts[0]).toBe(0);
    expect(ts[ts.length - 1]).toBe(1);
    expect(ts.length).toBe(2 + 49 + 2);
    expect(ts).toContain(0.5);
    expect(ts.some((t) => t < 0.5 && t > 0.5 - 1e-6)).toBe(true);
    for (let i = 1; i < ts.length; i++) expect(ts[i]).toBeGreaterThanOrEqual(ts[i - 1]);
  });

  it("draws a step sharply at a constant key", () => {
    const step = (t: number) => (t < 0.5 ? -1 : 1);
    const pts = points(curvePath(plot, step, [0.5]))[0];
    const i = pts.findIndex(([x, y]) => x === 50 && y === 0);
    expect(i).toBeGreaterThan(0);
    expect(pts[i - 1]).toEqual([50, 50]);
  });

  it("adds the display offset", () => {
    const pts = points(curvePath(plot, () => 0, [], 0.5))[0];
    expect(pts.every(([, y]) => y === 12.5)).toBe(true);
  });

  it("cuts over-limit spans out of the curve, one sub-path each, skipping spans out of view", () => {
    const d = spansPath(plot, [{ t_start: 0.1, t_end: 0.2 }, { t_start: 0.6, t_end: 0.7 }, { t_start: 2, t_end: 3 }], (t) => t, []);
    const subs = points(d);
    expect(subs.length).toBe(2);
    expect(subs[0][0][0]).toBe(10);
    expect(subs[0][subs[0].length - 1][0]).toBe(20);
    expect(subs[1][0][0]).toBe(60);
    expect(subs[1][subs[1].length - 1][0]).toBe(70);
  });

  it("widens a one-sample span so it shows", () => {
    const subs = points(spansPath(plot, [{ t_start: 0.5, t_end: 0.5 }], () => 0, []));
    expect(subs[0].length).toBeGreaterThanOrEqual(2);
    expect(subs[0][subs[0].length - 1][0] - subs[0][0][0]).toBeCloseTo(1, 5);
  });

  it("groups spans by key in order", () => {
    const g = groupSpans([{ t_start: 0, t_end: 1, k: "a" }, { t_start: 1, t_end: 2, k: "b" }, { t_start: 2, t_end: 3, k: "a" }], (s) => s.k);
    expect([...g.keys()]).toEqual(["a", "b"]);
    expect(g.get("a")?.map((s) => s.t_start)).toEqual([0, 2]);
  });

  it("draws ghost samples from time 0 at their rate, decimated to the pixels", () => {
    const values = Array.from({ length: 11 }, (_v, i) => i / 10);
    const pts = points(samplesPath(plot, values, 10))[0];
    expect(pts.length).toBe(11);
    expect(pts[10]).toEqual([100, 0]);
    const dense = Array.from({ length: 1001 }, () => 0);
    const dpts = points(samplesPath(plot, dense, 1000))[0];
    expect(dpts.length).toBeLessThanOrEqual(52);
    expect(dpts[dpts.length - 1][0]).toBe(100);
    expect(samplesPath(plot, [], 10)).toBe("");
  });

  it("labels value ticks", () => {
    const ticks = valueTicks({ ...plot, height: 200 });
    expect(ticks.map((t) => t.label)).toEqual(["-1.0", "-0.5", "0.0", "0.5", "1.0"]);
    expect(valueTicks(plot).map((t) => t.label)).toEqual(["0"]);
    expect(valueTicks({ ...plot, height: 250 }).map((t) => t.label)).toContain("0.25");
  });

  it("finds extents ignoring non-finite values", () => {
    expect(extent([3, NaN, -2, Infinity])).toEqual([-2, 3]);
    expect(extent([])).toBeNull();
  });
});
