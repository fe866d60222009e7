// The canvas's shapes of a program: its blocks, subgraph nodes and annotations as React Flow nodes, its
// edges as React Flow edges. Types only, shared by the modules that convert the program (./graph) and
// its editor annotations (./annotations), so that neither has to import the other.
import type { PortSpec, PortType } from "./api";

export interface NodeData {
  type: string;
  params: Record<string, unknown>;
  ui: Record<string, unknown>;
  inputs: Record<string, PortSpec>;
  outputs: Record<string, PortSpec>;
  errors: string[];
  /** Bypassed (program node `bypass: true`): the block passes its first frame input through. */
  bypass?: boolean;
  [key: string]: unknown;
}

export interface FlowNode {
  id: string;
  /** "subgraph": a node using a subgraph; "comment", "reroute": editor annotations (./annotations). */
  type: "block" | "subgraph" | "comment" | "reroute";
  position: { x: number; y: number };
  data: NodeData;
  selected?: boolean;
  width?: number;
  height?: number;
  zIndex?: number;
  measured?: { width?: number; height?: number };
}

export interface FlowEdge {
  id: string;
  source: string;
  sourceHandle: string;
  target: string;
  targetHandle: string;
  data?: { type: PortType };
}
