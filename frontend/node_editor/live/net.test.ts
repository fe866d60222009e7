import { describe, expect, it } from "vitest";
import type { Telemetry } from "../api";
import { emptyLive, emptySamples, nextLive, nextSamples, snapshot, type Samples } from "../telemetry";
import { amountText, legendText, netCounts, recentCorrections, recentForBar, viewWindow, yRange } from "./net";

/** A telemetry message at `t` where the net corrects `neck` (velocity) on odd ticks and `ear` (jerk) every
 * third one. */
function msg(t: number): Telemetry {
  const channels: NonNullable<NonNullable<Telemetry["frame"]>["net"]>["channels"] = {};
  if (t % 2) channels.neck = { limit: "velocity", requested: 0.5, amount: 0.1 + t / 1000 };
  if (t % 3 === 0) channels.ear = { limit: "jerk", requested: 0.2, amount: 0.01 };
  const corrected = Object.keys(channels).length > 0;
  return {
    type: "telemetry", t: t / 30, seq: t, signals: {},
    frame: {
      position: { neck: 0.4, ear: 0.19 }, stage1: { neck: 0, ear: 0 }, classes: {}, corrected: Object.keys(channels),
      joints: { neck_joint: 0.4 },
      net: corrected ? { channels, joints: t % 2 ? { neck_joint: { limit: "position", requested: 0.55, amount: 0.15 } } : {} } : null,
      net_totals: { ticks: t, channels: { neck: t }, joints: {} },
    },
  };
}

function run(n: number, keep?: number): Samples {
  let s = emptySamples;
  for (let t = 0; t < n; t++) s = nextSamples(s, msg(t), keep);
  return s;
}

describe("the safety net in the samples", () => {
  it("keeps what was asked and what was delivered, per DoF and per joint, aligned with time", () => {
    const s = run(6);
    expect(s.final["dof:neck"]).toEqual([0.4, 0.4, 0.4, 0.4, 0.4, 0.4]);
    expect(s.requested["dof:neck"]).toEqual([0.4, 0.5, 0.4, 0.5, 0.4, 0.5]);  // delivered where the net passed
    expect(s.requested["joint:neck_joint"]).toEqual([0.4, 0.55, 0.4, 0.55, 0.4, 0.55]);
    expect(s.net[1]["dof:neck"]).toEqual([1, 0.101]);
    expect(s.net[3]["dof:ear"]).toEqual([3, 0.01]);
    expect(s.net[1]["joint:neck_joint"]).toEqual([4, 0.15]);
    expect(emptySamples.t).toEqual([]);  // the arrays are extended in place, never the empty ones
  });

  it("keeps the last `keep` samples, and a snapshot stays as it was", () => {
    const s = run(50, 20);
    expect(s.t).toHaveLength(20);
    expect(s.final["dof:neck"]).toHaveLength(20);
    const held = snapshot(s);
    const later = nextSamples(s, msg(50), 20);
    expect(later.t.at(-1)).toBeCloseTo(50 / 30);
    expect(held.t.at(-1)).toBeCloseTo(49 / 30);
  });

  it("counts the delivered frames in view and the ones the net corrected, by the limit enforced", () => {
    const s = run(12);
    const c = netCounts(s, ["dof:neck"]);
    expect(c.frames).toBe(12);
    expect(c.corrected).toBe(6);
    expect(c.byLimit).toEqual([0, 6, 0, 0, 0]);
    expect(legendText(c)).toBe("net corrected 6 (velocity 6, acceleration 0, jerk 0, position 0)");
    // several series: a frame counts once, by its most severe correction
    const both = netCounts(s, ["dof:neck", "dof:ear"]);
    expect(both.corrected).toBe(8);  // t = 1, 3, 5, 7, 9, 11 and 0, 6
    expect(both.byLimit).toEqual([0, 4, 0, 4, 0]);
    expect(netCounts(s, ["joint:neck_joint"]).byLimit[4]).toBe(6);
    expect(netCounts(s, ["dof:neck"], 10, 12).frames).toBe(2);
  });

  it("names the DoFs corrected in the last seconds, largest first, and forgets them after", () => {
    const s = run(12);
    const recent = recentCorrections(s, 10);
    expect(recent.map((r) => r.name)).toEqual(["neck", "ear"]);
    expect(recent[0].amount).toBeCloseTo(0.111);
    expect(recent[0].limit).toBe(1);
    const quiet = { ...s, t: [...s.t, 20], net: [...s.net, {}] };  // nothing corrected for 10 s and more
    expect(recentCorrections(quiet, 10)).toEqual([]);
    expect(amountText(Math.PI / 180 * 2.1, true)).toBe("2.1°");
    expect(amountText(0.0021, false)).toBe("2.1 mm");
  });

  it("shows a window of the last seconds, or one scrubbed back, and the limits on the y axis", () => {
    const t = Array.from({ length: 601 }, (_, i) => i / 10);  // 60 s at 10 Hz
    expect(viewWindow(t, 8)).toEqual([521, 601]);  // (52, 60]: 80 frames in 8 s
    expect(viewWindow(t, 8, 30)).toEqual([221, 301]);
    expect(viewWindow([], 8)).toEqual([0, 0]);
    expect(yRange([[0.1, 0.2]], [-0.35, 0.5])[0]).toBeLessThan(-0.35);
    expect(yRange([[0.1, null]], [null, 0.5])[1]).toBeGreaterThan(0.5);
  });
});

describe("live values", () => {
  it("keep the sparklines of the subscribed signals only, and the net's totals", () => {
    let live = nextLive(emptyLive, { ...msg(1), signals: { "breathe.out": 0.1 } });
    live = nextLive(live, { ...msg(2), signals: { "breathe.out": 0.2 } });
    expect(live.history["breathe.out"]).toEqual([0.1, 0.2]);
    expect(live.net?.ticks).toBe(2);
    live = nextLive(live, { ...msg(3), signals: {} });  // unsubscribed (a draft): no sparkline left
    expect(live.history).toEqual({});
  });
});

describe("the top bar's corrections", () => {
  it("names a joint only when its own DoF is not named already", () => {
    const s = run(6);
    const robot = { dofs: [{ name: "neck", joint: "neck_joint" }], joints: ["neck_joint", "jaw"], joint_frames: {} } as never;
    expect(recentForBar(s, robot).map((r) => r.key)).toEqual(["dof:neck", "dof:ear"]);
    const jawOnly = { ...s, net: s.net.map(() => ({ "joint:jaw": [4, 0.2] as [number, number] })) };
    expect(recentForBar(jawOnly, robot).map((r) => r.key)).toEqual(["joint:jaw"]);
  });
});
