import { describe, expect, it } from "vitest";
import type { ValidationReport } from "../api";
import type { FlowEdge } from "../graph";
import {
  MINUS, cookText, drivenBy, firstWarnedNode, heat, heatColour, heatScale, maskSummary, moved, mutePlan, plotted, signed,
  soloPlan, stats, summarise, tick, ticks, unsoloPlan, warningsByNode,
} from "./logic";

describe("numbers with their sign", () => {
  it("always shows the sign, with a real minus", () => {
    expect(signed(0.12)).toBe("+0.120");
    expect(signed(-0.031)).toBe(`${MINUS}0.031`);
    expect(signed(-250)).toBe(`${MINUS}250`);
    expect(signed(0)).toBe("0.000");
    expect(signed(-0.00001)).toBe("0.000");  // rounds to zero: no sign
  });
  it("axis ticks keep the minus of negative values", () => {
    expect(tick(-0.05)).toBe(`${MINUS}0.05`);
    expect(tick(0.05)).toBe("0.05");
    expect(ticks([-0.1, -0.05, 0, 0.05, 0.1])).toEqual([`${MINUS}0.10`, `${MINUS}0.05`, "0.00", "0.05", "0.10"]);
    expect(ticks([-2, 0, 2])).toEqual([`${MINUS}2`, "0", "2"]);
    expect(ticks([-0.002, 0, 0.002])[0]).toBe(`${MINUS}0.002`);
  });
  it("summarises frames by DoF count and first DoFs", () => {
    expect(summarise({ mask: 4, values: { a: 0.1, b: -0.2, c: 0, d: 1 } })).toBe(`4 DoFs · a +0.100, b ${MINUS}0.200, c 0.000, …`);
    expect(summarise({ mask: 0, values: {} })).toBe("empty frame");
    expect(summarise(-1.5)).toBe(`${MINUS}1.500`);
    expect(summarise(undefined)).toBe("–");
    expect(plotted({ mask: 1, values: { x: -0.3 } })).toBe(-0.3);
    expect(plotted("text")).toBeUndefined();
    expect(stats([1, -2, 3, 0.5])).toEqual({ min: -2, max: 3, last: 0.5 });
    expect(stats([])).toBeUndefined();
  });
});

