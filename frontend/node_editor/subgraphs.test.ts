import { describe, expect, it } from "vitest";
import interactiveJson from "../../robots/nutty_desk/programs/interactive.json";
import blocks from "./generated/blocks.json";
import type { BlockEntry, Program } from "./api";
import { annotationsFromFlow, withRoutes } from "./annotations";
import { flowToProgram, programToFlow, type FlowNode, type SubgraphDef } from "./graph";
import { initialState, reducer, structureKey, type EditorState } from "./store/state";
import { liveInside, signalsInside } from "./organise/liveInside";
import type { Live } from "./telemetry";
import { breadcrumb, exposedCandidates, groupCandidates, groupSelection, nodePorts, openDefinition } from "./subgraphs";

const catalog: Record<string, BlockEntry> = Object.fromEntries((blocks as unknown as BlockEntry[]).map((b) => [b.type, b]));
const interactive = interactiveJson as Program;
const IDLE = ["breathe", "wander", "wander_filter", "weight_shift", "blink", "eyelid_filter"];

function loaded(program: Program): EditorState {
  const s = reducer({ ...initialState, catalog }, { type: "programLoaded", program: structuredClone(program) });
  return s;
}

function select(state: EditorState, ids: string[]): EditorState {
  const g = state.history.present;
  return { ...state, history: { ...state.history, present: { ...g, nodes: g.nodes.map((n) => ({ ...n, selected: ids.includes(n.id) })) } } };
}

function grouped(): EditorState {
  const s = select(loaded(interactive), IDLE);
  const cands = groupCandidates(s.history.present, IDLE);
  return reducer(s, { type: "grouped", name: "idle", ports: cands.filter((c) => c.crossing) });
}

describe("grouping", () => {
  it("lists the wires crossing the selection as candidates, then free ports", () => {
    const g = loaded(interactive).history.present;
    const c = groupCandidates(g, IDLE);
    const wired = c.filter((x) => x.crossing).map((x) => `${x.kind}:${x.node}.${x.port}`);
    expect(wired.sort()).toEqual([
      "input:blink.gaze", "input:breathe.amplitude",
      "output:breathe.out", "output:eyelid_filter.out", "output:weight_shift.out", "output:wander_filter.out",
    ].sort());
    expect(c.find((x) => x.kind === "input" && x.node === "breathe" && x.port === "amplitude")?.type).toBe("float");
    expect(c.some((x) => !x.crossing)).toBe(true);
  });

  it("turns the selection into a definition, one subgraph node and rewired edges, in one undo step", () => {
    const before = loaded(interactive);
    const after = grouped();
    const p = flowToProgram(after.history.present.nodes, after.history.present.edges, after.meta!);
    const def = p.subgraphs!.idle;
    expect(def.nodes!.map((n) => n.id).sort()).toEqual([...IDLE].sort());
    expect(def.edges).toEqual([
      { from: { node: "wander", port: "out" }, to: { node: "wander_filter", port: "in" } },
      { from: { node: "blink", port: "out" }, to: { node: "eyelid_filter", port: "in" } },
    ]);
    expect(def.inputs).toContainEqual({ name: "breathe_amplitude", node: "breathe", port: "amplitude" });
    expect(def.outputs).toContainEqual({ name: "eyelid_filter_out", node: "eyelid_filter", port: "out" });
    const node = p.nodes!.find((n) => n.id === "idle")!;
    expect(node.type).toBe("subgraph");
    expect(node.params).toEqual({ subgraph: "idle" });
    expect(p.nodes!.some((n) => IDLE.includes(n.id))).toBe(false);
    expect(p.edges).toContainEqual({ from: { node: "breath_amplitude", port: "value" }, to: { node: "idle", port: "breathe_amplitude" } });
    expect(p.edges).toContainEqual({ from: { node: "idle", port: "eyelid_filter_out" }, to: { node: "mix", port: "blink" } });
    expect(p.edges).toHaveLength(interactive.edges!.length - 2);
    const flowNode = after.history.present.nodes.find((n) => n.id === "idle")!;
    expect(flowNode.type).toBe("subgraph");
    expect(flowNode.data.inputs.breathe_amplitude.type).toBe("float");
    expect(flowNode.data.outputs.breathe_out.type).toBe("frame");
    expect(after.history.past).toHaveLength(before.history.past.length + 1);
    const undone = reducer(after, { type: "undo" });
    expect(undone.history.present.nodes.map((n) => n.id)).toEqual(before.history.present.nodes.map((n) => n.id));
  });

  it("refuses to cut a wired port, and a bad name", () => {
    const s = select(loaded(interactive), IDLE);
    const g = s.history.present;
    expect(groupSelection(g, s.meta!, catalog, "idle", [])).toMatch(/would be cut/);
    expect(groupSelection(g, s.meta!, catalog, "no way", groupCandidates(g, IDLE))).toMatch(/not a valid name/);
  });

  it("ports of nested subgraph nodes follow the inner definition", () => {
    const defs = {
      inner: { nodes: [{ id: "s", type: "sine", params: {} }], edges: [], inputs: [{ name: "amp", node: "s", port: "amplitude" }], outputs: [{ name: "o", node: "s", port: "out" }] },
      outer: { nodes: [{ id: "i", type: "subgraph", params: { subgraph: "inner" } }], edges: [], inputs: [{ name: "a", node: "i", port: "amp" }], outputs: [{ name: "x", node: "i", port: "o" }] },
      loop: { nodes: [{ id: "l", type: "subgraph", params: { subgraph: "loop" } }], edges: [], inputs: [], outputs: [{ name: "y", node: "l", port: "y" }] },
    };
    const p = nodePorts("subgraph", { subgraph: "outer" }, defs, catalog);
    expect(p.inputs.a.type).toBe("float");
    expect(p.outputs.x.type).toBe("frame");
    expect(nodePorts("subgraph", { subgraph: "loop" }, defs, catalog).outputs).toEqual({});
  });
});

