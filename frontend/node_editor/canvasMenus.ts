// Extra entries of the canvas's context menus, registered by other parts of the editor (e.g. a probe
// on a wire): push `{ label, run }` here at module load; the menus list them after their own entries.
import type { FlowEdge, FlowNode } from "./graph";

export interface MenuExtra<T> {
  label: string;
  /** Whether to offer it for this element (default: always). */
  when?: (target: T) => boolean;
  run: (target: T) => void;
}

/** Entries of the menu of a wire (right-click on an edge). */
export const wireMenuExtras: MenuExtra<FlowEdge>[] = [];
/** Entries of the menu of a block (right-click on a node). */
export const nodeMenuExtras: MenuExtra<FlowNode>[] = [];