describe("cook-time heat", () => {
  it("is 0 for nothing, 1 for the most expensive node, monotonic between", () => {
    const scale = heatScale([10, 40, 160]);
    expect(scale).toBe(160);
    expect(heat(160, scale)).toBe(1);
    expect(heat(0, scale)).toBe(0);
    expect(heat(10, scale)).toBeLessThan(heat(40, scale));
    expect(heat(1000, scale)).toBe(1);
    expect(heat(5, 0)).toBe(0);
  });
  it("against a tick budget: a light program stays cool, never hotter than its top node allows", () => {
    expect(heatScale([10, 20], 10000)).toBe(200);  // ten times the top node, below the budget
    expect(heatScale([5000, 20], 2000)).toBe(5000);  // over budget: the top node is the scale
  });
  it("goes from blue to red", () => {
    expect(heatColour(0)).toMatch(/^hsl\(210,/);
    expect(heatColour(1)).toMatch(/^hsl\(0,/);
    expect(heatColour(0.5)).toMatch(/^hsl\(105,/);
    expect(heatColour(7)).toBe(heatColour(1));
  });
  it("writes µs and ms", () => {
    expect(cookText(42.4)).toBe("42 µs");
    expect(cookText(3.25)).toBe("3.3 µs");
    expect(cookText(1300)).toBe("1.3 ms");
    expect(cookText(25000)).toBe("25 ms");
  });
});

describe("report and wires", () => {
  const issue = (node: string | null, message: string, port: string | null = null) =>
    ({ code: "w", column: null, line: null, message, node, path: null, port });
  const report: ValidationReport = {
    valid: true, level: 2, errors: [issue("a", "bad")],
    warnings: [issue(null, "program-wide"), issue("mix", "layer 'x' has weight 0", "x"), issue("mix", "empty"), issue("b", "hm")],
  };
  it("groups warnings by node, apart from errors", () => {
    expect(warningsByNode(report)).toEqual({ mix: ["x: layer 'x' has weight 0", "empty"], b: ["hm"] });
    expect(firstWarnedNode(report)).toBe("mix");
    expect(firstWarnedNode(null)).toBeNull();
  });
  it("finds the wire into a parameter's same-named input", () => {
    const edges: FlowEdge[] = [
      { id: "1", source: "amp", sourceHandle: "value", target: "breathe", targetHandle: "amplitude" },
      { id: "2", source: "x", sourceHandle: "out", target: "mix", targetHandle: "base" },
    ];
    expect(drivenBy(edges, "breathe", "amplitude")).toEqual({ node: "amp", port: "value" });
    expect(drivenBy(edges, "breathe", "frequency")).toBeNull();
    expect(drivenBy(edges, "mix", "amplitude")).toBeNull();
  });
});

describe("layer stack", () => {
  const layers = [
    { name: "base", active: true }, { name: "idle", active: true }, { name: "gesture", active: false }, { name: "face", active: true },
  ];
  it("solo switches off every other active layer and turns the soloed one on", () => {
    const { switches, saved } = soloPlan(layers, "gesture");
    expect(saved).toEqual(["base", "idle", "face"]);
    expect(switches).toEqual([
      { layer: "base", active: false }, { layer: "idle", active: false }, { layer: "gesture", active: true }, { layer: "face", active: false },
    ]);
  });
  it("un-solo restores exactly the saved active set", () => {
    const during = [{ name: "base", active: false }, { name: "idle", active: false }, { name: "gesture", active: true }, { name: "face", active: false }];
    expect(unsoloPlan(during, ["base", "idle", "face"])).toEqual([
      { layer: "base", active: true }, { layer: "idle", active: true }, { layer: "gesture", active: false }, { layer: "face", active: true },
    ]);
    expect(unsoloPlan(layers, ["base", "idle", "face"])).toEqual([]);  // nothing changed: nothing to send
  });
  it("mute toggles one layer", () => {
    expect(mutePlan({ name: "idle", active: true })).toEqual({ layer: "idle", active: false });
    expect(mutePlan({ name: "idle", active: false })).toEqual({ layer: "idle", active: true });
  });
  it("moves a layer up or down, not past the ends", () => {
    expect(moved(["a", "b", "c"], 1, -1)).toEqual(["b", "a", "c"]);
    expect(moved(["a", "b", "c"], 1, 1)).toEqual(["a", "c", "b"]);
    const same = ["a", "b"];
    expect(moved(same, 0, -1)).toBe(same);
    expect(moved(same, 1, 1)).toBe(same);
  });
  it("summarises masks", () => {
    expect(maskSummary(["*"])).toBe("all DoFs");
    expect(maskSummary(undefined)).toBe("all DoFs");
    expect(maskSummary(["eye_leds"])).toBe("eye_leds");
    expect(maskSummary(["a", "b", "c", "d", "e"])).toBe("a, b, c +2");
  });
});

describe("telemetry", () => {
  it("keeps the last cook times between the messages that carry them", async () => {
    const { emptyLive, nextLive } = await import("../telemetry");
    const profile = { apu: { mean_us: 1, p50_us: 1, p99_us: 1, max_us: 1 }, every: 10, window: 300, samples: 3, nodes: [] };
    let live = nextLive(emptyLive, { type: "telemetry", t: 1, seq: 1, profile });
    live = nextLive(live, { type: "telemetry", t: 2, seq: 2 });
    expect(live.profile).toBe(profile);
    expect(live.t).toBe(2);
  });
  it("puts watched signals first only when the plain subscription could miss them", async () => {
    const { withWatched } = await import("./logic");
    const all = [{ node: "a", port: "out" }, { node: "b", port: "out" }];
    expect(withWatched(all, [])).toBe(all);
    expect(withWatched(all, [{ node: "b", port: "out" }])).toBe(all);  // already subscribed
    const extra = [{ node: "c", port: "value" }];
    const merged = withWatched(all, extra);
    expect(merged).toEqual([{ node: "c", port: "value" }, ...all]);
    expect(withWatched(all, extra)).toBe(merged);  // the same list: no new subscription
    const many = Array.from({ length: 250 }, (_, i) => ({ node: `n${i}`, port: "out" }));
    expect(withWatched(many, [{ node: "n240", port: "out" }])[0]).toEqual({ node: "n240", port: "out" });
  });
});
