import { describe, expect, it } from "vitest";
import blocks from "./generated/blocks.json";
import type { BlockEntry, Program } from "./api";
import { autoLayout, connectionProblem, flowToProgram, pasteClipboard, programToFlow } from "./graph";
import * as H from "./history";
import { fieldsFromSchema, hexToRgb, rgbToHex } from "./schemaForm";
import { classify, JERK, OK, VELOCITY } from "./trajectory";

const catalog: Record<string, BlockEntry> = Object.fromEntries((blocks as unknown as BlockEntry[]).map((b) => [b.type, b]));

const program = {
  format: "nutty-program/1", name: "t", max_level: 3, ui: {},
  inputs: [{ name: "amp", type: "float", default: 0.1, min: 0, max: 1 }],
  nodes: [
    { id: "in_amp", type: "input", params: { name: "amp", type: "float" }, ui: { x: 0, y: 200 } },
    { id: "wave", type: "sine", params: { amplitude: 0.2 }, ui: { x: 0, y: 0, colour: "teal" } },
    { id: "mix", type: "layer_mixer", params: { layers: [{ name: "base" }, { name: "idle", mode: "additive" }] }, ui: { x: 300, y: 0 } },
    { id: "output", type: "output", params: {}, ui: { x: 600, y: 0 } },
  ],
  edges: [
    { from: { node: "in_amp", port: "value" }, to: { node: "wave", port: "amplitude" } },
    { from: { node: "wave", port: "out" }, to: { node: "mix", port: "idle" } },
    { from: { node: "mix", port: "out" }, to: { node: "output", port: "in" } },
  ],
} satisfies Program;

describe("graph <-> program", () => {
  it("round-trips losslessly, editor data included", () => {
    const { nodes, edges, meta } = programToFlow(program, catalog);
    expect(flowToProgram(nodes, edges, meta)).toEqual(program);
  });
  it("derives dynamic ports by the backend's rules: a frame input and a weight input per layer, typed exposed inputs", () => {
    const { nodes, edges } = programToFlow(program, catalog);
    const mix = nodes.find((n) => n.id === "mix")!;
    expect(Object.keys(mix.data.inputs)).toEqual(["base", "idle", "base_weight", "idle_weight"]);
    expect(mix.data.inputs.idle_weight.type).toBe("float");
    expect(mix.data.inputs.idle.doc).toBe("layer 'idle' (additive)");
    expect(mix.data.inputs.base.doc).toBe("layer 'base' (override)");  // the item's default mode, as the backend fills it
    expect(edges.find((e) => e.source === "in_amp")!.data!.type).toBe("float");
  });
  it("wires a signal into a mixer's layer weight, and refuses a frame there", () => {
    const { nodes, edges } = programToFlow(program, catalog);
    expect(connectionProblem(nodes, edges, "in_amp", "value", "mix", "idle_weight")).toBeNull();
    expect(connectionProblem(nodes, edges, "wave", "out", "mix", "base_weight")).toMatch(/cannot connect frame output/);
  });
  it("lays out unpositioned programs left to right by depth", () => {
    const pos = autoLayout({ ...program, nodes: program.nodes.map((n) => ({ ...n, ui: {} })) });
    expect(pos.in_amp.x).toBeLessThan(pos.wave.x);
    expect(pos.wave.x).toBeLessThan(pos.mix.x);
    expect(pos.mix.x).toBeLessThan(pos.output.x);
  });
  it("refuses wrong types, a second edge into an input, and cycles — with a reason", () => {
    const { nodes, edges } = programToFlow(program, catalog);
    expect(connectionProblem(nodes, edges, "in_amp", "value", "mix", "base")).toMatch(/cannot connect float output/);
    expect(connectionProblem(nodes, edges, "wave", "out", "mix", "idle")).toMatch(/already has an edge/);
    expect(connectionProblem(nodes, edges, "mix", "out", "mix", "base")).toMatch(/cannot feed itself/);
    expect(connectionProblem(nodes, edges, "wave", "out", "mix", "base")).toBeNull();
  });
  it("pastes copies with fresh ids and their inner connections", () => {
    const { nodes, edges } = programToFlow(program, catalog);
    const clip = { nodes: nodes.filter((n) => n.id === "in_amp" || n.id === "wave"), edges: edges.filter((e) => e.source === "in_amp") };
    const pasted = pasteClipboard(nodes, clip);
    expect(pasted.nodes.map((n) => n.id)).toEqual(["in_amp_2", "wave_2"]);
    expect(pasted.edges).toHaveLength(1);
    expect(pasted.edges[0].source).toBe("in_amp_2");
    expect(pasted.edges[0].target).toBe("wave_2");
  });
});

describe("undo/redo", () => {
  it("walks back and forth and drops redo after a new edit", () => {
    let h = H.init(1);
    h = H.push(h, 2);
    h = H.push(h, 3);
    h = H.undo(h);
    expect(h.present).toBe(2);
    h = H.redo(h);
    expect(h.present).toBe(3);
    h = H.undo(H.undo(h));
    expect(h.present).toBe(1);
    h = H.push(h, 9);
    expect(h.future).toEqual([]);
    expect(H.redo(h).present).toBe(9);
  });
  it("ignores identical states and non-history replacements", () => {
    let h = H.init("a");
    h = H.push(h, "a");
    expect(h.past).toEqual([]);
    h = H.replace(h, "b");
    expect(H.undo(h).present).toBe("b");
  });
});

describe("schema-driven forms", () => {
  it("maps bounded numbers to sliders, enums to dropdowns, selectors to DoF pickers", () => {
    const sine = fieldsFromSchema(catalog.sine.params_schema);
    const amp = sine.find((f) => f.name === "amplitude")!;
    expect(amp.kind).toBe("slider");
    expect([amp.min, amp.max]).toEqual([0, 1]);  // the slider spans the soft range (x-soft)
    expect([amp.number?.hardMin, amp.number?.hardMax]).toEqual([0, 10]);  // typing goes up to the hard one
    expect(sine.find((f) => f.name === "dofs")!.kind).toBe("dofs");
    const nmf = fieldsFromSchema(catalog.nmf_stage2.params_schema);
    expect(nmf.find((f) => f.name === "preset")!.options).toContain("D");
    const sigma = nmf.find((f) => f.name === "sigma")!;
    expect(sigma.kind).toBe("slider");
    expect(sigma.nullable).toBe(true);
    expect(nmf.find((f) => f.name === "bypass")!.kind).toBe("bool");
    expect(fieldsFromSchema(catalog.pose.params_schema).find((f) => f.name === "posture")!.kind).toBe("posture");
  });
  it("converts colours both ways", () => {
    expect(rgbToHex([1, 0.5, 0])).toBe("#ff8000");
    expect(hexToRgb("#ff8000")).toEqual([1, 0.502, 0]);
  });
});

describe("trajectory-helper colouring", () => {
  it("marks velocity and jerk violations, most severe first", () => {
    const x = [0, 0, 0, 0, 1, 1, 1];
    const cls = classify(x, 10, 5, 1e9, 1e9);
    expect(cls[4]).toBe(VELOCITY);
    expect(classify(x, 10, 5, 50, 100)[4]).toBe(JERK);
    expect(cls[0]).toBe(OK);
  });
});
