// The canvas's edits: renaming a node in place (F2), ungrouping a subgraph node, where a wire dropped on a
// block's body goes and which ports dim while it is dragged, and the open subgraph's Group Input / Output.
import { describe, expect, it } from "vitest";
import interactiveJson from "../../robots/nutty_desk/programs/interactive.json";
import blocks from "./generated/blocks.json";
import type { BlockEntry, Program } from "./api";
import { flowToProgram } from "./graph";
import { groupIO, GROUP_INPUT, GROUP_OUTPUT } from "./groupIO";
import { renameProblem } from "./rename";
import { initialState, reducer, structureKey, type EditorState } from "./store/state";
import { groupCandidates } from "./subgraphs";
import { dropOnBody, incompatiblePorts, portKey } from "./wireDrop";

const catalog: Record<string, BlockEntry> = Object.fromEntries((blocks as unknown as BlockEntry[]).map((b) => [b.type, b]));
const interactive = interactiveJson as Program;
const IDLE = ["breathe", "wander", "wander_filter", "weight_shift", "blink", "eyelid_filter"];

const loaded = (): EditorState => reducer({ ...initialState, catalog }, { type: "programLoaded", program: structuredClone(interactive) });
const program = (s: EditorState) => flowToProgram(s.history.present.nodes, s.history.present.edges, s.meta!);
const wires = (s: EditorState) => program(s).edges!.map((e) => `${e.from.node}.${e.from.port}->${e.to.node}.${e.to.port}`).sort();

function grouped(): EditorState {
  const s0 = loaded();
  const g = s0.history.present;
  const s = { ...s0, history: { ...s0.history, present: { ...g, nodes: g.nodes.map((n) => ({ ...n, selected: IDLE.includes(n.id) })) } } };
  return reducer(s, { type: "grouped", name: "idle", ports: groupCandidates(s.history.present, IDLE).filter((c) => c.crossing) });
}

describe("renaming a node", () => {
  it("renames it and every wire to and from it, in one undo step", () => {
    const before = loaded();
    const after = reducer(before, { type: "nodeRenamed", from: "wander_filter", to: "drift" });
    const ids = program(after).nodes!.map((n) => n.id);
    expect(ids).toContain("drift");
    expect(ids).not.toContain("wander_filter");
    expect(wires(after)).toEqual(wires(before).map((w) => w.replaceAll("wander_filter.", "drift.")).sort());
    expect(after.history.present.edges.every((e) => e.id === `${e.source}.${e.sourceHandle}->${e.target}.${e.targetHandle}`)).toBe(true);
    expect(after.dirty).toBe(true);
    const undone = reducer(after, { type: "undo" });
    expect(structureKey(undone.history.present, undone.meta)).toBe(structureKey(before.history.present, before.meta));
  });

  it("refuses an invalid or taken id with a toast, and changes nothing", () => {
    const before = loaded();
    for (const [to, why] of [["9lives", "not a valid name"], ["a/b", "not a valid name"], ["mix", "taken"], ["", "not a valid name"]]) {
      const after = reducer(before, { type: "nodeRenamed", from: "breathe", to });
      expect(after.toast).toContain(why);
      expect(after.history).toBe(before.history);
    }
    expect(renameProblem(before.history.present.nodes, "breathe", "breath.2")).toBeNull();
  });

  it("inside a subgraph, the definition's exposed ports follow the renamed block", () => {
    const inside = reducer(grouped(), { type: "subgraphOpened", node: "idle" });
    const after = reducer(inside, { type: "nodeRenamed", from: "breathe", to: "lungs" });
    expect(after.meta!.inside!.inputs).toContainEqual({ name: "breathe_amplitude", node: "lungs", port: "amplitude" });
    expect(after.meta!.inside!.outputs.some((p) => p.node === "lungs" && p.port === "out")).toBe(true);
    const def = program(after).subgraphs!.idle;
    expect(def.nodes!.map((n) => n.id)).toContain("lungs");
    expect(def.inputs).toContainEqual({ name: "breathe_amplitude", node: "lungs", port: "amplitude" });
  });
});

