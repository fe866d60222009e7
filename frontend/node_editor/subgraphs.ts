// Subgraphs in the editor: a subgraph node's ports (from its definition), grouping a selection into a
// subgraph, opening one to edit its inside and going back, inserting one from the library, and the
// annotations (comments, reroutes). The program format is docs/program-format.md "Subgraphs"; the
// server flattens subgraphs and stays the judge of validity. Pure functions (tested with vitest); the
// reducer's cases for these actions delegate to `organise`.
import type { Catalog, PortSpec } from "./api";
import { commentNode, COMMENT_COLOURS, COMMENT_SIZE, freshAnnotationId, isAnnotation, rerouteNode, REROUTE_SIZE } from "./annotations";
import {
  edgeId, flowToProgram, freshId, nodePorts, programToFlow, SUBGRAPH, type ExposedPort, type FlowEdge, type FlowNode, type Meta,
  type SubgraphDef,
} from "./graph";
import * as H from "./history";
import { NEW_BLOCK_CLEARANCE, NEW_BLOCK_STEP } from "./layout/constants";
import type { EditorState, Graph, Position } from "./store/types";

export { nodePorts, SUBGRAPH };
export type { ExposedPort, SubgraphDef };

export type OrganiseAction =
  | { type: "grouped"; name: string; ports: Candidate[] }
  | { type: "subgraphOpened"; node: string }
  | { type: "subgraphClosed"; levels?: number }
  | { type: "subgraphInserted"; name: string; definition: SubgraphDef; position: Position }
  | { type: "commentAdded"; position: Position; size?: { w: number; h: number } }
  | { type: "rerouteAdded"; edge: string; position: Position }
  | { type: "exposedEdited"; ports: Candidate[]; description?: string };

/** A port that grouping can expose: an inner block's port, and whether a wire crosses the group's edge there. */
export interface Candidate {
  kind: "input" | "output"; node: string; port: string; name: string; type: string; crossing: boolean;
  /** Exposed already (editing an open subgraph's ports). */
  checked?: boolean;
}

/** Every port of the open subgraph's blocks it could expose (inputs that an inner wire feeds cannot be),
 * those it exposes now checked and under their names. */
export function exposedCandidates(graph: Graph, meta: Meta | null): Candidate[] {
  const inside = meta?.inside;
  if (!inside) return [];
  const out: Candidate[] = [];
  for (const n of graph.nodes) {
    if (isAnnotation(n)) continue;
    for (const [kind, ports, list] of [["input", n.data.inputs, inside.inputs], ["output", n.data.outputs, inside.outputs]] as const) {
      for (const [port, spec] of Object.entries(ports)) {
        if (kind === "input" && graph.edges.some((e) => e.target === n.id && e.targetHandle === port)) continue;
        const current = list.find((p) => p.node === n.id && p.port === port);
        out.push({ kind, node: n.id, port, name: current?.name ?? `${n.id}_${port}`, type: spec.type, crossing: false, checked: !!current });
      }
    }
  }
  return out;
}

/** The blocks of a selection (not comments or reroutes). */
export function selectedBlocks(graph: Graph): FlowNode[] {
  return graph.nodes.filter((n) => n.selected && !isAnnotation(n));
}

/** Every port grouping `ids` could expose: wires crossing the edge first (to be pre-checked), then free ports. */
export function groupCandidates(graph: Graph, ids: string[]): Candidate[] {
  const inside = new Set(ids);
  const out: Candidate[] = [];
  const seen = new Set<string>();
  const add = (kind: Candidate["kind"], node: string, port: string, crossing: boolean) => {
    const key = `${kind}:${node}.${port}`;
    if (seen.has(key)) return;
    seen.add(key);
    const n = graph.nodes.find((x) => x.id === node);
    const spec = (kind === "input" ? n?.data.inputs : n?.data.outputs)?.[port];
    out.push({ kind, node, port, name: `${node}_${port}`, type: spec?.type ?? "frame", crossing });
  };
  for (const e of graph.edges) {
    if (!inside.has(e.source) && inside.has(e.target)) add("input", e.target, e.targetHandle, true);
    if (inside.has(e.source) && !inside.has(e.target)) add("output", e.source, e.sourceHandle, true);
  }
  for (const id of ids) {
    const n = graph.nodes.find((x) => x.id === id);
    if (!n) continue;
    for (const port of Object.keys(n.data.inputs))
      if (!graph.edges.some((e) => e.target === id && e.targetHandle === port)) add("input", id, port, false);
    for (const port of Object.keys(n.data.outputs))
      if (!graph.edges.some((e) => e.source === id && e.sourceHandle === port)) add("output", id, port, false);
  }
  return out;
}

