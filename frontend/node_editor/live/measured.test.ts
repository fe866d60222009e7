import { describe, expect, it } from "vitest";
import type { JointReading, Telemetry } from "../api";
import { emptySamples, nextSamples, snapshot, type Samples } from "../telemetry";
import { measuredKeys, trackingInView, trackingText } from "./measured";
import type { SeriesInfo } from "./net";

const reading = (measured: number | null, saturated = false): JointReading => ({
  commanded: 0.4, measured, error: measured == null ? null : 0.4 - measured, effort: null, saturated,
});

/** A telemetry frame at tick `t` delivering neck_joint = 0.4, with the motors' readings if given. */
function msg(t: number, measured?: Record<string, JointReading>): Telemetry {
  return {
    type: "telemetry", t: t / 30, seq: t, signals: {}, measured,
    frame: { position: { neck: 0.4 }, stage1: { neck: 0 }, classes: {}, corrected: [], joints: { neck_joint: 0.4, slide: 0.01 }, net: null },
  };
}

const joint = (name: string, angular = true): SeriesInfo => ({ key: `joint:${name}`, label: `${name} (joint)`, name, lo: null, hi: null, angular });
const dof: SeriesInfo = { key: "dof:neck", label: "neck", name: "neck", lo: null, hi: null, angular: true };

/** Two ticks unread, then neck_joint read (its third read missed, its fifth saturated), then unread again. */
function run(keep?: number): Samples {
  const frames = [
    msg(0), msg(1),
    msg(2, { neck_joint: reading(0.39) }),
    msg(3, { neck_joint: reading(0.385) }),
    msg(4, { neck_joint: reading(null) }),
    msg(5, { neck_joint: reading(0.41) }),
    msg(6, { neck_joint: reading(0.38, true) }),
    msg(7),
  ];
  return frames.reduce((s, m) => nextSamples(s, m, keep), emptySamples);
}

describe("the motors' readings in the samples", () => {
  it("are kept per joint in step with time, with gaps where nothing was read", () => {
    const s = run();
    expect(s.t).toHaveLength(8);
    expect(s.measured["joint:neck_joint"]).toEqual([null, null, 0.39, 0.385, null, 0.41, 0.38, null]);
    expect(s.error["joint:neck_joint"]?.map((e) => e && +e.toFixed(3))).toEqual([null, null, 0.01, 0.015, null, -0.01, 0.02, null]);
    expect(s.saturated["joint:neck_joint"]).toEqual([null, null, false, false, false, false, true, null]);
    expect(Object.keys(s.measured)).toEqual(["joint:neck_joint"]);  // a joint never read has no series
  });

  it("are left alone by messages without readings, kept to the last `keep`, and held by a snapshot", () => {
    const unread = [msg(0), msg(1)].reduce((s, m) => nextSamples(s, m), emptySamples);
    expect(unread.measured).toEqual({});
    expect(emptySamples.measured).toEqual({});
    const s = run(5);
    expect(s.measured["joint:neck_joint"]).toEqual([0.385, null, 0.41, 0.38, null]);
    const held = snapshot(s);
    nextSamples(s, msg(8, { neck_joint: reading(0.4) }), 5);
    expect(held.measured["joint:neck_joint"]).toEqual([0.385, null, 0.41, 0.38, null]);
    expect(held.saturated["joint:neck_joint"]).toEqual([false, false, false, true, null]);
    expect(s.measured["joint:neck_joint"].at(-1)).toBe(0.4);
  });
});

describe("the curve panel's measured line and legend", () => {
  it("names the joint series read in view, with their peak error and saturated frames", () => {
    const s = run();
    const all = trackingInView(s, [dof, joint("neck_joint"), joint("slide", false)], 0, 8);
    expect(all.map((t) => t.key)).toEqual(["joint:neck_joint"]);  // a DoF, or a joint not read: no line
    expect(all[0].peak).toBeCloseTo(0.02);
    expect(all[0].saturated).toBe(1);
    expect(trackingText(all[0])).toBe("neck_joint: tracking 0.020 rad peak, ⚠ saturated 1 frame");
    const early = trackingInView(s, [joint("neck_joint")], 2, 5);  // the saturated read out of view
    expect(trackingText(early[0])).toBe("neck_joint: tracking 0.015 rad peak");
    expect(trackingInView(s, [joint("neck_joint")], 0, 2)).toEqual([]);  // nothing read in view
    expect(measuredKeys(s)).toEqual(new Set(["joint:neck_joint"]));
  });

  it("shows a prismatic joint's error in mm, and several saturated frames", () => {
    expect(trackingText({ key: "joint:slide", name: "slide", angular: false, peak: 0.0021, saturated: 3 }))
      .toBe("slide: tracking 2.1 mm peak, ⚠ saturated 3 frames");
    expect(trackingText({ key: "joint:a", name: "a", angular: true, peak: null, saturated: 0 })).toBe("a: tracking — peak");
  });
});
