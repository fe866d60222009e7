// Inside an open subgraph, where its exposed ports go: a "Group Input" node left of its blocks lists the
// exposed inputs, a "Group Output" node right of them the exposed outputs, each wired to the inner port it
// stands for. View only: never in the graph the store keeps, so never saved, synced or undone.
import type { FlowEdge, FlowNode, Inside } from "./graph";
import { isAnnotation } from "./annotations";
import { BLOCK_WIDTH } from "./layout/constants";

export const GROUP_INPUT = "group-io:input";
export const GROUP_OUTPUT = "group-io:output";
/** Gap (flow px) between the stand-ins and the subgraph's blocks. */
const GAP = 120;

/** Whether a canvas node or edge is one of the view-only stand-ins. */
export const isGroupIO = (id: string) => id.startsWith("group-io:");

/** The stand-in nodes and their wires for the open subgraph `inside` (nothing at the top level). */
export function groupIO(nodes: FlowNode[], inside: Inside | undefined): { nodes: FlowNode[]; edges: FlowEdge[] } {
  if (!inside) return { nodes: [], edges: [] };
  const blocks = nodes.filter((n) => !isAnnotation(n));
  const byId = new Map(blocks.map((n) => [n.id, n]));
  const xs = blocks.map((n) => n.position.x), ys = blocks.map((n) => n.position.y);
  const left = xs.length ? Math.min(...xs) : 0, right = xs.length ? Math.max(...xs.map((x, i) => x + (blocks[i].measured?.width ?? BLOCK_WIDTH))) : 0;
  const top = ys.length ? Math.min(...ys) : 0;
  const ports = (list: Inside["inputs"], kind: "inputs" | "outputs") => Object.fromEntries(list.flatMap((p) => {
    const spec = byId.get(p.node)?.data[kind][p.port];
    return spec ? [[p.name, { ...spec, doc: `${p.node}.${p.port}` }]] : [];
  }));
  const stand = (id: string, label: string, x: number, inputs: FlowNode["data"]["inputs"], outputs: FlowNode["data"]["outputs"]): FlowNode => ({
    id, type: "groupIO" as FlowNode["type"], position: { x, y: top },
    data: { type: label, params: {}, ui: {}, inputs, outputs, errors: [] },
    ...{ draggable: false, selectable: false, deletable: false, connectable: false },
  });
  const out: FlowNode[] = [];
  const edges: FlowEdge[] = [];
  if (inside.inputs.length) {
    out.push(stand(GROUP_INPUT, "Group Input", left - BLOCK_WIDTH - GAP, {}, ports(inside.inputs, "inputs")));
    for (const p of inside.inputs) if (byId.has(p.node)) edges.push({
      id: `${GROUP_INPUT}.${p.name}->${p.node}.${p.port}`, source: GROUP_INPUT, sourceHandle: p.name, target: p.node, targetHandle: p.port,
      data: { type: byId.get(p.node)!.data.inputs[p.port]?.type ?? "frame" },
    });
  }
  if (inside.outputs.length) {
    out.push(stand(GROUP_OUTPUT, "Group Output", right + GAP, ports(inside.outputs, "outputs"), {}));
    for (const p of inside.outputs) if (byId.has(p.node)) edges.push({
      id: `${p.node}.${p.port}->${GROUP_OUTPUT}.${p.name}`, source: p.node, sourceHandle: p.port, target: GROUP_OUTPUT, targetHandle: p.name,
      data: { type: byId.get(p.node)!.data.outputs[p.port]?.type ?? "frame" },
    });
  }
  return { nodes: out, edges };
}
