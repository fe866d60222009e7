import { describe, expect, it } from "vitest";
import type { Clip } from "../model/types";
import { docEnd, frameAll, niceStep, panBy, rulerTicks, snapFrame, timeToX, xToTime, zoomAbout } from "./timeView";

describe("timeView", () => {
  const view = { t0: 1, t1: 3 };

  it("maps time to pixels and back", () => {
    expect(timeToX(view, 200, 1)).toBe(0);
    expect(timeToX(view, 200, 3)).toBe(200);
    expect(timeToX(view, 200, 2)).toBe(100);
    for (const x of [0, 13, 77.5, 200]) expect(timeToX(view, 200, xToTime(view, 200, x))).toBeCloseTo(x, 9);
  });

  it("zooms about a time, keeping it at the same pixel", () => {
    const z = zoomAbout(view, 1.5, 0.5);
    expect(z.t1 - z.t0).toBeCloseTo(1, 12);
    expect(timeToX(z, 200, 1.5)).toBeCloseTo(timeToX(view, 200, 1.5), 9);
    const out = zoomAbout(view, 3, 2);
    expect(out).toEqual({ t0: -1, t1: 3 });
  });

  it("clamps the zoom span", () => {
    const tiny = zoomAbout(view, 2, 1e-9);
    expect(tiny.t1 - tiny.t0).toBeCloseTo(1e-3, 12);
  });

  it("pans by seconds", () => {
    expect(panBy(view, 0.5)).toEqual({ t0: 1.5, t1: 3.5 });
  });

  it("frames the whole clip with margins", () => {
    const doc: Clip = { tracks: { a: [{ t: 0, v: 0 }, { t: 2, v: 1 }] }, anchors: { hit: 3 } };
    expect(docEnd(doc)).toBe(3);
    const f = frameAll(doc);
    expect(f.t0).toBeCloseTo(-0.15, 12);
    expect(f.t1).toBeCloseTo(3.15, 12);
    expect(docEnd({ ...doc, duration: 5 })).toBe(5);
    const empty = frameAll({ tracks: {} });
    expect(empty.t0).toBeLessThan(0);
    expect(empty.t1).toBeGreaterThan(2);
  });

  it("snaps to frames, never below 0", () => {
    expect(snapFrame(0.51, 30)).toBeCloseTo(15 / 30, 12);
    expect(snapFrame(-0.2, 30)).toBe(0);
  });

  it("picks nice steps at least minPx apart", () => {
    expect(niceStep(0.01, 70)).toBe(1);
    expect(niceStep(0.001, 70)).toBe(0.1);
    expect(niceStep(10, 70)).toBe(1200);
  });

  it("labels ticks in seconds and shows frame ticks only when zoomed in", () => {
    const wide = rulerTicks({ t0: 0, t1: 10 }, 1000, 30);
    expect(wide.major.map((t) => t.label).slice(0, 3)).toEqual(["0 s", "1 s", "2 s"]);
    expect(wide.frames).toBe(false);
    const close = rulerTicks({ t0: 0, t1: 1 }, 1000, 30);
    expect(close.frames).toBe(true);
    expect(close.minor.length).toBe(31);
    expect(close.minor[1]).toBeCloseTo(1 / 30, 12);
    expect(close.major[1].label).toBe("0.1 s");
  });
});