describe("opening a subgraph", () => {
  it("is the same program as the server's, which stores an empty ui on each definition", () => {
    const g = grouped();
    const served = flowToProgram(g.history.present.nodes, g.history.present.edges, g.meta!);
    for (const d of Object.values(served.subgraphs ?? {})) d.ui = {};  // as GET /api/program answers it
    const fromServer = reducer({ ...initialState, catalog }, { type: "programLoaded", program: served, fromServer: true });
    const inside = reducer(fromServer, { type: "subgraphOpened", node: "idle" });
    expect(inside.loaded.view).toBe(true);  // a view of the program the server has: nothing to send
    expect(structureKey(inside.history.present, inside.meta)).toBe(structureKey(fromServer.history.present, fromServer.meta));
  });

  it("shows the inside, composes the whole program while inside, and goes back", () => {
    const g = grouped();
    const whole = structureKey(g.history.present, g.meta);
    const inside = reducer(g, { type: "subgraphOpened", node: "idle" });
    expect(inside.history.present.nodes.map((n) => n.id).sort()).toEqual([...IDLE].sort());
    expect(breadcrumb(inside.meta).map((c) => c.label)).toEqual([interactive.name, "idle"]);
    expect(structureKey(inside.history.present, inside.meta)).toBe(whole);  // nothing changed: same program
    // edit an inner parameter: the definition changes, the outer program keeps its shape
    const edited = reducer(inside, { type: "paramsEdited", node: "breathe", params: { ...inside.history.present.nodes.find((n) => n.id === "breathe")!.data.params, frequency: 0.4 }, at: 0 });
    const p = flowToProgram(edited.history.present.nodes, edited.history.present.edges, edited.meta!);
    expect(p.nodes!.some((n) => n.id === "idle")).toBe(true);
    expect(p.subgraphs!.idle.nodes!.find((n) => n.id === "breathe")!.params!.frequency).toBe(0.4);
    expect(openDefinition(edited.history.present, edited.meta)!.definition.nodes!.find((n) => n.id === "breathe")!.params!.frequency).toBe(0.4);
    const back = reducer(edited, { type: "subgraphClosed" });
    expect(back.meta?.inside).toBeUndefined();
    expect(back.history.present.nodes.some((n) => n.id === "idle")).toBe(true);
    const q = flowToProgram(back.history.present.nodes, back.history.present.edges, back.meta!);
    expect(q).toEqual(p);
  });

  it("inserts a library subgraph by embedding its definition", () => {
    const g = grouped();
    const def = flowToProgram(g.history.present.nodes, g.history.present.edges, g.meta!).subgraphs!.idle as SubgraphDef;
    const blank = loaded({ format: "nutty-program/1", name: "b", nodes: [], edges: [], ui: {} });
    const s = reducer(blank, { type: "subgraphInserted", name: "idle", definition: def, position: { x: 0, y: 0 } });
    const p = flowToProgram(s.history.present.nodes, s.history.present.edges, s.meta!);
    expect(p.subgraphs!.idle).toEqual(def);
    expect(p.nodes).toEqual([{ id: "idle", type: "subgraph", params: { subgraph: "idle" }, ui: { x: 0, y: 0 } }]);
  });
});

