// The block palette: grouped by category (the backend's order and titles), searchable; drag onto the
// graph or double-click to add.
import { useMemo, useState } from "react";
import type { BlockEntry } from "../api";
import { CATEGORY_COLOURS } from "../BlockNode";
import { DRAG_BLOCK } from "../layout/constants";
import { CATEGORIES } from "../ports";
import { useActions, useEditor } from "../store/EditorStore";

export function Palette() {
  const { catalog } = useEditor().state;
  const { addBlock } = useActions();
  const [query, setQuery] = useState("");
  const groups = useMemo(() => {
    const q = query.trim().toLowerCase();
    const out: Record<string, BlockEntry[]> = {};
    for (const e of Object.values(catalog)) {
      if (q && !`${e.type} ${e.title} ${e.summary}`.toLowerCase().includes(q)) continue;
      (out[e.category] ??= []).push(e);
    }
    return CATEGORIES.filter((c) => out[c.name]?.length)
      .map((c) => [c, out[c.name].sort((a, b) => a.title.localeCompare(b.title))] as const);
  }, [catalog, query]);
  return (
    <div className="palette" data-testid="palette">
      <input className="search" placeholder="Search blocks…" value={query} onChange={(e) => setQuery(e.target.value)} aria-label="search blocks" />
      {groups.map(([cat, items]) => (
        <div key={cat.name} className="group">
          <div className="group-title" style={{ borderColor: CATEGORY_COLOURS[cat.name] }}>{cat.title}</div>
          {items.map((e) => (
            <div key={e.type} className="palette-item" draggable data-testid={`palette-${e.type}`} title={e.doc}
                 onDragStart={(ev) => { ev.dataTransfer.setData(DRAG_BLOCK, e.type); ev.dataTransfer.effectAllowed = "move"; }}
                 onDoubleClick={() => addBlock(e.type)}>
              <span className="dot" style={{ background: CATEGORY_COLOURS[cat.name] }} />
              <span className="name">{e.title}</span>
              <span className="summary">{e.summary}</span>
            </div>
          ))}
        </div>
      ))}
    </div>
  );
}
