// Copy the selected blocks (and the edges between them); paste them with fresh ids, where `place` says
// (the pointer or a free spot in view) or beside their originals.
import { useCallback, useRef } from "react";
import { useEditor } from "../store/EditorStore";
import type { Graph, Position } from "../store/state";

export function useClipboard(place?: (clip: Graph) => Position) {
  const { state, dispatch } = useEditor();
  const graph = state.history.present;
  const clip = useRef<Graph | null>(null);
  const copy = useCallback(() => {
    const nodes = graph.nodes.filter((n) => n.selected);
    const ids = new Set(nodes.map((n) => n.id));
    clip.current = { nodes, edges: graph.edges.filter((e) => ids.has(e.source) && ids.has(e.target)) };
  }, [graph]);
  const paste = useCallback(() => {
    if (clip.current) dispatch({ type: "pasted", clip: clip.current, at: place?.(clip.current) });
  }, [dispatch, place]);
  return { copy, paste };
}