function freshName(taken: Iterable<string>, base: string): string {
  const names = new Set(taken);
  if (!names.has(base)) return base;
  for (let k = 2; ; k++) if (!names.has(`${base}_${k}`)) return `${base}_${k}`;
}

const VALID_NAME = /^[A-Za-z_][A-Za-z0-9_\-.]{0,63}$/;

/** The selection grouped into one subgraph node: its definition goes into the program's subgraphs,
 * the wires crossing the selection's edge go to the node's exposed ports. `ports`: those to expose. */
export function groupSelection(graph: Graph, meta: Meta, catalog: Catalog, name: string, ports: Candidate[]
): { graph: Graph; meta: Meta; node: string } | string {
  const blocks = selectedBlocks(graph);
  if (blocks.length < 1) return "select the blocks to group first";
  if (!VALID_NAME.test(name)) return `'${name}' is not a valid name (a letter or _, then letters, digits, _ - .)`;
  const ids = new Set(blocks.map((n) => n.id));
  const defs = { ...(meta.subgraphs ?? {}) } as Record<string, SubgraphDef>;
  // a name whose definition nothing uses any more (e.g. a grouping undone) is free again
  const used = usedDefinitions(graph.nodes, defs);
  const defName = freshName(Object.keys(defs).filter((k) => used.has(k)), name);
  const inputs: ExposedPort[] = [];
  const outputs: ExposedPort[] = [];
  const names = { input: new Set<string>(), output: new Set<string>() };
  const exposedAs: Record<string, string> = {};
  for (const c of ports) {
    if (!ids.has(c.node)) continue;
    const key = `${c.kind}:${c.node}.${c.port}`;
    if (exposedAs[key]) continue;
    const outer = freshName(names[c.kind], VALID_NAME.test(c.name) ? c.name : `${c.node}_${c.port}`.replace(/[^A-Za-z0-9_\-.]/g, "_"));
    names[c.kind].add(outer);
    exposedAs[key] = outer;
    (c.kind === "input" ? inputs : outputs).push({ name: outer, node: c.node, port: c.port });
  }
  const crossingIn = graph.edges.filter((e) => !ids.has(e.source) && ids.has(e.target));
  const crossingOut = graph.edges.filter((e) => ids.has(e.source) && !ids.has(e.target));
  const missing = [
    ...crossingIn.filter((e) => !exposedAs[`input:${e.target}.${e.targetHandle}`]).map((e) => `${e.target}.${e.targetHandle}`),
    ...crossingOut.filter((e) => !exposedAs[`output:${e.source}.${e.sourceHandle}`]).map((e) => `${e.source}.${e.sourceHandle}`),
  ];
  if (missing.length) return `a wire crosses the group at ${missing.join(", ")}: expose that port or it would be cut`;
  const innerEdges = graph.edges.filter((e) => ids.has(e.source) && ids.has(e.target));
  const inner = flowToProgram(blocks.map((n) => ({ ...n, selected: false })), innerEdges, { ui: {} } as Meta);
  const left = Math.min(...blocks.map((n) => n.position.x));
  const top = Math.min(...blocks.map((n) => n.position.y));
  const definition: SubgraphDef = {
    description: "", nodes: inner.nodes as SubgraphDef["nodes"], edges: inner.edges as SubgraphDef["edges"], inputs, outputs,
  };
  const innerUi = innerAnnotations(graph, ids);
  if (Object.keys(innerUi).length) definition.ui = innerUi;
  defs[defName] = definition;
  const rest = graph.nodes.filter((n) => !ids.has(n.id));
  const nodeId = freshId(rest, name);
  const { inputs: pin, outputs: pout } = nodePorts(SUBGRAPH, { subgraph: defName }, defs, catalog);
  const node: FlowNode = {
    id: nodeId, type: "subgraph", position: { x: left, y: top }, selected: true,
    data: { type: SUBGRAPH, params: { subgraph: defName }, ui: {}, inputs: pin, outputs: pout, errors: [] },
  };
  const rewired = (e: FlowEdge): FlowEdge => {
    const fe = ids.has(e.target)
      ? { source: e.source, sourceHandle: e.sourceHandle, target: nodeId, targetHandle: exposedAs[`input:${e.target}.${e.targetHandle}`] }
      : { source: nodeId, sourceHandle: exposedAs[`output:${e.source}.${e.sourceHandle}`], target: e.target, targetHandle: e.targetHandle };
    return { ...fe, id: edgeId(fe), data: e.data };
  };
  const outerEdges = graph.edges.filter((e) => !ids.has(e.source) && !ids.has(e.target));
  const keptNodes = rest.filter((n) => n.type !== "reroute" || outerEdges.some((e) => e.id === n.data.params.edge));
  return {
    graph: { nodes: [...keptNodes.map((n) => ({ ...n, selected: false })), node], edges: [...outerEdges, ...crossingIn.map(rewired), ...crossingOut.map(rewired)] },
    meta: { ...meta, subgraphs: defs } as Meta,
    node: nodeId,
  };
}

