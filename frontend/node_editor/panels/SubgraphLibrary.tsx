// The palette's "Subgraphs" group: the robot library's subgraphs (GET /api/subgraphs). Drag one onto the
// canvas, double-click it or press its + to add it to the program: its definition is copied into the
// program's subgraphs.
import { useReactFlow } from "@xyflow/react";
import { useEffect, useState } from "react";
import { api } from "../api";
import { DRAG_SUBGRAPH } from "../layout/constants";
import { useActions, useEditor } from "../store/EditorStore";
import type { SubgraphDef } from "../subgraphs";
import { visibleSpot } from "../viewport";
import { SUBGRAPHS_CHANGED } from "./SubgraphBar";

type Item = { name: string; definition: SubgraphDef };


/** The library's subgraphs with their definitions (one that cannot be read is left out). */
async function librarySubgraphs(): Promise<Item[]> {
  const names = await api.subgraphs();
  const defs = await Promise.all(names.map((n) => api.getSubgraph(n).catch(() => null)));
  return names.flatMap((name, i) => (defs[i] ? [{ name, definition: defs[i] as unknown as SubgraphDef }] : []));
}

export function SubgraphLibrary() {
  const { state, dispatch } = useEditor();
  const { say } = useActions();
  const flow = useReactFlow();
  const [items, setItems] = useState<Item[]>([]);

  // listed on opening and again whenever a subgraph is saved to the library
  useEffect(() => {
    const refresh = () => {
      librarySubgraphs().then(setItems).catch((e) => say(`cannot list the library's subgraphs: ${e}`));
    };
    refresh();
    window.addEventListener(SUBGRAPHS_CHANGED, refresh);
    return () => window.removeEventListener(SUBGRAPHS_CHANGED, refresh);
  }, [say]);

  const add = (name: string, definition: SubgraphDef) => dispatch({
    type: "subgraphInserted", name, definition,
    position: visibleSpot(flow, state.history.present.nodes),  // a free spot in view, clear of the canvas's overlays
  });

  return (
    <div className="palette subgraph-library" data-testid="subgraph-library">
      <div className="group">
        <div className="group-title" style={{ borderColor: "#c9a227" }}>Subgraphs</div>
        {!items.length && <div className="muted small">Group blocks (Ctrl+G) and save them to the library to reuse them here.</div>}
        {items.map(({ name, definition }) => (
          <div key={name} className="palette-item" data-testid={`palette-subgraph-${name}`} onDoubleClick={() => add(name, definition)} draggable
               onDragStart={(ev) => { ev.dataTransfer.setData(DRAG_SUBGRAPH, JSON.stringify({ name, definition })); ev.dataTransfer.effectAllowed = "move"; }}
               title={`${definition.nodes?.length ?? 0} blocks; inputs: ${(definition.inputs ?? []).map((p) => p.name).join(", ") || "none"}; outputs: ${(definition.outputs ?? []).map((p) => p.name).join(", ") || "none"}`}>
            <span className="dot" style={{ background: "#c9a227" }} />
            <span className="name">▣ {name} <button className="add-subgraph" data-testid={`add-subgraph-${name}`} onClick={() => add(name, definition)}>+</button></span>
            <span className="summary">{definition.description || `${definition.nodes?.length ?? 0} blocks`}</span>
          </div>
        ))}
      </div>
    </div>
  );
}
