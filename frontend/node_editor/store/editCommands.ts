// Editing commands on the selection: bypass (M) and duplicate (Shift+D). Pure functions of the editor
// state (tested with vitest); the reducer (./state) delegates its `bypassToggled` and `duplicated` cases here.
import type { BlockEntry } from "../api";
import { isAnnotation } from "../annotations";
import { pasteClipboard, type FlowNode } from "../graph";
import * as H from "../history";
import type { EditorState, Position } from "./types";

export type EditCommand =
  | { type: "bypassToggled"; nodes?: string[] }
  | { type: "duplicated"; nodes?: string[]; at?: Position };

/** Roles of the blocks that take a frame and give one (the output's role is not among them). */
const PASS_THROUGH_ROLES: string[] = ["operator", "mixer", "stage2"];

/** Whether a block type may be bypassed: the catalog says so (`bypassable`); a catalog from a server
 * before the field existed is read the way the server decides it, from the block's role. */
export function bypassable(entry: BlockEntry | undefined): boolean {
  if (!entry) return false;
  return typeof entry.bypassable === "boolean" ? entry.bypassable : PASS_THROUGH_ROLES.includes(entry.role);
}

const chosen = (state: EditorState, ids?: string[]): FlowNode[] => {
  const nodes = state.history.present.nodes;
  return ids ? nodes.filter((n) => ids.includes(n.id)) : nodes.filter((n) => n.selected);
};

/** Bypass on the chosen (default: selected) blocks that can be, or off when all of them are bypassed:
 * one undo step; those that cannot be bypassed are named in a notice. */
export function toggleBypass(state: EditorState, ids?: string[]): EditorState {
  const targets = chosen(state, ids).filter((n) => !isAnnotation(n));
  const ok = targets.filter((n) => n.type === "block" && bypassable(state.catalog[n.data.type]));
  const refused = targets.filter((n) => !ok.includes(n)).map((n) => n.id);
  const why = refused.length
    ? `cannot bypass ${refused.join(", ")}: only a block with a frame input and a frame output (not the output, not a subgraph) passes its frame through`
    : null;
  if (!ok.length) return { ...state, toast: why ?? "select the blocks to bypass (M)" };
  const on = !ok.every((n) => n.data.bypass === true);
  const flip = new Set(ok.map((n) => n.id));
  const graph = state.history.present;
  const nodes = graph.nodes.map((n) => {
    if (!flip.has(n.id)) return n;
    const { bypass: _was, ...data } = n.data;  // false is not kept: the program omits it
    return { ...n, data: on ? { ...data, bypass: true } : data };
  });
  return { ...state, history: H.push(state.history, { ...graph, nodes }), dirty: true, lastParamEdit: null, toast: why ?? state.toast };
}

/** Copies of the chosen (default: selected) blocks and comment frames, with the wires between them, their
 * top-left corner at `at` (else beside the originals); the copies become the selection. One undo step. */
export function duplicate(state: EditorState, ids?: string[], at?: Position): EditorState {
  const graph = state.history.present;
  // a reroute belongs to a wire: copied only with the wire (not at all, here)
  const picked = chosen(state, ids).filter((n) => n.type !== "reroute");
  if (!picked.length) return { ...state, toast: "select the blocks to duplicate (Shift+D)" };
  const keep = new Set(picked.map((n) => n.id));
  const clip = { nodes: picked, edges: graph.edges.filter((e) => keep.has(e.source) && keep.has(e.target)) };
  const copies = at ? pasteClipboard(graph.nodes, clip, 0) : pasteClipboard(graph.nodes, clip);
  if (at) {
    const dx = at.x - Math.min(...picked.map((n) => n.position.x)), dy = at.y - Math.min(...picked.map((n) => n.position.y));
    copies.nodes = copies.nodes.map((n) => ({ ...n, position: { x: n.position.x + dx, y: n.position.y + dy } }));
  }
  const nodes = [...graph.nodes.map((n) => (n.selected ? { ...n, selected: false } : n)), ...copies.nodes];
  return { ...state, history: H.push(state.history, { nodes, edges: [...graph.edges, ...copies.edges] }), dirty: true, lastParamEdit: null };
}

export function editCommand(state: EditorState, action: EditCommand): EditorState {
  switch (action.type) {
    case "bypassToggled":
      return toggleBypass(state, action.nodes);
    case "duplicated":
      return duplicate(state, action.nodes, action.at);
  }
}