/** Names of the definitions the graph's subgraph nodes use, directly or through other definitions. */
export function usedDefinitions(nodes: FlowNode[], defs: Record<string, SubgraphDef>): Set<string> {
  const used = new Set<string>();
  const stack = nodes.filter((n) => n.data.type === SUBGRAPH).map((n) => String(n.data.params.subgraph));
  while (stack.length) {
    const name = stack.pop()!;
    if (used.has(name)) continue;
    used.add(name);
    for (const n of defs[name]?.nodes ?? []) if (n.type === SUBGRAPH) stack.push(String(n.params?.subgraph));
  }
  return used;
}

/** Reroutes of wires inside the group move into the definition's `ui`. */
function innerAnnotations(graph: Graph, ids: Set<string>): Record<string, unknown> {
  const reroutes = graph.nodes.filter((n) => n.type === "reroute").flatMap((n) => {
    const e = graph.edges.find((x) => x.id === n.data.params.edge);
    if (!e || !ids.has(e.source) || !ids.has(e.target)) return [];
    return [{ id: n.id, x: Math.round(n.position.x), y: Math.round(n.position.y),
      edge: { from: { node: e.source, port: e.sourceHandle }, to: { node: e.target, port: e.targetHandle } } }];
  });
  return reroutes.length ? { reroutes } : {};
}

/** The names along the way into the open subgraph: ["program", "idle", …]. */
export function breadcrumb(meta: Meta | null): { label: string; levels: number }[] {
  const out: { label: string; levels: number }[] = [];
  let m = meta;
  while (m?.inside) {
    out.unshift({ label: m.inside.name, levels: 0 });
    m = m.inside.outerMeta;
  }
  out.unshift({ label: m?.name ?? "program", levels: 0 });
  return out.map((c, i) => ({ ...c, levels: out.length - 1 - i }));
}

/** The definition being edited (the open subgraph's inside as it is now), or null at the top. */
export function openDefinition(graph: Graph, meta: Meta | null): { name: string; definition: SubgraphDef } | null {
  if (!meta?.inside) return null;
  const composed = flowToProgram(graph.nodes, graph.edges, meta);
  return { name: meta.inside.name, definition: composed.subgraphs![meta.inside.name] as SubgraphDef };
}

function openSubgraph(state: EditorState, id: string): EditorState {
  const graph = state.history.present;
  const meta = state.meta;
  const node = graph.nodes.find((n) => n.id === id);
  if (!meta || !node || node.data.type !== SUBGRAPH) return state;
  const name = String(node.data.params.subgraph ?? "");
  const def = (meta.subgraphs ?? {})[name] as SubgraphDef | undefined;
  if (!def) return { ...state, toast: `this program defines no subgraph '${name}'` };
  const { inside: _, ...plain } = meta;
  const inner = programToFlow({ ...plain, nodes: def.nodes ?? [], edges: def.edges ?? [], ui: def.ui ?? {} }, state.catalog);
  const path = meta.inside ? `${meta.inside.path}/${id}` : id;
  const innerMeta: Meta = {
    ...inner.meta,
    inside: {
      name, instance: id, path, outer: { ...state.history, present: { ...graph, nodes: graph.nodes.map((n) => ({ ...n, selected: n.id === id })) } },
      outerMeta: meta, description: def.description ?? "", inputs: def.inputs ?? [], outputs: def.outputs ?? [],
    },
  };
  return {
    ...state, meta: innerMeta, history: H.init({ nodes: inner.nodes, edges: inner.edges }), lastParamEdit: null,
    loaded: { count: state.loaded.count + 1, fromServer: false, view: true },
  };
}

