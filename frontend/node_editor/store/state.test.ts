// The editor's reducer: loading, editing, the wiring and output rules, undo steps, notices.
import { describe, expect, it } from "vitest";
import type { BlockEntry, Program, RobotDescription, ValidationReport } from "../api";
import blocks from "../generated/blocks.json";
import { describeControlMessage } from "../hooks/useControlSocket";
import { emptyLive, emptySamples, nextLive, nextSamples } from "../telemetry";
import { errorsByNode, initialState, reducer, statusText, structureKey, type Action, type EditorState } from "./state";

const catalog: Record<string, BlockEntry> = Object.fromEntries((blocks as unknown as BlockEntry[]).map((b) => [b.type, b]));
const robot = { name: "r", dofs: [], postures: [] } as unknown as RobotDescription;

const program = {
  format: "nutty-program/1", name: "p", max_level: 3, ui: {},
  inputs: [{ name: "level", type: "float", default: 0.5, min: 0, max: 1 }],
  nodes: [
    { id: "in_level", type: "input", params: { name: "level", type: "float" }, ui: { x: 0, y: 300 } },
    { id: "rest", type: "rest_pose", params: {}, ui: { x: 0, y: 0 } },
    { id: "wave", type: "sine", params: {}, ui: { x: 0, y: 150 } },
    { id: "mix", type: "layer_mixer", params: { layers: [{ name: "base" }, { name: "idle", mode: "additive" }] }, ui: { x: 300, y: 0 } },
    { id: "output", type: "output", params: {}, ui: { x: 600, y: 0 } },
  ],
  edges: [
    { from: { node: "rest", port: "out" }, to: { node: "mix", port: "base" } },
    { from: { node: "wave", port: "out" }, to: { node: "mix", port: "idle" } },
    { from: { node: "mix", port: "out" }, to: { node: "output", port: "in" } },
  ],
} as unknown as Program;

const run = (actions: Action[], from: EditorState = initialState) => actions.reduce(reducer, from);
const loaded = () => run([
  { type: "serverDescribed", catalog, robot, previz: { url: null, direct: null, token_required: false, ghost: null } },
  { type: "programLoaded", program, fromServer: true },
]);
const present = (s: EditorState) => s.history.present;

describe("loading", () => {
  it("turns the program into the graph, with the ports its blocks derive, as a clean history", () => {
    const s = loaded();
    expect(present(s).nodes.map((n) => n.id)).toEqual(["in_level", "rest", "wave", "mix", "output"]);
    expect(Object.keys(present(s).nodes[3].data.inputs)).toEqual(["base", "idle", "base_weight", "idle_weight"]);
    expect(s.meta?.name).toBe("p");
    expect(s.history.past).toEqual([]);
    expect(s.dirty).toBe(false);
    expect(s.loaded).toEqual({ count: 1, fromServer: true });
  });
});

describe("wiring", () => {
  const weight = { source: "in_level", sourceHandle: "value", target: "mix", targetHandle: "idle_weight" };

  it("connects a signal to a layer weight as one undo step", () => {
    const s = run([{ type: "connected", connection: weight }], loaded());
    expect(present(s).edges.at(-1)).toMatchObject({ ...weight, data: { type: "float" } });
    expect(s.dirty).toBe(true);
    expect(present(run([{ type: "undo" }], s)).edges).toHaveLength(3);
  });
  it("refuses a wrong type with a notice and changes nothing else", () => {
    const before = loaded();
    const s = run([{ type: "connected", connection: { ...weight, source: "wave", sourceHandle: "out" } }], before);
    expect(s.toast).toMatch(/^refused: cannot connect frame output 'wave.out' to float input 'mix.idle_weight'/);
    expect(s.history).toBe(before.history);
  });
  it("drops the edges of a removed node", () => {
    const s = run([{ type: "nodesChanged", changes: [{ type: "remove", id: "mix" }] }], loaded());
    expect(present(s).edges).toEqual([]);
    expect(s.history.past).toHaveLength(1);
  });
  it("keeps drag steps and selection out of the undo history", () => {
    const s = run([
      { type: "nodesChanged", changes: [{ type: "position", id: "rest", position: { x: 5, y: 5 }, dragging: true }] },
      { type: "nodesChanged", changes: [{ type: "select", id: "rest", selected: true }] },
    ], loaded());
    expect(s.history.past).toEqual([]);
    expect(present(s).nodes[1].position).toEqual({ x: 5, y: 5 });
  });
});

