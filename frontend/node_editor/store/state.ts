// The editor's state and every change to it, as one pure reducer (tested with vitest).
// Side effects (HTTP, WebSockets, timers, dialogs) live in the hooks, which dispatch these actions.
import { applyEdgeChanges, applyNodeChanges, type EdgeChange, type NodeChange } from "@xyflow/react";
import type { Catalog, ExposedInput, PrevizInfo, Program, RobotDescription, ValidationReport } from "../api";
import {
  edgeId, flowToProgram, freshId, pasteClipboard, programToFlow, type FlowEdge, type FlowNode, type Meta,
} from "../graph";
import * as H from "../history";
import { NEW_BLOCK_CLEARANCE, NEW_BLOCK_STEP } from "../layout/constants";
import { defaultParams, portsOf } from "../ports";
import { firstInputFor, firstOutputFor, replacingProblem, withoutOccupant, type PortRef } from "../quickAdd";
import { renameNode } from "../rename";
import { organise, type OrganiseAction } from "../subgraphs";
import { ungroupNode } from "../ungroup";
import { behaviourReducer, type BehaviourAction } from "./behaviourState";
import { clipReducer, type ClipAction } from "./clipState";
import { editCommand, type EditCommand } from "./editCommands";
import type { Connection, EditorState, Graph, Position } from "./types";

// the state's shape lives apart (./types), so that ../subgraphs, whose cases this reducer delegates to,
// needs nothing from here
export type { Connection, EditorState, Graph, Position } from "./types";

export type Action =
  | { type: "serverDescribed"; catalog: Catalog; robot: RobotDescription; previz: PrevizInfo }
  | { type: "programLoaded"; program: Program; fromServer?: boolean; libName?: string | null; report?: ValidationReport | null }
  | { type: "nodesChanged"; changes: NodeChange<FlowNode>[] }
  | { type: "edgesChanged"; changes: EdgeChange<FlowEdge>[] }
  | { type: "connected"; connection: Connection }
  | { type: "blockAdded"; blockType: string; position: Position }
  | { type: "paramsEdited"; node: string; params: Record<string, unknown>; at: number }
  | { type: "pasted"; clip: Graph; at?: Position }
  | { type: "undo" }
  | { type: "redo" }
  | { type: "renamed"; name: string }
  | { type: "syncing"; on: boolean }
  | { type: "reportReceived"; report: ValidationReport | null }
  | { type: "saved"; name: string; rename?: boolean }
  | { type: "wentLive"; report: ValidationReport }
  | { type: "draftStarted" }
  | { type: "libraryListed"; names: string[] }
  | { type: "clipsListed"; names: string[] }
  | { type: "inputsLoaded"; decls: ExposedInput[]; values: Record<string, unknown> }
  | { type: "inputSet"; name: string; value: unknown }
  | { type: "ghostShown"; visible: boolean }
  | { type: "toast"; message: string }
  | { type: "toastExpired"; message: string }
  | { type: "logged"; line: string }
  // the canvas: deletion as one step, quick-add wired to a port or inserted on a wire, layout, selection
  | { type: "deleted"; nodes: string[]; edges: string[] }
  | { type: "blockAddedFrom"; blockType: string; position: Position; port: PortRef }
  | { type: "blockInserted"; blockType: string; position: Position; edge: string }
  | { type: "disconnected"; node: string; handle?: string; side?: "source" | "target" }
  | { type: "laidOut"; positions: Record<string, Position>; undoable: boolean }
  | { type: "selectedAll" }
  | { type: "selectedOnly"; nodes: string[] }
  // the command overlays (find a block, the shortcut list): one at a time
  | { type: "overlayShown"; overlay: EditorState["overlay"] }
  | EditCommand
  // the clip editor: which clip is open (./clipState)
  | ClipAction
  | BehaviourAction
  // the canvas: a node renamed in place (F2), a subgraph node replaced by its blocks
  | { type: "nodeRenamed"; from: string; to: string }
  | { type: "ungrouped"; node: string }
  | OrganiseAction;

/** Parameter edits of one node closer together than this (ms) are one undo step. */
export const COALESCE_MS = 600;
const CONSOLE_LINES = 200;