describe("comment frames and reroutes round-trip through ui", () => {
  const program = {
    format: "nutty-program/1", name: "t", max_level: 3, inputs: [],
    ui: {
      viewport: { zoom: 1 },
      comments: [{ id: "note-1", x: -40, y: -60, w: 500, h: 300, title: "Idle", colour: "#3f6b55" }],
      reroutes: [{ id: "reroute-1", x: 150, y: 80, edge: { from: { node: "wave", port: "out" }, to: { node: "output", port: "in" } } }],
    },
    nodes: [
      { id: "wave", type: "sine", params: {}, ui: { x: 0, y: 0 } },
      { id: "output", type: "output", params: {}, ui: { x: 300, y: 0 } },
    ],
    edges: [{ from: { node: "wave", port: "out" }, to: { node: "output", port: "in" } }],
  } satisfies Program;

  it("loads them as canvas nodes and writes them back unchanged", () => {
    const { nodes, edges, meta } = programToFlow(structuredClone(program), catalog);
    expect(nodes.map((n) => n.type)).toEqual(["comment", "block", "block", "reroute"]);
    expect(nodes[0].zIndex).toBeLessThan(0);
    expect(flowToProgram(nodes, edges, meta)).toEqual(program);
    const routed = withRoutes(edges, nodes);
    expect(routed[0]).toMatchObject({ type: "routed", data: { via: [{ x: 157, y: 87 }] } });
  });

  it("drops a reroute whose wire is gone, keeps the program's edges as they are", () => {
    const { nodes, meta } = programToFlow(structuredClone(program), catalog);
    const p = flowToProgram(nodes, [], meta);
    expect(p.ui!.reroutes).toBeUndefined();
    expect(p.ui!.comments).toHaveLength(1);
    expect(p.nodes).toHaveLength(2);
  });

  it("adds, resizes and retitles comments through the reducer", () => {
    let s = loaded(program);
    s = reducer(s, { type: "commentAdded", position: { x: 10, y: 20 } });
    const added = s.history.present.nodes.find((n) => n.type === "comment" && n.id !== "note-1") as FlowNode;
    s = reducer(s, { type: "paramsEdited", node: added.id, params: { ...added.data.params, title: "Gaze" }, at: 0 });
    s = reducer(s, { type: "nodesChanged", changes: [{ type: "dimensions", id: added.id, dimensions: { width: 600, height: 200 }, resizing: false, setAttributes: true }] });
    const { comments } = annotationsFromFlow(s.history.present.nodes, s.history.present.edges);
    expect(comments.find((c) => c.id === added.id)).toMatchObject({ x: 10, y: 20, w: 600, h: 200, title: "Gaze" });
    s = reducer(s, { type: "rerouteAdded", edge: "wave.out->output.in", position: { x: 200, y: 40 } });
    const p = flowToProgram(s.history.present.nodes, s.history.present.edges, s.meta!);
    expect(p.ui!.reroutes).toHaveLength(2);
    expect(p.edges).toHaveLength(1);
  });
});

describe("live values inside an open subgraph", () => {
  it("subscribes to the flat ids and shows them under the inner ids", () => {
    expect(signalsInside([{ node: "breathe", port: "out" }], "idle")).toEqual([{ node: "idle/breathe", port: "out" }]);
    expect(signalsInside([{ node: "breathe", port: "out" }], undefined)).toEqual([{ node: "breathe", port: "out" }]);
    const live: Live = { values: { "idle/breathe.out": 1, "mix.out": 2 }, history: { "idle/breathe.out": [1] }, layers: { "idle/m": [] }, t: 0, profile: null, net: null };
    expect(liveInside(live, "idle")).toEqual({ values: { "breathe.out": 1 }, history: { "breathe.out": [1] }, layers: { m: [] }, t: 0, profile: null, net: null });
  });
});

describe("editing an open subgraph's ports", () => {
  it("renames a port keeping its wires, and cuts the wires of a port no longer exposed", () => {
    const inside = reducer(grouped(), { type: "subgraphOpened", node: "idle" });
    const cands = exposedCandidates(inside.history.present, inside.meta);
    expect(cands.filter((c) => c.checked).map((c) => c.name).sort()).toEqual(
      ["blink_gaze", "breathe_amplitude", "breathe_out", "eyelid_filter_out", "wander_filter_out", "weight_shift_out"]);
    expect(cands.some((c) => c.node === "wander_filter" && c.port === "in")).toBe(false);  // fed inside
    const ports = cands.filter((c) => c.checked && c.name !== "weight_shift_out")
      .map((c) => (c.name === "breathe_out" ? { ...c, name: "breath" } : c));
    const edited = reducer(inside, { type: "exposedEdited", ports, description: "idle motion" });
    const back = reducer(edited, { type: "subgraphClosed" });
    const p = flowToProgram(back.history.present.nodes, back.history.present.edges, back.meta!);
    expect(p.subgraphs!.idle.description).toBe("idle motion");
    expect(p.subgraphs!.idle.outputs!.map((o) => o.name)).toEqual(["breath", "wander_filter_out", "eyelid_filter_out"]);
    expect(p.edges).toContainEqual({ from: { node: "idle", port: "breath" }, to: { node: "mix", port: "idle" } });
    expect(p.edges!.some((e) => e.to.node === "mix" && e.to.port === "shift")).toBe(false);
    expect(Object.keys(back.history.present.nodes.find((n) => n.id === "idle")!.data.outputs)).toEqual(["breath", "wander_filter_out", "eyelid_filter_out"]);
  });

  it("reuses the name of a definition nothing uses any more (a grouping undone)", () => {
    const undone = reducer(grouped(), { type: "undo" });
    const again = reducer(select(undone, IDLE), { type: "grouped", name: "idle", ports: groupCandidates(undone.history.present, IDLE).filter((c) => c.crossing) });
    expect(Object.keys(again.meta!.subgraphs!)).toEqual(["idle"]);
    expect(again.history.present.nodes.find((n) => n.id === "idle")!.data.params).toEqual({ subgraph: "idle" });
  });
});
