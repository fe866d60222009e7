// Program document <-> React Flow graph, connection checks, auto-layout and paste.
// Pure functions (tested with vitest); ports and type rules come from the backend (./ports), and the
// server stays the judge of validity.
import { annotationsFromFlow, annotationsToFlow, isAnnotation } from "./annotations";
import type { Catalog, Program } from "./api";
import type { FlowEdge, FlowNode } from "./flowTypes";
import type { History } from "./history";
import { accepts, portsOf, type Ports } from "./ports";

// the canvas's node and edge shapes live apart (./flowTypes), so that ./annotations needs nothing from here
export type { FlowEdge, FlowNode, NodeData } from "./flowTypes";

/** The simple layout's spacing of columns (by depth) and rows (document order): a block's width or
 * height and a gap. The canvas's auto-layout (./autoLayout, ELK) measures instead. */
const DEPTH_LAYOUT_STEP = { x: 270, y: 150 };
/** Pasted blocks land this far right of and below their originals, so both stay visible. */
const PASTE_OFFSET = 40;

/** The `type` of a node that uses a subgraph (`params.subgraph` names its definition). */
export const SUBGRAPH = "subgraph";
export interface ExposedPort { name: string; node: string; port: string }
export interface SubgraphDef {
  description?: string;
  nodes: Program["nodes"];
  edges: Program["edges"];
  inputs: ExposedPort[];
  outputs: ExposedPort[];
  ui?: Record<string, unknown>;
}

/** While a subgraph is open, the canvas shows its inside and `meta.inside` says where it sits: the
 * enclosing graph (with its undo history) and meta, to compose the whole program from (flowToProgram). */
export interface Inside {
  name: string;
  instance: string;
  /** The instance's flat id on the server (`idle`, nested `life/idle`): inner blocks run as `<path>/<id>`. */
  path: string;
  outer: History<{ nodes: FlowNode[]; edges: FlowEdge[] }>;
  outerMeta: Meta;
  description: string;
  inputs: ExposedPort[];
  outputs: ExposedPort[];
}

export type Meta = Omit<Program, "nodes" | "edges"> & { inside?: Inside };

/** Ports of a node: a block's from the catalog; a subgraph node's are its definition's exposed ports
 * with the types of the inner ports they stand for (nested subgraphs followed, loops cut). */
export function nodePorts(type: string, params: Record<string, unknown>, defs: Record<string, unknown> | undefined | null,
  catalog: Catalog, seen: string[] = []): Ports {
  if (type !== SUBGRAPH) return portsOf(catalog[type], params);
  const name = String(params.subgraph ?? "");
  const def = (defs ?? {})[name] as SubgraphDef | undefined;
  if (!def || seen.includes(name)) return { inputs: {}, outputs: {} };
  const inner = (node: string) => {
    const n = (def.nodes ?? []).find((x) => x.id === node);
    return n ? nodePorts(n.type, (n.params ?? {}) as Record<string, unknown>, defs, catalog, [...seen, name]) : null;
  };
  const side = (list: ExposedPort[], kind: keyof Ports) => Object.fromEntries(list.flatMap((p) => {
    const spec = inner(p.node)?.[kind][p.port];
    return spec ? [[p.name, { ...spec, doc: `${p.node}.${p.port}${spec.doc ? " — " + spec.doc : ""}` }]] : [];
  }));
  return { inputs: side(def.inputs ?? [], "inputs"), outputs: side(def.outputs ?? [], "outputs") };
}

/** Why a connection is refused, or null when it is allowed. */
export function connectionProblem(
  nodes: FlowNode[], edges: FlowEdge[], source: string, sourceHandle: string, target: string, targetHandle: string,
): string | null {
  if (source === target) return "a block cannot feed itself";
  const s = nodes.find((n) => n.id === source);
  const t = nodes.find((n) => n.id === target);
  if (!s || !t) return "unknown node";
  const out = s.data.outputs[sourceHandle];
  const inp = t.data.inputs[targetHandle];
  if (!out || !inp) return "unknown port";
  if (!accepts(inp.type, out.type)) return `cannot connect ${out.type} output '${source}.${sourceHandle}' to ${inp.type} input '${target}.${targetHandle}'`;
  if (edges.some((e) => e.target === target && e.targetHandle === targetHandle))
    return `input '${target}.${targetHandle}' already has an edge; one edge per input`;
  if (reaches(edges, target, source)) return "that connection would make a cycle";
  return null;
}