function closeSubgraph(state: EditorState, levels = 1): EditorState {
  let next = state;
  for (let k = 0; k < levels && next.meta?.inside; k++) {
    const meta = next.meta!;
    const ctx = meta.inside!;
    const composed = flowToProgram(next.history.present.nodes, next.history.present.edges, meta);
    const defs = composed.subgraphs as Record<string, SubgraphDef>;
    const outerMeta = { ...ctx.outerMeta, name: meta.name, subgraphs: defs } as Meta;
    const outer = ctx.outer.present;
    const nodes = outer.nodes.map((n) => n.data.type === SUBGRAPH
      ? { ...n, data: { ...n.data, ...nodePorts(SUBGRAPH, n.data.params, defs, next.catalog) } } : n);
    // wires to ports a definition no longer exposes are cut
    const byId = new Map(nodes.map((n) => [n.id, n]));
    const edges = outer.edges.filter((e) => byId.get(e.source)?.data.outputs[e.sourceHandle] && byId.get(e.target)?.data.inputs[e.targetHandle]);
    next = {
      ...next, meta: outerMeta, history: H.replace(ctx.outer, { nodes, edges }), lastParamEdit: null, dirty: true,
      loaded: { count: next.loaded.count + 1, fromServer: false, view: true },
    };
  }
  return next;
}

function insertSubgraph(state: EditorState, name: string, definition: SubgraphDef, position: Position): EditorState {
  const meta = state.meta;
  if (!meta) return state;
  const graph = state.history.present;
  const defs = { ...(meta.subgraphs ?? {}) } as Record<string, SubgraphDef>;
  let defName = name;
  if (defs[name] && JSON.stringify(defs[name]) !== JSON.stringify(definition)) defName = freshName(Object.keys(defs), name);
  defs[defName] = structuredClone(definition);
  const pos = { ...position };
  const covered = (n: FlowNode) => Math.abs(n.position.x - pos.x) < NEW_BLOCK_CLEARANCE.x && Math.abs(n.position.y - pos.y) < NEW_BLOCK_CLEARANCE.y;
  while (graph.nodes.some((n) => !isAnnotation(n) && covered(n))) pos.y += NEW_BLOCK_STEP;
  const node: FlowNode = {
    id: freshId(graph.nodes, name), type: "subgraph", position: pos, selected: true,
    data: { type: SUBGRAPH, params: { subgraph: defName }, ui: {}, ...nodePorts(SUBGRAPH, { subgraph: defName }, defs, state.catalog), errors: [] },
  };
  return {
    ...state, meta: { ...meta, subgraphs: defs } as Meta, dirty: true,
    history: H.push(state.history, { nodes: [...graph.nodes.map((n) => ({ ...n, selected: false })), node], edges: graph.edges }),
  };
}