describe("adding blocks", () => {
  it("adds a selected block with default parameters and derived ports, never on top of another", () => {
    const s = run([{ type: "blockAdded", blockType: "layer_mixer", position: { x: 300, y: 0 } }], loaded());
    const added = present(s).nodes.at(-1)!;
    expect(added.id).toBe("layer_mixer");
    expect(added.selected).toBe(true);
    expect(Object.keys(added.data.inputs)).toEqual(["base", "base_weight"]);
    expect(added.position).toEqual({ x: 300, y: 150 });
    expect(present(s).nodes.filter((n) => n.selected)).toHaveLength(1);
  });
  it("keeps a program to one output block (by the catalog's role)", () => {
    const before = loaded();
    const s = run([{ type: "blockAdded", blockType: "output", position: { x: 0, y: 0 } }], before);
    expect(s.toast).toBe("a program has exactly one output");
    expect(s.history).toBe(before.history);
  });
});

describe("parameters", () => {
  it("derives ports again, and folds quick edits of one node into one undo step", () => {
    const layers = [{ name: "base" }, { name: "idle" }, { name: "gesture" }];
    const s = run([
      { type: "paramsEdited", node: "mix", params: { layers }, at: 1000 },
      { type: "paramsEdited", node: "mix", params: { layers: layers.slice(0, 2) }, at: 1200 },
      { type: "paramsEdited", node: "mix", params: { layers }, at: 5000 },
    ], loaded());
    expect(Object.keys(present(s).nodes[3].data.inputs)).toContain("gesture_weight");
    expect(s.history.past).toHaveLength(2);
  });
  it("drops unset parameters", () => {
    const s = run([{ type: "paramsEdited", node: "wave", params: { amplitude: 0.3, frequency: null }, at: 0 }], loaded());
    expect(present(s).nodes[2].data.params).toEqual({ amplitude: 0.3 });
  });
  it("changes the structure key, which positions do not", () => {
    const s = loaded();
    const moved = run([{ type: "nodesChanged", changes: [{ type: "position", id: "rest", position: { x: 9, y: 9 }, dragging: false }] }], s);
    expect(structureKey(present(moved), moved.meta)).toBe(structureKey(present(s), s.meta));
    const edited = run([{ type: "paramsEdited", node: "wave", params: { amplitude: 0.3 }, at: 0 }], s);
    expect(structureKey(present(edited), edited.meta)).not.toBe(structureKey(present(s), s.meta));
  });
});

describe("reports and notices", () => {
  const report: ValidationReport = {
    valid: false, level: null, warnings: [],
    errors: [{ code: "unknown_dof", node: "wave", port: "dofs", message: "no DoF 'tail'", path: null, line: null, column: null }],
  };
  it("puts errors on their nodes and in the status", () => {
    expect(errorsByNode(report)).toEqual({ wave: ["dofs: no DoF 'tail'"] });
    expect(statusText(report, false)).toMatch(/^1 error\(s\)/);
    expect(statusText({ ...report, valid: true, level: 3, errors: [] }, false)).toBe("valid · level 3");
    expect(statusText(report, true)).toBe("syncing…");
  });
  it("expires a toast only if no other replaced it", () => {
    const s = run([{ type: "toast", message: "a" }, { type: "toast", message: "b" }, { type: "toastExpired", message: "a" }]);
    expect(s.toast).toBe("b");
    expect(run([{ type: "toastExpired", message: "b" }], s).toast).toBeNull();
  });
  it("keeps the last 200 console lines", () => {
    const s = run(Array.from({ length: 250 }, (_, i) => ({ type: "logged", line: `l${i}` }) as Action));
    expect(s.consoleLines).toHaveLength(200);
    expect(s.consoleLines[0]).toBe("l50");
  });
  it("describes control-socket messages", () => {
    expect(describeControlMessage({ type: "event", event: "started", id: "7", command: "play_clip", node: "gesture" }))
      .toBe("event started play_clip #7 @gesture");
    expect(describeControlMessage({ type: "ack", id: "7", status: "started", result: null })).toBe("ack #7 started");
    expect(describeControlMessage({ type: "error", code: "no_target", message: "no clip player" })).toBe("error no_target: no clip player");
    expect(describeControlMessage({ type: "event", event: "servo_fault", id: null, joint: "head_yaw", servo: 3, bus: "/dev/ttyUSB0", fault: "overload", t: 4.2 }))
      .toBe("servo fault: head_yaw (servo 3 on /dev/ttyUSB0): overload; held, the rest of the robot went to rest");
    expect(describeControlMessage({ type: "event", event: "sim_contact", id: null, links: ["left_arm", "right_arm"], t: 0.39, depth: 0.0039, position: [0.2, 0, 0.12], stopped: true }))
      .toBe("contact in simulation: left_arm / right_arm at t=0.39 s, 3.9 mm deep; the program's motion stopped");
  });
});