function reaches(edges: FlowEdge[], from: string, to: string): boolean {
  const seen = new Set<string>();
  const stack = [from];
  while (stack.length) {
    const n = stack.pop()!;
    if (n === to) return true;
    if (seen.has(n)) continue;
    seen.add(n);
    for (const e of edges) if (e.source === n) stack.push(e.target);
  }
  return false;
}

export function edgeId(e: { source: string; sourceHandle: string; target: string; targetHandle: string }) {
  return `${e.source}.${e.sourceHandle}->${e.target}.${e.targetHandle}`;
}

/** Program document -> graph. Nodes without ui positions are laid out left to right by depth. */
export function programToFlow(program: Program, catalog: Catalog): { nodes: FlowNode[]; edges: FlowEdge[]; meta: Meta } {
  const { nodes: pnodes = [], edges: pedges = [], ...meta } = program;
  const positions = needsLayout(program) ? autoLayout(program) : null;
  const blocks: FlowNode[] = pnodes.map((n) => {
    const ui = (n.ui ?? {}) as Record<string, unknown>;
    const params = (n.params ?? {}) as Record<string, unknown>;
    const { inputs, outputs } = nodePorts(n.type, params, meta.subgraphs, catalog);
    const pos = positions?.[n.id] ?? { x: Number(ui.x ?? 0), y: Number(ui.y ?? 0) };
    const type = n.type === SUBGRAPH ? "subgraph" : "block";
    const bypass = n.bypass === true ? { bypass: true } : {};
    return { id: n.id, type, position: pos, data: { type: n.type, params, ui, inputs, outputs, errors: [], ...bypass } };
  });
  // comment frames first (drawn behind), reroutes last; the rest of `ui` stays in meta
  const notes = annotationsToFlow(meta.ui as Record<string, unknown> | undefined);
  if (meta.ui) meta.ui = notes.rest;
  const nodes = [...notes.nodes.filter((n) => n.type === "comment"), ...blocks, ...notes.nodes.filter((n) => n.type === "reroute")];
  const edges: FlowEdge[] = (pedges ?? []).map((e) => {
    const src = nodes.find((n) => n.id === e.from.node);
    const t = src?.data.outputs[e.from.port]?.type ?? "frame";
    const fe = { source: e.from.node, sourceHandle: e.from.port, target: e.to.node, targetHandle: e.to.port };
    return { id: edgeId(fe), ...fe, data: { type: t } };
  });
  return { nodes, edges, meta: meta as Meta };
}

/** Graph -> program document (editor positions go to `ui`, semantics stay apart). While a subgraph is
 * open (`meta.inside`), the graph is its inside: the whole program is composed around it. */