export const initialState: EditorState = {
  catalog: {}, robot: null, previz: null, meta: null, history: H.init({ nodes: [], edges: [] }), report: null,
  syncing: false, dirty: false, libName: null, library: [], clips: [], inputs: { decls: [], values: {} },
  toast: null, consoleLines: [], loaded: { count: 0, fromServer: false }, lastParamEdit: null,
  live: false, runningName: null, overlay: null, clip: null, clipTab: "program", clipRequest: null,
  behaviour: null, behaviourRequest: null,
};

/** The program's structure (no positions): what the server must have; equal keys need no sync. */
export function structureKey(g: Graph, meta: Meta | null): string {
  const p = flowToProgram(g.nodes.map((n) => ({ ...n, position: { x: 0, y: 0 } })), g.edges, meta ?? ({} as Meta));
  // inside an open subgraph the enclosing graph (and every definition) is in it too: no positions there either
  const still = (nodes: Program["nodes"] = []) => nodes.map((n) => ({ ...n, ui: { ...n.ui, x: 0, y: 0 } }));
  // an empty `ui` is no ui: the server stores one on every definition, a definition composed from an
  // open subgraph leaves it out
  const subgraphs = p.subgraphs && Object.fromEntries(Object.entries(p.subgraphs).map(([k, { ui, ...d }]) =>
    [k, { ...d, nodes: still(d.nodes), ...(ui && Object.keys(ui).length ? { ui } : {}) }]));
  return JSON.stringify({ ...p, ...(subgraphs ? { subgraphs } : {}), nodes: still(p.nodes) });
}

/** The graph with one node's parameters replaced (unset ones dropped) and its ports derived again;
 * `structural` when its ports changed (the server must rebuild, a live patch cannot do). */
export function withParams(g: Graph, catalog: Catalog, id: string, params: Record<string, unknown>) {
  const node = g.nodes.find((n) => n.id === id);
  if (!node) return null;
  const clean = Object.fromEntries(Object.entries(params).filter(([, v]) => v !== null && v !== undefined));
  const { inputs, outputs } = portsOf(catalog[node.data.type], clean);
  const structural = JSON.stringify(inputs) !== JSON.stringify(node.data.inputs) || JSON.stringify(outputs) !== JSON.stringify(node.data.outputs);
  const nodes = g.nodes.map((n) => (n.id === id ? { ...n, data: { ...n.data, params: clean, inputs, outputs } } : n));
  // a port the new parameters remove (e.g. a mixer's layer) takes its wires with it
  const edges = structural ? g.edges.filter((e) => (e.target !== id || e.targetHandle in inputs) && (e.source !== id || e.sourceHandle in outputs)) : g.edges;
  return { graph: { ...g, nodes, edges }, params: clean, structural };
}

/** Errors of the report by node, each as `port: message`. Blocks inside subgraphs run as
 * `<subgraph node>/<inner id>`: their errors show on the subgraph node, or on the inner block while
 * that subgraph (`inside`, its flat path) is open. */
export function errorsByNode(report: ValidationReport | null, inside?: string): Record<string, string[]> {
  const out: Record<string, string[]> = {};
  for (const e of report?.errors ?? []) {
    if (!e.node) continue;
    let node = e.node;
    if (inside) {
      if (!node.startsWith(inside + "/")) continue;
      node = node.slice(inside.length + 1);
    }
    const cut = node.indexOf("/");
    const port = cut >= 0 ? `${node.slice(cut + 1)}${e.port ? "." + e.port : ""}` : e.port;
    (out[cut >= 0 ? node.slice(0, cut) : node] ??= []).push(`${port ? port + ": " : ""}${e.message}`);
  }
  return out;
}

export function statusText(report: ValidationReport | null, syncing: boolean, live = true): string {
  if (syncing) return "syncing…";
  if (!report) return "…";
  if (!report.valid) return live ? `${report.errors.length} error(s) — the robot keeps the last valid program`
    : `${report.errors.length} error(s) — fix them to go live`;
  return `valid · level ${report.level}${report.warnings.length ? ` · ${report.warnings.length} warning(s)` : ""}`;
}