describe("telemetry", () => {
  it("keeps live values with a short history, and the last seconds of frames", () => {
    const msg = (t: number) => ({
      type: "telemetry" as const, t, seq: t, signals: { "wave.out": { mask: 2, values: { a: t, b: 0 } }, "in_level.value": 0.5 },
      frame: { position: { a: t }, stage1: { a: 0 }, classes: {}, corrected: [] }, layers: {},
    });
    let live = emptyLive, samples = emptySamples;
    for (let t = 0; t < 100; t++) { live = nextLive(live, msg(t)); samples = nextSamples(samples, msg(t), 10); }
    expect(live.history["wave.out"]).toHaveLength(60);
    expect(live.history["wave.out"].at(-1)).toBe(99);
    expect(live.values["in_level.value"]).toBe(0.5);
    expect(samples.t).toEqual([90, 91, 92, 93, 94, 95, 96, 97, 98, 99]);
    expect(samples.final["dof:a"].at(-1)).toBe(99);
  });
});

describe("drafts", () => {
  const report = { valid: true, level: 2, errors: [], warnings: [] } as unknown as ValidationReport;
  it("the running program is live; a program opened or imported is a draft until it goes live", () => {
    const s = loaded();
    expect(s.live).toBe(true);
    expect(s.runningName).toBe("p");
    const draft = reducer(s, { type: "programLoaded", program: { ...program, name: "other" }, libName: "other" });
    expect(draft.live).toBe(false);
    expect(draft.runningName).toBe("p");  // the robot still runs p
    const refused = { code: "x", column: null, line: null, message: "x", node: null, path: null, port: null };
    expect(statusText({ ...report, valid: false, errors: [refused] }, false, false)).toContain("to go live");
    const live = reducer(draft, { type: "wentLive", report });
    expect(live.live).toBe(true);
    expect(live.runningName).toBe("other");
    expect(live.report).toBe(report);
    expect(reducer(live, { type: "draftStarted" }).live).toBe(false);
  });
  it("saving under a new name names the program after it; a plain save keeps the name", () => {
    const s = reducer(loaded(), { type: "saved", name: "calm_idle", rename: true });
    expect(s.meta?.name).toBe("calm_idle");
    expect(s.libName).toBe("calm_idle");
    expect(reducer(loaded(), { type: "saved", name: "file" }).meta?.name).toBe("p");
  });
});

