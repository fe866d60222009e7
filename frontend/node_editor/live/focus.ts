// Selecting a node and bringing it into view (the warning count and "driven by" jump there).
import { useReactFlow } from "@xyflow/react";
import { useCallback } from "react";
import { useEditor } from "../store/EditorStore";
import { MAX_FIT_ZOOM } from "../viewport";

/** Room around the focused node, as a share of the view. */
const FOCUS_PADDING = 0.25;

export function useFocusNode(): (id: string) => void {
  const flow = useReactFlow();
  const { state, dispatch } = useEditor();
  const nodes = state.history.present.nodes;
  return useCallback((id: string) => {
    if (!nodes.some((n) => n.id === id)) return;
    dispatch({
      type: "nodesChanged",
      changes: nodes.filter((n) => n.id === id || n.selected).map((n) => ({ type: "select" as const, id: n.id, selected: n.id === id })),
    });
    flow.fitView({ nodes: [{ id }], padding: FOCUS_PADDING, maxZoom: MAX_FIT_ZOOM });
  }, [nodes, dispatch, flow]);
}
