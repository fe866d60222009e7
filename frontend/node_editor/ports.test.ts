// The editor applies the backend's port rules and wiring rule (generated/blocks.json, generated/rules.json).
import { describe, expect, it } from "vitest";
import type { BlockEntry, PortType, Program } from "./api";
import blocks from "./generated/blocks.json";
import generatedRules from "./generated/rules.json";
import { connectionProblem, programToFlow } from "./graph";
import { accepts, CATEGORIES, defaultParams, portsOf } from "./ports";

const entries = blocks as unknown as BlockEntry[];
const catalog: Record<string, BlockEntry> = Object.fromEntries(entries.map((b) => [b.type, b]));
const programs = import.meta.glob<Program>("../../robots/*/programs/*.json", { eager: true, import: "default" });

describe("port rules", () => {
  it("come with the catalog for every block whose ports follow its parameters", () => {
    const dynamic = entries.filter((b) => b.dynamic_ports).map((b) => b.type).sort();
    expect(dynamic).toEqual(entries.filter((b) => b.port_rules.length).map((b) => b.type).sort());
    expect(dynamic).toEqual(expect.arrayContaining(["input", "layer_mixer"]));
  });
  it("give a new mixer its default layer and that layer's weight", () => {
    const mixer = catalog.layer_mixer;
    const ports = portsOf(mixer, defaultParams(mixer));
    expect(Object.keys(ports.inputs)).toEqual(["base", "base_weight"]);
    expect(ports.outputs).toEqual(mixer.outputs);
  });
  it("type an exposed input's output by its parameter, and keep the fixed ports of other blocks", () => {
    expect(portsOf(catalog.input, { name: "look", type: "vec3" }).outputs.value.type).toBe("vec3");
    expect(portsOf(catalog.input, { name: "n" }).outputs.value.type).toBe("float");
    expect(portsOf(catalog.sine, {})).toEqual({ inputs: catalog.sine.inputs, outputs: catalog.sine.outputs });
  });
  it("ignore malformed parameters (the server reports them)", () => {
    expect(portsOf(catalog.layer_mixer, { layers: "base" }).inputs).toEqual({});
    expect(portsOf(catalog.input, { name: "n", type: "tensor" }).outputs).toEqual({});
  });
});

describe("wiring rule", () => {
  it("is the backend's compatibility table", () => {
    for (const [target, sources] of Object.entries(generatedRules.accepts))
      for (const source of generatedRules.port_types) expect(accepts(target as PortType, source as PortType)).toBe(sources.includes(source));
    expect(accepts("float", "int")).toBe(true);
    expect(accepts("int", "float")).toBe(false);
  });
  it("orders and names the palette's categories as the backend does", () => {
    expect(CATEGORIES.map((c) => c.name)).toEqual(generatedRules.categories.map((c) => c.name));
    expect(new Set(entries.map((b) => b.category))).toEqual(new Set(CATEGORIES.map((c) => c.name)));
  });
  it("lets the editor draw every edge of the robot's bundled programs", () => {
    expect(Object.keys(programs).length).toBeGreaterThan(0);
    for (const [file, program] of Object.entries(programs)) {
      const { nodes } = programToFlow(program, catalog);
      for (const e of program.edges ?? []) {
        const others = (program.edges ?? []).filter((x) => x !== e).map((x) => ({
          id: "", source: x.from.node, sourceHandle: x.from.port, target: x.to.node, targetHandle: x.to.port,
        }));
        expect(connectionProblem(nodes, others, e.from.node, e.from.port, e.to.node, e.to.port), `${file}: ${JSON.stringify(e)}`).toBeNull();
      }
    }
  });
});