export function flowToProgram(nodes: FlowNode[], edges: FlowEdge[], meta: Meta): Program {
  const { inside, ...plain } = meta;
  if (inside) {
    const def = flowToProgram(nodes, edges, { ui: plain.ui } as Meta);
    const definition: SubgraphDef = {
      description: inside.description, nodes: def.nodes, edges: def.edges, inputs: inside.inputs, outputs: inside.outputs,
      ...(def.ui && Object.keys(def.ui).length ? { ui: def.ui } : {}),
    };
    const outer = inside.outer.present;
    // wires of the enclosing graph to ports this definition no longer exposes are cut
    const mine = new Set(outer.nodes.filter((n) => n.data.type === SUBGRAPH && n.data.params.subgraph === inside.name).map((n) => n.id));
    const wired = outer.edges.filter((e) => (!mine.has(e.target) || inside.inputs.some((p) => p.name === e.targetHandle))
      && (!mine.has(e.source) || inside.outputs.some((p) => p.name === e.sourceHandle)));
    return flowToProgram(outer.nodes, wired,
      { ...inside.outerMeta, name: plain.name, subgraphs: { ...(plain.subgraphs ?? {}), [inside.name]: definition } } as Meta);
  }
  const notes = annotationsFromFlow(nodes, edges);
  const ui = { ...(plain.ui ?? {}) } as Record<string, unknown>;
  if (notes.comments.length) ui.comments = notes.comments;
  if (notes.reroutes.length) ui.reroutes = notes.reroutes;
  const hasUi = plain.ui !== undefined || notes.comments.length || notes.reroutes.length;
  return {
    ...plain,
    ...(hasUi ? { ui } : {}),
    nodes: nodes.filter((n) => !isAnnotation(n)).map((n) => ({
      id: n.id,
      type: n.data.type,
      params: n.data.params,
      ui: { ...n.data.ui, x: Math.round(n.position.x), y: Math.round(n.position.y) },
      ...(n.data.bypass ? { bypass: true } : {}),
    })),
    edges: edges.map((e) => ({ from: { node: e.source, port: e.sourceHandle }, to: { node: e.target, port: e.targetHandle } })),
  } as Program;
}

function needsLayout(p: Program): boolean {
  return (p.nodes ?? []).some((n) => typeof n.ui?.x !== "number" || typeof n.ui?.y !== "number");
}

/** Layered layout: column = longest path from a source, rows in document order. */
export function autoLayout(p: Program, dx = DEPTH_LAYOUT_STEP.x, dy = DEPTH_LAYOUT_STEP.y): Record<string, { x: number; y: number }> {
  const nodes = p.nodes ?? [];
  const edges = p.edges ?? [];
  const depth: Record<string, number> = {};
  for (const n of nodes) depth[n.id] = 0;
  for (let pass = 0; pass < nodes.length; pass++) {
    let changed = false;
    for (const e of edges) {
      const d = (depth[e.from.node] ?? 0) + 1;
      if (e.to.node in depth && d > depth[e.to.node]) {
        depth[e.to.node] = d;
        changed = true;
      }
    }
    if (!changed) break;
  }
  const rows: Record<number, number> = {};
  const out: Record<string, { x: number; y: number }> = {};
  for (const n of nodes) {
    const c = depth[n.id];
    const r = rows[c] ?? 0;
    rows[c] = r + 1;
    out[n.id] = { x: c * dx, y: r * dy };
  }
  return out;
}

/** A fresh node id for a block type, unique in the graph. */
export function freshId(nodes: FlowNode[], type: string): string {
  const ids = new Set(nodes.map((n) => n.id));
  if (!ids.has(type)) return type;
  for (let k = 2; ; k++) if (!ids.has(`${type}_${k}`)) return `${type}_${k}`;
}

/** Copy: the selected nodes and the edges between them; paste gives fresh ids and an offset. */
export function pasteClipboard(
  existing: FlowNode[], clip: { nodes: FlowNode[]; edges: FlowEdge[] }, offset = PASTE_OFFSET,
): { nodes: FlowNode[]; edges: FlowEdge[] } {
  const rename: Record<string, string> = {};
  const all = [...existing];
  const nodes = clip.nodes.map((n) => {
    const id = freshId(all, n.id.replace(/_\d+$/, ""));
    rename[n.id] = id;
    const copy: FlowNode = { ...structuredClone(n), id, selected: true, position: { x: n.position.x + offset, y: n.position.y + offset } };
    all.push(copy);
    return copy;
  });
  const edges = clip.edges
    .filter((e) => rename[e.source] && rename[e.target])
    .map((e) => {
      const fe = { source: rename[e.source], sourceHandle: e.sourceHandle, target: rename[e.target], targetHandle: e.targetHandle };
      return { ...e, ...fe, id: edgeId(fe) };
    });
  return { nodes, edges };
}
