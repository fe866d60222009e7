// Auto-layout of the program with ELK (layered, left to right): columns by stage (signals and sources,
// then operators, layers, stage 2, the output), never against the flow, ports kept in their order.
import ELK, { type ElkExtendedEdge, type ElkNode } from "elkjs/lib/elk.bundled.js";
import type { Catalog } from "./api";
import type { FlowEdge, FlowNode } from "./graph";
import { BLOCK_WIDTH } from "./layout/constants";

/** Left-to-right rank of each category: what feeds comes first. */
export const STAGE_RANK: Record<string, number> = { signals: 0, sources: 0, operators: 1, layers: 2, stage2: 3, output: 4 };

export type Size = { width: number; height: number };
const DEFAULT_SIZE: Size = { width: BLOCK_WIDTH, height: 120 };
/** Gaps between columns (room for the wires between them) and between the blocks of a column. */
const COLUMN_GAP = 90;
const ROW_GAP = 36;
/** A port's size to ELK: wires end at its centre. */
const PORT_SIZE = 8;

let elk: InstanceType<typeof ELK> | null = null;

/** Each node's partition: its stage, raised to its inputs' (so no wire ever points back a column). */
export function partitions(nodes: FlowNode[], edges: FlowEdge[], catalog: Catalog): Record<string, number> {
  const part: Record<string, number> = {};
  for (const n of nodes) part[n.id] = STAGE_RANK[catalog[n.data.type]?.category ?? "operators"] ?? 1;
  for (let pass = 0; pass < nodes.length; pass++) {
    let changed = false;
    for (const e of edges) {
      if (!(e.source in part) || !(e.target in part)) continue;
      if (part[e.target] < part[e.source]) { part[e.target] = part[e.source]; changed = true; }
    }
    if (!changed) break;
  }
  return part;
}

/** New top-left positions for the nodes (sizes as React Flow measured them, where known). */
export async function layoutGraph(
  nodes: FlowNode[], edges: FlowEdge[], catalog: Catalog, sizes: Record<string, Size> = {},
): Promise<Record<string, { x: number; y: number }>> {
  elk ??= new ELK();
  const part = partitions(nodes, edges, catalog);
  const ids = new Set(nodes.map((n) => n.id));
  const graph: ElkNode = {
    id: "root",
    layoutOptions: {
      "elk.algorithm": "layered",
      "elk.direction": "RIGHT",
      "elk.partitioning.activate": "true",
      "elk.layered.spacing.nodeNodeBetweenLayers": String(COLUMN_GAP),
      "elk.spacing.nodeNode": String(ROW_GAP),
      "elk.layered.nodePlacement.strategy": "NETWORK_SIMPLEX",
      "elk.layered.crossingMinimization.semiInteractive": "true",
      "elk.edgeRouting": "SPLINES",
    },
    children: nodes.map((n, order) => {
      const size = sizes[n.id] ?? DEFAULT_SIZE;
      const ins = Object.keys(n.data.inputs), outs = Object.keys(n.data.outputs);
      return {
        id: n.id, width: size.width, height: size.height,
        layoutOptions: {
          "elk.partitioning.partition": String(part[n.id]),
          "elk.portConstraints": "FIXED_ORDER",
          // keeps the document's order among nodes of one column where crossings allow
          "elk.position": `(${n.position.x},${order})`,
        },
        // ELK orders ports clockwise: east ones top to bottom, then west ones bottom to top
        ports: [
          ...ins.map((p, i) => ({ id: `${n.id}\u0000in\u0000${p}`, width: PORT_SIZE, height: PORT_SIZE,
            layoutOptions: { "elk.port.side": "WEST", "elk.port.index": String(outs.length + ins.length - 1 - i) } })),
          ...outs.map((p, i) => ({ id: `${n.id}\u0000out\u0000${p}`, width: PORT_SIZE, height: PORT_SIZE,
            layoutOptions: { "elk.port.side": "EAST", "elk.port.index": String(i) } })),
        ],
      };
    }),
    edges: edges.filter((e) => ids.has(e.source) && ids.has(e.target)).map((e): ElkExtendedEdge => ({
      id: e.id, sources: [`${e.source}\u0000out\u0000${e.sourceHandle}`], targets: [`${e.target}\u0000in\u0000${e.targetHandle}`],
      // the frame path (what the robot does) runs straight; signal wires bend around it
      layoutOptions: { "elk.layered.priority.straightness": (e.data?.type ?? "frame") === "frame" ? "10" : "0" },
    })),
  };
  const out = await elk.layout(graph);
  const positions: Record<string, { x: number; y: number }> = {};
  for (const c of out.children ?? []) positions[c.id] = { x: Math.round(c.x ?? 0), y: Math.round(c.y ?? 0) };
  return positions;
}
