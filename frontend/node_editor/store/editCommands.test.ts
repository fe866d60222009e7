// Bypass (M) and duplicate (Shift+D) on the selection: one undo step each, bypass saved in the program.
import { describe, expect, it } from "vitest";
import type { BlockEntry, Program, RobotDescription } from "../api";
import blocks from "../generated/blocks.json";
import { flowToProgram, programToFlow } from "../graph";
import { bypassable } from "./editCommands";
import { initialState, reducer, structureKey, type Action, type EditorState } from "./state";

const catalog: Record<string, BlockEntry> = Object.fromEntries((blocks as unknown as BlockEntry[]).map((b) => [b.type, b]));
const robot = { name: "r", dofs: [], postures: [] } as unknown as RobotDescription;
const program = {
  format: "nutty-program/1", name: "p", max_level: 3, ui: {},
  nodes: [
    { id: "rest", type: "rest_pose", params: {}, ui: { x: 0, y: 0 } },
    { id: "filter", type: "motion_filter", params: {}, ui: { x: 300, y: 0 } },
    { id: "gain", type: "gain_offset", params: {}, ui: { x: 600, y: 0 }, bypass: true },
    { id: "output", type: "output", params: {}, ui: { x: 900, y: 0 } },
  ],
  edges: [
    { from: { node: "rest", port: "out" }, to: { node: "filter", port: "in" } },
    { from: { node: "filter", port: "out" }, to: { node: "gain", port: "in" } },
    { from: { node: "gain", port: "out" }, to: { node: "output", port: "in" } },
  ],
} as unknown as Program;

const run = (actions: Action[], from: EditorState = initialState) => actions.reduce(reducer, from);
const loaded = () => run([
  { type: "serverDescribed", catalog, robot, previz: { url: null, direct: null, token_required: false, ghost: null } },
  { type: "programLoaded", program, fromServer: true },
]);
const node = (s: EditorState, id: string) => s.history.present.nodes.find((n) => n.id === id)!;
const select = (...ids: string[]): Action => ({ type: "selectedOnly", nodes: ids });

describe("bypass", () => {
  it("reads and writes `bypass` in the program, omitted when false", () => {
    const s = loaded();
    expect(node(s, "gain").data.bypass).toBe(true);
    expect(node(s, "filter").data.bypass).toBeUndefined();
    const back = flowToProgram(s.history.present.nodes, s.history.present.edges, s.meta!);
    expect(back.nodes!.find((n) => n.id === "gain")).toMatchObject({ bypass: true });
    expect(back.nodes!.find((n) => n.id === "filter")).not.toHaveProperty("bypass");
    expect(programToFlow(back, catalog).nodes.find((n) => n.id === "gain")!.data.bypass).toBe(true);
  });
  it("toggles the selected blocks as one undo step, a structural edit", () => {
    const before = run([select("filter")], loaded());
    const s = run([{ type: "bypassToggled" }], before);
    expect(node(s, "filter").data.bypass).toBe(true);
    expect(s.dirty).toBe(true);
    expect(structureKey(s.history.present, s.meta)).not.toBe(structureKey(before.history.present, before.meta));
    const off = run([{ type: "bypassToggled" }], s);
    expect(node(off, "filter").data).not.toHaveProperty("bypass");
    expect(node(run([{ type: "undo" }], s), "filter").data.bypass).toBeUndefined();
    expect(node(run([{ type: "undo" }, { type: "redo" }], s), "filter").data.bypass).toBe(true);
  });
  it("turns all on when some are off, all off when all are on", () => {
    const s = run([select("filter", "gain"), { type: "bypassToggled" }], loaded());
    expect([node(s, "filter").data.bypass, node(s, "gain").data.bypass]).toEqual([true, true]);
    const t = run([{ type: "bypassToggled" }], s);
    expect([node(t, "filter").data.bypass, node(t, "gain").data.bypass]).toEqual([undefined, undefined]);
  });
  it("refuses sources and the output with a notice naming them, and bypasses the rest", () => {
    const s = run([select("rest", "filter", "output"), { type: "bypassToggled" }], loaded());
    expect(s.toast).toMatch(/^cannot bypass rest, output: /);
    expect(node(s, "filter").data.bypass).toBe(true);
    expect(node(s, "rest").data.bypass).toBeUndefined();
    const none = run([select("output"), { type: "bypassToggled" }], loaded());
    expect(none.history.past.length).toBe(0);
    expect(none.toast).toMatch(/cannot bypass output/);
  });
  it("reads `bypassable` from the catalog, or the role when the catalog predates it", () => {
    expect(bypassable(catalog.motion_filter)).toBe(true);
    expect(bypassable(catalog.layer_mixer)).toBe(true);
    expect(bypassable(catalog.sine)).toBe(false);
    expect(bypassable(catalog.output)).toBe(false);
    expect(bypassable({ ...catalog.motion_filter, bypassable: false } as BlockEntry)).toBe(false);
    const older = (type: string) => ({ ...catalog[type], bypassable: undefined }) as unknown as BlockEntry;
    expect([bypassable(older("gain_offset")), bypassable(older("sine")), bypassable(older("output"))]).toEqual([true, false, false]);
  });
});

describe("duplicate", () => {
  it("copies the selection with the wires between its blocks, at the point given, selected, as one step", () => {
    const before = run([select("filter", "gain")], loaded());
    const s = run([{ type: "duplicated", at: { x: 1000, y: 500 } }], before);
    const g = s.history.present;
    const copies = g.nodes.filter((n) => n.selected);
    expect(copies.map((n) => n.id)).toEqual(["filter_2", "gain_2"]);
    expect(copies.map((n) => n.position)).toEqual([{ x: 1000, y: 500 }, { x: 1300, y: 500 }]);
    expect(node(s, "gain_2").data.bypass).toBe(true);
    expect(g.edges.filter((e) => e.source.endsWith("_2") || e.target.endsWith("_2")).map((e) => e.id))
      .toEqual(["filter_2.out->gain_2.in"]);
    expect(s.history.past.length).toBe(before.history.past.length + 1);
    expect(run([{ type: "undo" }], s).history.present.nodes).toHaveLength(4);
  });
  it("says so when nothing is selected", () => {
    const s = run([select(), { type: "duplicated", at: { x: 0, y: 0 } }], loaded());
    expect(s.toast).toMatch(/select the blocks to duplicate/);
    expect(s.history.present.nodes).toHaveLength(4);
  });
});

describe("overlays", () => {
  it("shows one command overlay at a time", () => {
    const s = run([{ type: "overlayShown", overlay: "find" }], loaded());
    expect(s.overlay).toBe("find");
    expect(run([{ type: "overlayShown", overlay: "help" }], s).overlay).toBe("help");
    expect(run([{ type: "overlayShown", overlay: null }], s).overlay).toBeNull();
  });
});
