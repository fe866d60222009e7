// The palette's "Subgraphs" group: the robot library's subgraphs (GET /api/subgraphs). Double-click
// one (or its +) to add it to the program: its definition is copied into the program's subgraphs.
import { useReactFlow } from "@xyflow/react";
import { useCallback, useEffect, useState } from "react";
import { api } from "../api";
import { useActions, useEditor } from "../store/EditorStore";
import type { SubgraphDef } from "../subgraphs";
import { SUBGRAPHS_CHANGED } from "./SubgraphBar";

export function SubgraphLibrary() {
  const { dispatch } = useEditor();
  const { say } = useActions();
  const flow = useReactFlow();
  const [items, setItems] = useState<{ name: string; definition: SubgraphDef }[]>([]);

  const refresh = useCallback(async () => {
    try {
      const names = await api.subgraphs();
      const defs = await Promise.all(names.map((n) => api.getSubgraph(n).catch(() => null)));
      setItems(names.flatMap((name, i) => (defs[i] ? [{ name, definition: defs[i] as unknown as SubgraphDef }] : [])));
    } catch (e) {
      say(`cannot list the library's subgraphs: ${e}`);
    }
  }, [say]);

  useEffect(() => {
    refresh();
    window.addEventListener(SUBGRAPHS_CHANGED, refresh);
    return () => window.removeEventListener(SUBGRAPHS_CHANGED, refresh);
  }, [refresh]);

  const add = (name: string, definition: SubgraphDef) => dispatch({
    type: "subgraphInserted", name, definition,
    position: flow.screenToFlowPosition({ x: window.innerWidth * 0.4, y: window.innerHeight * 0.3 }),
  });

  return (
    <div className="palette subgraph-library" data-testid="subgraph-library">
      <div className="group">
        <div className="group-title" style={{ borderColor: "#c9a227" }}>Subgraphs</div>
        {!items.length && <div className="muted small">Group blocks (Ctrl+G) and save them to the library to reuse them here.</div>}
        {items.map(({ name, definition }) => (
          <div key={name} className="palette-item" data-testid={`palette-subgraph-${name}`} onDoubleClick={() => add(name, definition)}
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
