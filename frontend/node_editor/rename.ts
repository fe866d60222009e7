// Renaming a node (F2): its id changes everywhere the graph names it — its wires, the reroutes on them and,
// inside an open subgraph, the definition's exposed ports. One undo step. Pure (tested with vitest).
import { edgeId, type FlowEdge, type FlowNode } from "./graph";
import * as H from "./history";
import type { EditorState } from "./store/types";

/** A node id the editor gives: a letter or _, then letters, digits, _ - . (backend NODE_ID_PATTERN, one
 * segment: '/' is the server's, for the blocks of subgraphs). */
export const NODE_ID = /^[A-Za-z_][A-Za-z0-9_\-.]{0,63}$/;

/** Why `to` cannot be the new id of `from`, or null. */
export function renameProblem(nodes: FlowNode[], from: string, to: string): string | null {
  if (!nodes.some((n) => n.id === from)) return `there is no block '${from}'`;
  if (!NODE_ID.test(to)) return `'${to}' is not a valid name: a letter or _, then letters, digits, _ - . (at most 64)`;
  if (to !== from && nodes.some((n) => n.id === to)) return `'${to}' is taken by another block`;
  return null;
}

const swap = (id: string, from: string, to: string) => (id === from ? to : id);

/** The edges with `from` renamed `to`, and what each edge id became. */
function renamedEdges(edges: FlowEdge[], from: string, to: string): { edges: FlowEdge[]; ids: Map<string, string> } {
  const ids = new Map<string, string>();
  const out = edges.map((e) => {
    if (e.source !== from && e.target !== from) return e;
    const fe = { source: swap(e.source, from, to), sourceHandle: e.sourceHandle, target: swap(e.target, from, to), targetHandle: e.targetHandle };
    const id = edgeId(fe);
    ids.set(e.id, id);
    return { ...e, ...fe, id };
  });
  return { edges: out, ids };
}

/** The state with node `from` renamed `to` (one undo step), or with a toast saying why not. */
export function renameNode(state: EditorState, from: string, to: string): EditorState {
  const graph = state.history.present;
  if (from === to) return state;
  const problem = renameProblem(graph.nodes, from, to);
  if (problem) return { ...state, toast: `cannot rename: ${problem}` };
  const { edges, ids } = renamedEdges(graph.edges, from, to);
  const nodes = graph.nodes.map((n) => {
    if (n.id === from) return { ...n, id: to };
    // a reroute names the edge it bends
    const bent = n.type === "reroute" ? ids.get(String(n.data.params.edge)) : undefined;
    return bent ? { ...n, data: { ...n.data, params: { ...n.data.params, edge: bent } } } : n;
  });
  let meta = state.meta;
  const inside = meta?.inside;
  if (meta && inside) {
    const ports = (list: typeof inside.inputs) => list.map((p) => (p.node === from ? { ...p, node: to } : p));
    meta = { ...meta, inside: { ...inside, inputs: ports(inside.inputs), outputs: ports(inside.outputs) } };
  }
  return { ...state, meta, dirty: true, lastParamEdit: null, history: H.push(state.history, { nodes, edges }) };
}