/** The reducer's cases for subgraphs and annotations (store/state.ts delegates here). */
export function organise(state: EditorState, action: OrganiseAction): EditorState {
  const graph = state.history.present;
  switch (action.type) {
    case "grouped": {
      if (!state.meta) return state;
      const out = groupSelection(graph, state.meta, state.catalog, action.name, action.ports);
      if (typeof out === "string") return { ...state, toast: `cannot group: ${out}` };
      return { ...state, meta: out.meta, history: H.push(state.history, out.graph), dirty: true };
    }
    case "subgraphOpened":
      return openSubgraph(state, action.node);
    case "subgraphClosed":
      return closeSubgraph(state, action.levels ?? 1);
    case "subgraphInserted":
      return insertSubgraph(state, action.name, action.definition, action.position);
    case "commentAdded": {
      const id = freshAnnotationId(graph.nodes, "note-");
      const size = action.size ?? COMMENT_SIZE;
      const colour = COMMENT_COLOURS[graph.nodes.filter((n) => n.type === "comment").length % COMMENT_COLOURS.length];
      const node = { ...commentNode({ id, x: action.position.x, y: action.position.y, ...size, title: "Comment", colour }), selected: true };
      return { ...state, dirty: true, history: H.push(state.history, { nodes: [node, ...graph.nodes.map((n) => ({ ...n, selected: false }))], edges: graph.edges }) };
    }
    case "exposedEdited": {
      const inside = state.meta?.inside;
      if (!inside) return state;
      const pick = (kind: Candidate["kind"]) => {
        const names = new Set<string>();
        return action.ports.filter((c) => c.kind === kind).map((c) => {
          const name = freshName(names, VALID_NAME.test(c.name) ? c.name : `${c.node}_${c.port}`.replace(/[^A-Za-z0-9_\-.]/g, "_"));
          names.add(name);
          return { name, node: c.node, port: c.port };
        });
      };
      const inputs = pick("input"), outputs = pick("output");
      // a port renamed keeps the wires of the enclosing graph: they follow the new name
      const renamed = (before: ExposedPort[], after: ExposedPort[]) => Object.fromEntries(before.flatMap((p) => {
        const now = after.find((q) => q.node === p.node && q.port === p.port);
        return now && now.name !== p.name ? [[p.name, now.name]] : [];
      }));
      const ins = renamed(inside.inputs, inputs), outs = renamed(inside.outputs, outputs);
      const outer = inside.outer.present;
      const mine = new Set(outer.nodes.filter((n) => n.data.type === SUBGRAPH && n.data.params.subgraph === inside.name).map((n) => n.id));
      const edges = outer.edges.map((e) => {
        const fe = {
          source: e.source, sourceHandle: mine.has(e.source) ? outs[e.sourceHandle] ?? e.sourceHandle : e.sourceHandle,
          target: e.target, targetHandle: mine.has(e.target) ? ins[e.targetHandle] ?? e.targetHandle : e.targetHandle,
        };
        return fe.sourceHandle === e.sourceHandle && fe.targetHandle === e.targetHandle ? e : { ...e, ...fe, id: edgeId(fe) };
      });
      const next = {
        ...inside, inputs, outputs, description: action.description ?? inside.description,
        outer: H.replace(inside.outer, { ...outer, edges }),
      };
      return { ...state, meta: { ...state.meta!, inside: next }, dirty: true };
    }
    case "rerouteAdded": {
      if (!graph.edges.some((e) => e.id === action.edge)) return state;
      const id = freshAnnotationId(graph.nodes, "reroute-");
      const node = rerouteNode({ id, x: action.position.x - REROUTE_SIZE / 2, y: action.position.y - REROUTE_SIZE / 2, edge: action.edge });
      return { ...state, dirty: true, history: H.push(state.history, { nodes: [...graph.nodes, node], edges: graph.edges }) };
    }
  }
}

/** A comment frame's margin around the blocks it is made around, the room above them for its title, and
 * the size it assumes of a block not measured yet. */
const FRAME_MARGIN = 40;
const FRAME_TITLE = 20;
const UNMEASURED = { width: 220, height: 120 };

/** A comment frame around the selected blocks (with a margin), or at `fallback` when none is selected. */
export function frameAround(graph: Graph, fallback: Position): { position: Position; size?: { w: number; h: number } } {
  const sel = selectedBlocks(graph);
  if (!sel.length) return { position: fallback };
  const m = FRAME_MARGIN;
  const xs = sel.map((n) => n.position.x), ys = sel.map((n) => n.position.y);
  const x2 = sel.map((n) => n.position.x + (n.measured?.width ?? UNMEASURED.width)), y2 = sel.map((n) => n.position.y + (n.measured?.height ?? UNMEASURED.height));
  const x = Math.min(...xs) - m, y = Math.min(...ys) - m - FRAME_TITLE;
  return { position: { x, y }, size: { w: Math.max(...x2) + m - x, h: Math.max(...y2) + m - y } };
}

export type { PortSpec };