describe("canvas", () => {
  const edgeIds = (s: EditorState) => present(s).edges.map((e) => e.id).sort();
  it("replaces the wire on an occupied input (one undo step), and keeps other refusals", () => {
    const before = loaded();
    const s = run([{ type: "connected", connection: { source: "wave", sourceHandle: "out", target: "mix", targetHandle: "base" } }], before);
    expect(edgeIds(s)).toEqual(["mix.out->output.in", "wave.out->mix.base", "wave.out->mix.idle"].sort());
    expect(s.history.past).toHaveLength(1);
    expect(edgeIds(run([{ type: "undo" }], s))).toEqual(edgeIds(before));
    const wrong = run([{ type: "connected", connection: { source: "in_level", sourceHandle: "value", target: "mix", targetHandle: "base" } }], before);
    expect(wrong.toast).toMatch(/^refused: cannot connect float output/);
    expect(wrong.history).toBe(before.history);
    const cycle = run([{ type: "connected", connection: { source: "mix", sourceHandle: "out", target: "mix", targetHandle: "base" } }], before);
    expect(cycle.toast).toMatch(/^refused: a block cannot feed itself/);
  });
  it("deletes nodes with their wires as one undo step, and undo restores both", () => {
    const before = loaded();
    const s = run([{ type: "deleted", nodes: ["mix"], edges: ["rest.out->mix.base"] }], before);
    expect(present(s).nodes.map((n) => n.id)).not.toContain("mix");
    expect(present(s).edges).toEqual([]);
    expect(s.history.past).toHaveLength(1);
    const undone = run([{ type: "undo" }], s);
    expect(present(undone)).toBe(present(before));
    expect(run([{ type: "deleted", nodes: [], edges: [] }], before)).toBe(before);
  });
  it("adds a block wired from a dragged output to its first input that fits, in one step", () => {
    const s = run([{ type: "blockAddedFrom", blockType: "motion_filter", position: { x: 900, y: 300 }, port: { node: "wave", handle: "out", side: "source" } }], loaded());
    expect(present(s).nodes.at(-1)!.id).toBe("motion_filter");
    expect(present(s).edges.at(-1)).toMatchObject({ source: "wave", sourceHandle: "out", target: "motion_filter", targetHandle: "in" });
    expect(s.history.past).toHaveLength(1);
  });
  it("adds a block feeding a dragged input, replacing that input's wire", () => {
    const s = run([{ type: "blockAddedFrom", blockType: "lfo", position: { x: 0, y: 600 }, port: { node: "mix", handle: "base_weight", side: "target" } }], loaded());
    expect(present(s).edges.at(-1)).toMatchObject({ source: "lfo", sourceHandle: "value", target: "mix", targetHandle: "base_weight" });
    const t = run([{ type: "blockAddedFrom", blockType: "pose", position: { x: 0, y: 600 }, port: { node: "mix", handle: "base", side: "target" } }], loaded());
    expect(edgeIds(t)).toContain("pose.out->mix.base");
    expect(edgeIds(t)).not.toContain("rest.out->mix.base");
  });
  it("refuses a block with no port that fits, changing nothing", () => {
    const before = loaded();
    const s = run([{ type: "blockAddedFrom", blockType: "rest_pose", position: { x: 0, y: 0 }, port: { node: "wave", handle: "out", side: "source" } }], before);
    expect(s.toast).toMatch(/^refused/);
    expect(s.history).toBe(before.history);
  });
  it("inserts a block on a wire, between its ends, as one undo step", () => {
    const before = loaded();
    const s = run([{ type: "blockInserted", blockType: "safety_limiter", position: { x: 450, y: 0 }, edge: "mix.out->output.in" }], before);
    expect(edgeIds(s)).toContain("mix.out->safety_limiter.in");
    expect(edgeIds(s)).toContain("safety_limiter.out->output.in");
    expect(edgeIds(s)).not.toContain("mix.out->output.in");
    expect(s.history.past).toHaveLength(1);
    expect(present(run([{ type: "undo" }], s))).toBe(present(before));
  });
  it("disconnects a node, or one of its ports", () => {
    const s = run([{ type: "disconnected", node: "mix" }], loaded());
    expect(present(s).edges).toEqual([]);
    const one = run([{ type: "disconnected", node: "mix", handle: "idle", side: "target" }], loaded());
    expect(edgeIds(one)).toEqual(["mix.out->output.in", "rest.out->mix.base"]);
  });
  it("lays out as one undo step (or none, for a program that arrived without positions)", () => {
    const s = run([{ type: "laidOut", positions: { rest: { x: 10, y: 20 } }, undoable: true }], loaded());
    expect(present(s).nodes[1].position).toEqual({ x: 10, y: 20 });
    expect(s.history.past).toHaveLength(1);
    expect(run([{ type: "laidOut", positions: { rest: { x: 1, y: 2 } }, undoable: false }], loaded()).history.past).toHaveLength(0);
  });
  it("selects all nodes, or only some, without an undo step", () => {
    const s = run([{ type: "selectedAll" }], loaded());
    expect(present(s).nodes.every((n) => n.selected)).toBe(true);
    expect(s.history.past).toHaveLength(0);
    const only = run([{ type: "selectedOnly", nodes: ["wave"] }], s);
    expect(present(only).nodes.filter((n) => n.selected).map((n) => n.id)).toEqual(["wave"]);
  });
});

describe("layers", () => {
  it("removing a mixer layer removes its ports and the wires to them, in one undo step", () => {
    const s = loaded();
    const next = reducer(s, { type: "paramsEdited", node: "mix", params: { layers: [{ name: "base" }] }, at: 0 });
    const mix = present(next).nodes.find((n) => n.id === "mix")!;
    expect(Object.keys(mix.data.inputs)).toEqual(["base", "base_weight"]);
    expect(present(next).edges.map((e) => e.id)).not.toContain("wave.out->mix.idle");
    expect(present(reducer(next, { type: "undo" })).edges.map((e) => e.id)).toContain("wave.out->mix.idle");
  });
});
