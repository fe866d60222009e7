// The quick-add search: which blocks it offers for a dragged port or a wire, and the text filter.
import { describe, expect, it } from "vitest";
import type { BlockEntry, Program } from "./api";
import blocks from "./generated/blocks.json";
import { programToFlow } from "./graph";
import { layoutGraph, partitions } from "./autoLayout";
import { matching, offers } from "./quickAdd";
import { outputChain } from "./viewport";

const catalog: Record<string, BlockEntry> = Object.fromEntries((blocks as unknown as BlockEntry[]).map((b) => [b.type, b]));
const program = {
  format: "nutty-program/1", name: "p", max_level: 3, ui: {}, inputs: [],
  nodes: [
    { id: "rest", type: "rest_pose", params: {}, ui: { x: 0, y: 0 } },
    { id: "wave", type: "sine", params: {}, ui: { x: 0, y: 150 } },
    { id: "swell", type: "lfo", params: {}, ui: { x: 0, y: 300 } },
    { id: "mix", type: "layer_mixer", params: { layers: [{ name: "base" }, { name: "idle", mode: "additive" }] }, ui: { x: 300, y: 0 } },
    { id: "nmf", type: "nmf_stage2", params: {}, ui: { x: 600, y: 0 } },
    { id: "output", type: "output", params: {}, ui: { x: 900, y: 0 } },
  ],
  edges: [
    { from: { node: "rest", port: "out" }, to: { node: "mix", port: "base" } },
    { from: { node: "wave", port: "out" }, to: { node: "mix", port: "idle" } },
    { from: { node: "mix", port: "out" }, to: { node: "nmf", port: "in" } },
    { from: { node: "nmf", port: "out" }, to: { node: "output", port: "in" } },
  ],
} satisfies Program;
const { nodes, edges } = programToFlow(program, catalog);
const types = (list: { type: string }[]) => list.map((o) => o.type);

describe("quick-add offers", () => {
  it("offers every block but a second output, in palette order", () => {
    const all = types(offers(catalog, nodes, edges, { kind: "any" }));
    expect(all).not.toContain("output");
    expect(all.length).toBe(Object.keys(catalog).length - 1);
    expect(all.indexOf("sine")).toBeLessThan(all.indexOf("motion_filter"));
  });
  it("offers for a frame output the blocks with a frame input, naming the port to wire", () => {
    const list = offers(catalog, nodes, edges, { kind: "from", port: { node: "wave", handle: "out", side: "source" } });
    expect(types(list)).toContain("motion_filter");
    expect(types(list)).toContain("layer_mixer");
    expect(types(list)).not.toContain("sine");        // a sine's inputs are floats
    expect(types(list)).not.toContain("rest_pose");   // no inputs
    expect(list.find((o) => o.type === "motion_filter")!.input).toBe("in");
    expect(list.find((o) => o.type === "layer_mixer")!.input).toBe("base");
  });
  it("offers for a float output the blocks with a float input", () => {
    const list = offers(catalog, nodes, edges, { kind: "from", port: { node: "swell", handle: "value", side: "source" } });
    expect(list.find((o) => o.type === "sine")!.input).toBe("amplitude");
    expect(types(list)).not.toContain("safety_limiter");
  });
  it("offers for an input the blocks that can feed it (never a cycle)", () => {
    const list = offers(catalog, nodes, edges, { kind: "from", port: { node: "mix", handle: "idle_weight", side: "target" } });
    expect(list.find((o) => o.type === "lfo")!.output).toBe("value");
    expect(types(list)).not.toContain("rest_pose");    // frame output into a float input
  });
  it("offers on a wire only blocks with a fitting input and output", () => {
    const list = offers(catalog, nodes, edges, { kind: "insert", edge: "mix.out->nmf.in" });
    expect(types(list)).toContain("motion_filter");
    expect(types(list)).not.toContain("sine");
    expect(types(list)).not.toContain("lfo");
    expect(list.find((o) => o.type === "motion_filter")).toMatchObject({ input: "in", output: "out" });
  });
  it("filters by every word typed, titles that start with it first", () => {
    const all = offers(catalog, nodes, edges, { kind: "any" });
    expect(types(matching(all, "motion")).at(0)).toBe("motion_filter");
    expect(types(matching(all, "sine"))).toEqual(["sine"]);
    expect(matching(all, "zzzz")).toEqual([]);
    expect(matching(all, "")).toBe(all);
  });
});

describe("auto-layout", () => {
  it("puts columns in stage order: sources and signals, layers, stage 2, output", async () => {
    const pos = await layoutGraph(nodes, edges, catalog);
    expect(pos.rest.x).toBeLessThan(pos.mix.x);
    expect(pos.wave.x).toBeLessThan(pos.mix.x);
    expect(pos.mix.x).toBeLessThan(pos.nmf.x);
    expect(pos.nmf.x).toBeLessThan(pos.output.x);
    // nodes of one column do not overlap
    expect(Math.abs(pos.rest.y - pos.wave.y)).toBeGreaterThanOrEqual(120);
  });
  it("never puts a block left of what feeds it", () => {
    const part = partitions(nodes, [...edges, { id: "x", source: "nmf", sourceHandle: "out", target: "wave", targetHandle: "amplitude" }], catalog);
    expect(part.wave).toBe(part.nmf);
  });
});

describe("opening frame", () => {
  it("follows the output's frame feeds back to the first block mixing several", () => {
    expect(outputChain(nodes, edges, catalog)).toEqual(["output", "nmf", "mix"]);
  });
});