describe("ungrouping a subgraph node", () => {
  it("puts the definition's blocks back with the outer wires on their inner ports, in one undo step", () => {
    const before = loaded();
    const g = grouped();
    const after = reducer(g, { type: "ungrouped", node: "idle" });
    const p = program(after);
    expect(p.nodes!.some((n) => n.type === "subgraph")).toBe(false);
    expect(p.nodes!.map((n) => n.id).sort()).toEqual(program(before).nodes!.map((n) => n.id).sort());
    expect(wires(after)).toEqual(wires(before));
    // where the node was
    const node = g.history.present.nodes.find((n) => n.id === "idle")!;
    const placed = after.history.present.nodes.filter((n) => IDLE.includes(n.id));
    expect(Math.min(...placed.map((n) => n.position.x))).toBe(node.position.x);
    expect(Math.min(...placed.map((n) => n.position.y))).toBe(node.position.y);
    expect(reducer(after, { type: "undo" }).history.present).toBe(g.history.present);
  });

  it("gives fresh ids to inner blocks whose ids the enclosing graph has", () => {
    const g = grouped();
    // a second block named like an inner one
    const renamed = reducer(g, { type: "nodeRenamed", from: "mix", to: "breathe" });
    const after = reducer(renamed, { type: "ungrouped", node: "idle" });
    const ids = after.history.present.nodes.map((n) => n.id);
    expect(new Set(ids).size).toBe(ids.length);
    expect(ids).toContain("breathe_2");
    expect(wires(after)).toContain("breathe_2.out->breathe.idle");
    expect(wires(after)).toContain("breath_amplitude.value->breathe_2.amplitude");
  });
});

describe("a dragged wire", () => {
  it("dropped on a block's body goes to its first free input that fits, else one it replaces", () => {
    const g = loaded().history.present;
    expect(dropOnBody(g.nodes, g.edges, { node: "breathe", handle: "out", side: "source" }, "look_at")).toEqual({
      source: "breathe", sourceHandle: "out", target: "look_at", targetHandle: "in",
    });
    // from an input: the block's first output that fits
    expect(dropOnBody(g.nodes, g.edges, { node: "mood", handle: "in", side: "target" }, "posture")).toMatchObject({
      source: "posture", target: "mood", targetHandle: "in",
    });
    expect(dropOnBody(g.nodes, g.edges, { node: "in_valence", handle: "value", side: "source" }, "rest")).toContain("no input");
    expect(dropOnBody(g.nodes, g.edges, { node: "mix", handle: "out", side: "source" }, "mix")).toContain("itself");
  });

  it("dims the ports that cannot take it: its own side and the refused ones", () => {
    const g = loaded().history.present;
    const dim = incompatiblePorts(g.nodes, g.edges, { node: "wander", handle: "out", side: "source" });
    expect(dim.has(portKey("wander_filter", "target", "in"))).toBe(false);
    expect(dim.has(portKey("breathe", "target", "amplitude"))).toBe(true);  // a float input
    expect(dim.has(portKey("mix", "source", "out"))).toBe(true);  // an output
    expect(dim.has(portKey("wander", "source", "out"))).toBe(false);  // where it starts
  });
});

describe("inside a subgraph", () => {
  it("Group Input and Group Output list the exposed ports, wired to the inner ports, never in the program", () => {
    const inside = reducer(grouped(), { type: "subgraphOpened", node: "idle" });
    const io = groupIO(inside.history.present.nodes, inside.meta!.inside);
    const input = io.nodes.find((n) => n.id === GROUP_INPUT)!, output = io.nodes.find((n) => n.id === GROUP_OUTPUT)!;
    expect(Object.keys(input.data.outputs)).toEqual(inside.meta!.inside!.inputs.map((p) => p.name));
    expect(Object.keys(output.data.inputs)).toEqual(inside.meta!.inside!.outputs.map((p) => p.name));
    expect(io.edges).toContainEqual(expect.objectContaining({ source: GROUP_INPUT, sourceHandle: "breathe_amplitude", target: "breathe", targetHandle: "amplitude" }));
    expect(io.edges).toContainEqual(expect.objectContaining({ source: "eyelid_filter", sourceHandle: "out", target: GROUP_OUTPUT }));
    const left = Math.min(...inside.history.present.nodes.map((n) => n.position.x));
    expect(input.position.x).toBeLessThan(left);
    expect(groupIO(loaded().history.present.nodes, undefined).nodes).toEqual([]);
  });
});
