// Copy the selected blocks (and the edges between them); paste them with fresh ids.
import { useCallback, useRef } from "react";
import { useEditor } from "../store/EditorStore";
import type { Graph } from "../store/state";

export function useClipboard() {
  const { state, dispatch } = useEditor();
  const graph = state.history.present;
  const clip = useRef<Graph | null>(null);
  const copy = useCallback(() => {
    const nodes = graph.nodes.filter((n) => n.selected);
    const ids = new Set(nodes.map((n) => n.id));
    clip.current = { nodes, edges: graph.edges.filter((e) => ids.has(e.source) && ids.has(e.target)) };
  }, [graph]);
  const paste = useCallback(() => { if (clip.current) dispatch({ type: "pasted", clip: clip.current }); }, [dispatch]);
  return { copy, paste };
}