const deselected = (nodes: FlowNode[]) => nodes.map((n) => ({ ...n, selected: false }));

/** The clip moved so that its top-left corner is at `at`. */
function placedAt(clip: Graph, at: Position): Graph {
  const dx = at.x - Math.min(...clip.nodes.map((n) => n.position.x)), dy = at.y - Math.min(...clip.nodes.map((n) => n.position.y));
  return { ...clip, nodes: clip.nodes.map((n) => ({ ...n, position: { x: n.position.x + dx, y: n.position.y + dy } })) };
}

/** Record a graph edit: a new undo step (`push`) or folded into the present one. */
function edit(state: EditorState, next: Graph, push = true): EditorState {
  return { ...state, history: push ? H.push(state.history, next) : H.replace(state.history, next), dirty: state.dirty || push };
}

/** A new block of `type` at `position` (moved off other blocks), or why none may be added. */
function newBlock(state: EditorState, type: string, position: Position): FlowNode | string | null {
  const entry = state.catalog[type];
  if (!entry) return null;
  const graph = state.history.present;
  if (entry.role === "output" && graph.nodes.some((n) => state.catalog[n.data.type]?.role === "output"))
    return "a program has exactly one output";
  const params = defaultParams(entry);
  const { inputs, outputs } = portsOf(entry, params);
  const pos = { ...position };
  // never drop a new block exactly on top of another one
  while (graph.nodes.some((n) => Math.abs(n.position.x - pos.x) < NEW_BLOCK_CLEARANCE.x && Math.abs(n.position.y - pos.y) < NEW_BLOCK_CLEARANCE.y))
    pos.y += NEW_BLOCK_STEP;
  const node: FlowNode = {
    id: freshId(graph.nodes, type), type: "block", position: pos, selected: true,
    data: { type, params, ui: {}, inputs, outputs, errors: [] },
  };
  return node;
}

function addBlock(state: EditorState, type: string, position: Position): EditorState {
  const node = newBlock(state, type, position);
  if (node === null) return state;
  if (typeof node === "string") return { ...state, toast: node };
  const graph = state.history.present;
  return edit(state, { nodes: [...deselected(graph.nodes), node], edges: graph.edges });
}

function wire(nodes: FlowNode[], c: Connection): FlowEdge {
  const src = nodes.find((n) => n.id === c.source)!;
  return { ...c, id: edgeId(c), data: { type: src.data.outputs[c.sourceHandle].type } };
}

/** A new block wired to a dragged port (its first port that fits), as one undo step. */
function addBlockFrom(state: EditorState, type: string, position: Position, port: PortRef): EditorState {
  const node = newBlock(state, type, position);
  if (node === null) return state;
  if (typeof node === "string") return { ...state, toast: node };
  const graph = state.history.present;
  const nodes = [...deselected(graph.nodes), node];
  let c: Connection | null = null;
  if (port.side === "source") {
    const input = firstInputFor(nodes, graph.edges, node, port.node, port.handle);
    if (input) c = { source: port.node, sourceHandle: port.handle, target: node.id, targetHandle: input };
  } else {
    const output = firstOutputFor(nodes, graph.edges, node, port.node, port.handle);
    if (output) c = { source: node.id, sourceHandle: output, target: port.node, targetHandle: port.handle };
  }
  if (!c) return { ...state, toast: `refused: no port of ${type} fits ${port.node}.${port.handle}` };
  return edit(state, { nodes, edges: [...withoutOccupant(graph.edges, c.target, c.targetHandle), wire(nodes, c)] });
}

