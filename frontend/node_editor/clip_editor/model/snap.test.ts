// Frame grid and nearest-time snapping.
import { describe, expect, it } from "vitest";
import { clipFps, frameTime, nearestTime, snapDelta, snapToFrames, timeFrame } from "./snap";

describe("snap", () => {
  it("rounds to the frame grid exactly (0.1 at 30 fps is 0.1)", () => {
    expect(snapToFrames(0.1 + 1e-4, 30)).toBe(0.1);
    expect(snapToFrames(1.2345, 24)).toBe(30 / 24);
    expect(frameTime(3, 30)).toBe(0.1);
    expect(timeFrame(0.5, 30)).toBe(15);
  });

  it("picks the clip's fps, else 30", () => {
    expect(clipFps({ tracks: {} })).toBe(30);
    expect(clipFps({ tracks: {}, fps: 24 })).toBe(24);
    expect(clipFps({ tracks: {}, fps: 24 }, 60)).toBe(60);
  });

  it("finds the nearest candidate within the tolerance", () => {
    expect(nearestTime(1.02, [0, 1, 1.1], 0.05)).toBe(1);
    expect(nearestTime(1.5, [0, 1], 0.05)).toBeNull();
  });

  it("snapDelta lands the moved time nearest to a candidate on it", () => {
    expect(snapDelta([0.98, 2.4], [1, 2.5], 0.2)).toBeCloseTo(0.02, 12);
    expect(snapDelta([0.5], [1], 0.2)).toBe(0);
  });
});
