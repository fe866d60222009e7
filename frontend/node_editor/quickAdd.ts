// Which blocks the quick-add search offers: all of them, or those that can take (or feed) a dragged
// port, or those that fit on a wire. Decided with the same rules as a drop (`connectionProblem`) on a
// hypothetical node of each type with its default parameters. Pure (tested with vitest).
import type { BlockEntry, Catalog } from "./api";
import { connectionProblem, type FlowEdge, type FlowNode } from "./graph";
import { CATEGORIES, defaultParams, portsOf } from "./ports";

/** A port of a node on the canvas: `source` for an output, `target` for an input. */
export interface PortRef { node: string; handle: string; side: "source" | "target" }

/** What the search is for: any block, a block wired to a dragged port, or a block inserted on a wire. */
export type QuickAddMode = { kind: "any" } | { kind: "from"; port: PortRef } | { kind: "insert"; edge: string };

/** One offered block, with the ports of it that would be wired (`input` fed, `output` feeding). */
export interface Offer { type: string; entry: BlockEntry; input?: string; output?: string }

const HYPOTHETICAL = "\u0000new";

function hypothetical(entry: BlockEntry): FlowNode {
  const params = defaultParams(entry);
  const { inputs, outputs } = portsOf(entry, params);
  return { id: HYPOTHETICAL, type: "block", position: { x: 0, y: 0 }, data: { type: entry.type, params, ui: {}, inputs, outputs, errors: [] } };
}

/** The edges without the one that now feeds an input (a new wire to it replaces that one). */
export function withoutOccupant(edges: FlowEdge[], target: string, targetHandle: string): FlowEdge[] {
  return edges.filter((e) => !(e.target === target && e.targetHandle === targetHandle));
}

/** Why wiring source -> target is refused when a wire already on that input would be replaced, or null. */
export function replacingProblem(nodes: FlowNode[], edges: FlowEdge[], source: string, sourceHandle: string, target: string, targetHandle: string) {
  return connectionProblem(nodes, withoutOccupant(edges, target, targetHandle), source, sourceHandle, target, targetHandle);
}

/** The first input of `node` that `source.sourceHandle` may feed (in the node's port order), if any. */
export function firstInputFor(nodes: FlowNode[], edges: FlowEdge[], node: FlowNode, source: string, sourceHandle: string) {
  const all = nodes.some((n) => n.id === node.id) ? nodes : [...nodes, node];
  return Object.keys(node.data.inputs).find((h) => replacingProblem(all, edges, source, sourceHandle, node.id, h) === null);
}

/** The first output of `node` that may feed `target.targetHandle` (replacing its wire), if any. */
export function firstOutputFor(nodes: FlowNode[], edges: FlowEdge[], node: FlowNode, target: string, targetHandle: string) {
  const all = nodes.some((n) => n.id === node.id) ? nodes : [...nodes, node];
  return Object.keys(node.data.outputs).find((h) => replacingProblem(all, edges, node.id, h, target, targetHandle) === null);
}

const hasOutput = (catalog: Catalog, nodes: FlowNode[]) => nodes.some((n) => catalog[n.data.type]?.role === "output");

/** The blocks the search offers for `mode`, in palette order (category, then title). */
export function offers(catalog: Catalog, nodes: FlowNode[], edges: FlowEdge[], mode: QuickAddMode): Offer[] {
  const order = CATEGORIES.map((c) => c.name);
  const entries = Object.values(catalog)
    .filter((e) => e.role !== "output" || !hasOutput(catalog, nodes))
    .sort((a, b) => order.indexOf(a.category) - order.indexOf(b.category) || a.title.localeCompare(b.title));
  const out: Offer[] = [];
  const edge = mode.kind === "insert" ? edges.find((e) => e.id === mode.edge) : undefined;
  if (mode.kind === "insert" && !edge) return out;
  for (const entry of entries) {
    if (mode.kind === "any") { out.push({ type: entry.type, entry }); continue; }
    const node = hypothetical(entry);
    if (mode.kind === "from") {
      const p = mode.port;
      if (p.side === "source") {
        const input = firstInputFor(nodes, edges, node, p.node, p.handle);
        if (input) out.push({ type: entry.type, entry, input });
      } else {
        const output = firstOutputFor(nodes, edges, node, p.node, p.handle);
        if (output) out.push({ type: entry.type, entry, output });
      }
    } else if (edge) {
      const rest = edges.filter((e) => e.id !== edge.id);
      const input = firstInputFor(nodes, rest, node, edge.source, edge.sourceHandle);
      const output = firstOutputFor(nodes, rest, node, edge.target, edge.targetHandle);
      if (input && output) out.push({ type: entry.type, entry, input, output });
    }
  }
  return out;
}

/** Offers whose type, title, summary or category contain every word of the query. */
export function matching(list: Offer[], query: string): Offer[] {
  const words = query.trim().toLowerCase().split(/\s+/).filter(Boolean);
  if (!words.length) return list;
  const scored = list
    .map((o) => {
      const title = o.entry.title.toLowerCase();
      const hay = `${o.type} ${title} ${o.entry.summary ?? ""} ${o.entry.category}`.toLowerCase();
      if (!words.every((w) => hay.includes(w))) return null;
      // title starts with the query first, then title contains it, then the rest
      const q = words.join(" ");
      const rank = title.startsWith(q) || o.type.startsWith(q) ? 0 : title.includes(q) ? 1 : 2;
      return { o, rank };
    })
    .filter((x): x is { o: Offer; rank: number } => x !== null);
  return scored.sort((a, b) => a.rank - b.rank).map((x) => x.o);
}
