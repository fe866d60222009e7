// Ungrouping a subgraph node: its definition's blocks take its place (ids already taken get fresh ones),
// laid where the node was, and the wires of the enclosing graph go to the inner ports they stood for.
// One undo step; the definition stays in the program (undo brings the node back). Pure (tested with vitest).
import type { Program } from "./api";
import { isAnnotation } from "./annotations";
import { edgeId, freshId, programToFlow, SUBGRAPH, type FlowEdge, type FlowNode, type SubgraphDef } from "./graph";
import * as H from "./history";
import type { EditorState } from "./store/types";

/** The state with subgraph node `id` replaced by its definition's blocks, or with a toast saying why not. */
export function ungroupNode(state: EditorState, id: string): EditorState {
  const graph = state.history.present;
  const node = graph.nodes.find((n) => n.id === id);
  if (!node || node.data.type !== SUBGRAPH || !state.meta) return state;
  const name = String(node.data.params.subgraph ?? "");
  const def = (state.meta.subgraphs ?? {})[name] as SubgraphDef | undefined;
  if (!def) return { ...state, toast: `cannot ungroup: this program defines no subgraph '${name}'` };
  const inner = programToFlow({ nodes: def.nodes ?? [], edges: def.edges ?? [], subgraphs: state.meta.subgraphs } as Program, state.catalog);
  const blocks = inner.nodes.filter((n) => !isAnnotation(n));
  const rest = graph.nodes.filter((n) => n.id !== id).map((n) => (n.selected ? { ...n, selected: false } : n));
  // fresh ids where the enclosing graph has them already; laid out from where the node was
  const rename: Record<string, string> = {};
  const all: FlowNode[] = [...rest];
  const left = Math.min(...blocks.map((n) => n.position.x)), top = Math.min(...blocks.map((n) => n.position.y));
  const placed = blocks.map((n) => {
    const fresh = freshId(all, n.id);
    rename[n.id] = fresh;
    const copy: FlowNode = { ...n, id: fresh, selected: true,
      position: { x: node.position.x + n.position.x - left, y: node.position.y + n.position.y - top } };
    all.push(copy);
    return copy;
  });
  const wire = (e: Omit<FlowEdge, "id">): FlowEdge => ({ ...e, id: edgeId(e) });
  const innerEdges = inner.edges.map((e) => wire({ ...e, source: rename[e.source], target: rename[e.target] }));
  const port = (list: SubgraphDef["inputs"], exposed: string) => list.find((p) => p.name === exposed);
  const outer = graph.edges.flatMap((e): FlowEdge[] => {
    if (e.target === id) {
      const p = port(def.inputs ?? [], e.targetHandle);
      return p ? [wire({ ...e, target: rename[p.node], targetHandle: p.port })] : [];
    }
    if (e.source === id) {
      const p = port(def.outputs ?? [], e.sourceHandle);
      return p ? [wire({ ...e, source: rename[p.node], sourceHandle: p.port })] : [];
    }
    return [e];
  });
  // reroutes on the node's wires lose their wire
  const kept = rest.filter((n) => n.type !== "reroute" || outer.some((e) => e.id === n.data.params.edge));
  return { ...state, dirty: true, history: H.push(state.history, { nodes: [...kept, ...placed], edges: [...outer, ...innerEdges] }) };
}