/** A new block on a wire: the wire's source feeds it, it feeds the wire's target; one undo step. */
function insertBlock(state: EditorState, type: string, position: Position, edgeIdent: string): EditorState {
  const graph = state.history.present;
  const old = graph.edges.find((e) => e.id === edgeIdent);
  if (!old) return state;
  const node = newBlock(state, type, position);
  if (node === null) return state;
  if (typeof node === "string") return { ...state, toast: node };
  const nodes = [...deselected(graph.nodes), node];
  const rest = graph.edges.filter((e) => e.id !== old.id);
  const input = firstInputFor(nodes, rest, node, old.source, old.sourceHandle);
  const output = firstOutputFor(nodes, rest, node, old.target, old.targetHandle);
  if (!input || !output) return { ...state, toast: `refused: ${type} does not fit on that wire` };
  const a = wire(nodes, { source: old.source, sourceHandle: old.sourceHandle, target: node.id, targetHandle: input });
  const b = wire(nodes, { source: node.id, sourceHandle: output, target: old.target, targetHandle: old.targetHandle });
  return edit(state, { nodes, edges: [...rest, a, b] });
}

/** Nodes and edges removed together (with every edge of a removed node): one undo step. */
function deleteElements(state: EditorState, nodeIds: string[], edgeIds: string[]): EditorState {
  const graph = state.history.present;
  const gone = new Set(nodeIds);
  const cut = new Set(edgeIds);
  const nodes = graph.nodes.filter((n) => !gone.has(n.id));
  const edges = graph.edges.filter((e) => !cut.has(e.id) && !gone.has(e.source) && !gone.has(e.target));
  if (nodes.length === graph.nodes.length && edges.length === graph.edges.length) return state;
  return edit(state, { nodes, edges });
}

/** A new wire; one onto an input that has a wire replaces that wire (one undo step). */
function connect(state: EditorState, c: Connection): EditorState {
  const graph = state.history.present;
  const problem = replacingProblem(graph.nodes, graph.edges, c.source, c.sourceHandle, c.target, c.targetHandle);
  if (problem) return { ...state, toast: `refused: ${problem}` };
  const edge = wire(graph.nodes, c);
  if (graph.edges.some((e) => e.id === edge.id)) return state;
  return edit(state, { ...graph, edges: [...withoutOccupant(graph.edges, c.target, c.targetHandle), edge] });
}

