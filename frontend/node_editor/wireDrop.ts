// A wire being dragged: the ports that cannot take it (dimmed on the canvas while it is dragged) and where
// it goes when dropped on a block's body instead of a port. The rules are the port rules (./quickAdd).
import { createContext, useContext } from "react";
import type { FlowEdge, FlowNode } from "./graph";
import { replacingProblem, type PortRef } from "./quickAdd";
import type { Connection } from "./store/types";

/** A port's key in the dimmed set: `<node>:<side>:<handle>`. */
export const portKey = (node: string, side: "source" | "target", handle: string) => `${node}:${side}:${handle}`;

/** The ports to dim while a wire from `from` is dragged (empty when nothing is dragged). */
export const DimContext = createContext<ReadonlySet<string>>(new Set());

/** For node `id`: the class suffix of a port while a wire that port cannot take is dragged (" dimmed"). */
export function useFaded(id: string): (side: "source" | "target", port: string) => string {
  const dim = useContext(DimContext);
  return (side, port) => (dim.has(portKey(id, side, port)) ? " dimmed" : "");
}

/** Every port of the canvas's blocks that a wire dragged from `from` cannot be dropped on: the ports on its
 * own side, and those of the other side the rules refuse. */
export function incompatiblePorts(nodes: FlowNode[], edges: FlowEdge[], from: PortRef): Set<string> {
  const out = new Set<string>();
  for (const n of nodes) {
    for (const h of Object.keys(n.data.outputs)) {
      if (from.side === "source") { if (n.id !== from.node || h !== from.handle) out.add(portKey(n.id, "source", h)); }
      else if (replacingProblem(nodes, edges, n.id, h, from.node, from.handle) !== null) out.add(portKey(n.id, "source", h));
    }
    for (const h of Object.keys(n.data.inputs)) {
      if (from.side === "target") { if (n.id !== from.node || h !== from.handle) out.add(portKey(n.id, "target", h)); }
      else if (replacingProblem(nodes, edges, from.node, from.handle, n.id, h) !== null) out.add(portKey(n.id, "target", h));
    }
  }
  return out;
}

/** The wire a drag from `from` makes when dropped on the body of block `onto`: to its first input that
 * can take it (a free one before one whose wire it would replace), or from its first output that fits;
 * else why not. */
export function dropOnBody(nodes: FlowNode[], edges: FlowEdge[], from: PortRef, onto: string): Connection | string {
  const node = nodes.find((n) => n.id === onto);
  if (!node) return "unknown block";
  if (onto === from.node) return "a block cannot feed itself";
  const wired = (h: string) => edges.some((e) => e.target === onto && e.targetHandle === h);
  if (from.side === "source") {
    const fits = Object.keys(node.data.inputs).filter((h) => replacingProblem(nodes, edges, from.node, from.handle, onto, h) === null);
    const input = fits.find((h) => !wired(h)) ?? fits[0];
    return input ? { source: from.node, sourceHandle: from.handle, target: onto, targetHandle: input }
      : `no input of ${onto} takes ${from.node}.${from.handle}`;
  }
  const output = Object.keys(node.data.outputs).find((h) => replacingProblem(nodes, edges, onto, h, from.node, from.handle) === null);
  return output ? { source: onto, sourceHandle: output, target: from.node, targetHandle: from.handle }
    : `no output of ${onto} fits ${from.node}.${from.handle}`;
}
