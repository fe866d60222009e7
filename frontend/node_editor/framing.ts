// Framing part of the graph on the canvas: the selected blocks ("."), a block found by name (Ctrl+F).
import type { ReactFlowInstance } from "@xyflow/react";
import { MAX_FIT_ZOOM, READABLE_ZOOM } from "./viewport";

/** Room around the framed blocks, as a fraction of the view. */
const FRAME_PADDING = 0.2;
const FRAME_MS = 200;

/** Frame the blocks `ids` (all of them when none is given), never below a zoom their names read at. */
export function frameNodes(flow: ReactFlowInstance, ids: string[], duration = FRAME_MS): void {
  const nodes = ids.length ? ids.map((id) => ({ id })) : undefined;
  void flow.fitView({ nodes, padding: FRAME_PADDING, minZoom: READABLE_ZOOM, maxZoom: MAX_FIT_ZOOM, duration });
}