export function reducer(state: EditorState, action: Action): EditorState {
  const graph = state.history.present;
  switch (action.type) {
    case "serverDescribed":
      return { ...state, catalog: action.catalog, robot: action.robot, previz: action.previz };
    case "programLoaded": {
      const { nodes, edges, meta } = programToFlow(action.program, state.catalog);
      return {
        ...state, meta, history: H.init({ nodes, edges }), dirty: false, lastParamEdit: null,
        libName: action.libName === undefined ? state.libName : action.libName,
        report: action.report === undefined ? state.report : action.report,
        loaded: { count: state.loaded.count + 1, fromServer: action.fromServer ?? false },
        live: action.fromServer ?? false, runningName: action.fromServer ? meta.name ?? null : state.runningName,
      };
    }
    case "nodesChanged": {
      const nodes = applyNodeChanges(action.changes, graph.nodes);
      const removed = new Set(action.changes.flatMap((c) => (c.type === "remove" ? [c.id] : [])));
      const edges = removed.size ? graph.edges.filter((e) => !removed.has(e.source) && !removed.has(e.target)) : graph.edges;
      // selection and drag steps are not edits; a drop or a removal is
      const meaningful = action.changes.some((c) => c.type === "remove" || (c.type === "position" && c.dragging === false)
        || (c.type === "dimensions" && c.resizing === false));
      return edit(state, { nodes, edges }, meaningful);
    }
    case "edgesChanged": {
      const edges = applyEdgeChanges(action.changes, graph.edges);
      return edit(state, { ...graph, edges }, action.changes.some((c) => c.type === "remove"));
    }
    case "connected":
      return connect(state, action.connection);
    case "blockAdded":
      return addBlock(state, action.blockType, action.position);
    case "paramsEdited": {
      const next = withParams(graph, state.catalog, action.node, action.params);
      if (!next) return state;
      const last = state.lastParamEdit;
      const coalesce = last?.node === action.node && action.at - last.at < COALESCE_MS;
      const history = coalesce ? H.replace(state.history, next.graph) : H.push(state.history, next.graph);
      return { ...state, history, dirty: true, lastParamEdit: { node: action.node, at: action.at } };
    }
    case "pasted": {
      if (!action.clip.nodes.length) return state;
      // with `at`: the clip's top-left corner lands there (the pointer, or a free spot in view)
      const pasted = action.at ? pasteClipboard(graph.nodes, placedAt(action.clip, action.at), 0) : pasteClipboard(graph.nodes, action.clip);
      return edit(state, { nodes: [...deselected(graph.nodes), ...pasted.nodes], edges: [...graph.edges, ...pasted.edges] });
    }
    case "undo":
      return { ...state, history: H.undo(state.history), lastParamEdit: null };
    case "redo":
      return { ...state, history: H.redo(state.history), lastParamEdit: null };
    case "renamed":
      return state.meta ? { ...state, meta: { ...state.meta, name: action.name }, dirty: true } : state;
    case "syncing":
      return { ...state, syncing: action.on };
    case "reportReceived":
      return { ...state, report: action.report };
    case "saved":
      return {
        ...state, libName: action.name, dirty: false,
        meta: action.rename && state.meta ? { ...state.meta, name: action.name } : state.meta,
      };
    case "wentLive":
      return { ...state, live: true, report: action.report, runningName: state.meta?.name ?? null };
    case "draftStarted":
      return { ...state, live: false };
    case "libraryListed":
      return { ...state, library: action.names };
    case "clipsListed":
      return { ...state, clips: action.names };
    case "inputsLoaded":
      return { ...state, inputs: { decls: action.decls, values: action.values } };
    case "inputSet":
      return { ...state, inputs: { ...state.inputs, values: { ...state.inputs.values, [action.name]: action.value } } };
    case "ghostShown":
      return state.previz ? { ...state, previz: { ...state.previz, ghost: action.visible } } : state;
    case "toast":
      return { ...state, toast: action.message };
    case "toastExpired":
      return state.toast === action.message ? { ...state, toast: null } : state;
    case "logged":
      return { ...state, consoleLines: [...state.consoleLines.slice(-(CONSOLE_LINES - 1)), action.line] };
    case "deleted":
      return deleteElements(state, action.nodes, action.edges);
    case "blockAddedFrom":
      return addBlockFrom(state, action.blockType, action.position, action.port);
    case "blockInserted":
      return insertBlock(state, action.blockType, action.position, action.edge);
    case "disconnected": {
      const { node, handle, side } = action;
      const edges = graph.edges.filter((e) => {
        const asSource = e.source === node && (side !== "target") && (handle === undefined || e.sourceHandle === handle);
        const asTarget = e.target === node && (side !== "source") && (handle === undefined || e.targetHandle === handle);
        return !(asSource || asTarget);
      });
      return edges.length === graph.edges.length ? state : edit(state, { ...graph, edges });
    }
    case "laidOut": {
      const nodes = graph.nodes.map((n) => (action.positions[n.id] ? { ...n, position: { ...action.positions[n.id] } } : n));
      return edit(state, { ...graph, nodes }, action.undoable);
    }
    case "selectedAll":
      return edit(state, { ...graph, nodes: graph.nodes.map((n) => (n.selected ? n : { ...n, selected: true })) }, false);
    case "selectedOnly": {
      const keep = new Set(action.nodes);
      const nodes = graph.nodes.map((n) => (!!n.selected === keep.has(n.id) ? n : { ...n, selected: keep.has(n.id) }));
      return edit(state, { ...graph, nodes }, false);
    }
    case "overlayShown":
      return { ...state, overlay: action.overlay };
    case "nodeRenamed":
      return renameNode(state, action.from, action.to);
    case "ungrouped":
      return ungroupNode(state, action.node);
    case "bypassToggled":
    case "duplicated":
      return editCommand(state, action);
    case "clipRequested":
    case "clipCloseRequested":
    case "clipRequestGranted":
    case "clipRequestDropped":
    case "clipTabShown":
    case "clipSaved":
      return clipReducer(state, action);
    case "behaviourRequested":
    case "behaviourCloseRequested":
    case "behaviourRequestGranted":
    case "behaviourRequestDropped":
    case "behaviourSaved":
      return behaviourReducer(state, action);
    default:
      return organise(state, action);  // subgraphs, comment frames, reroutes (../subgraphs)
  }
}
