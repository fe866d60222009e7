// The canvas's hooks for subgraphs and annotations: open a subgraph node, edit a comment, add a
// reroute point where a wire is double-clicked.
import { useReactFlow } from "@xyflow/react";
import { useCallback, useMemo } from "react";
import { useEditor } from "../store/EditorStore";
import type { Organise } from "./context";

export function useOrganise() {
  const { dispatch } = useEditor();
  const flow = useReactFlow();
  const openSubgraph = useCallback((node: string) => dispatch({ type: "subgraphOpened", node }), [dispatch]);
  // a comment is no block: its title and colour are an edit of the graph (synced with the program's ui),
  // never a live parameter change of the server
  const editComment = useCallback((node: string, params: Record<string, unknown>) =>
    dispatch({ type: "paramsEdited", node, params, at: performance.now() }), [dispatch]);
  const context: Organise = useMemo(() => ({ openSubgraph, editComment }), [openSubgraph, editComment]);
  const onEdgeDoubleClick = useCallback((event: React.MouseEvent, edge: { id: string }) => {
    event.stopPropagation();
    dispatch({ type: "rerouteAdded", edge: edge.id, position: flow.screenToFlowPosition({ x: event.clientX, y: event.clientY }) });
  }, [dispatch, flow]);
  const onNodeDoubleClick = useCallback((_: React.MouseEvent, node: { id: string; type?: string }) => {
    if (node.type === "subgraph") openSubgraph(node.id);
  }, [openSubgraph]);
  return { context, onEdgeDoubleClick, onNodeDoubleClick };
}
