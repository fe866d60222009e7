// The block palette: grouped by category, searchable; drag onto the graph or double-click to add.
import { useContext, useMemo, useState } from "react";
import { CatalogContext } from "./context";
import { CATEGORY_COLOURS } from "./BlockNode";
import { CATEGORY_ORDER } from "./graph";

const TITLES: Record<string, string> = {
  sources: "Sources", operators: "Operators", layers: "Layers", stage2: "Stage 2", signals: "Signals", output: "Output",
};

export function Palette({ onAdd }: { onAdd: (type: string) => void }) {
  const catalog = useContext(CatalogContext);
  const [query, setQuery] = useState("");
  const groups = useMemo(() => {
    const q = query.trim().toLowerCase();
    const out: Record<string, { type: string; title: string; summary: string; doc: string }[]> = {};
    for (const e of Object.values(catalog)) {
      if (q && !`${e.type} ${e.title} ${e.summary}`.toLowerCase().includes(q)) continue;
      (out[e.category] ??= []).push(e);
    }
    return CATEGORY_ORDER.filter((c) => out[c]?.length).map((c) => [c, out[c].sort((a, b) => a.title.localeCompare(b.title))] as const);
  }, [catalog, query]);
  return (
    <div className="palette" data-testid="palette">
      <input className="search" placeholder="Search blocks…" value={query} onChange={(e) => setQuery(e.target.value)} aria-label="search blocks" />
      {groups.map(([cat, items]) => (
        <div key={cat} className="group">
          <div className="group-title" style={{ borderColor: CATEGORY_COLOURS[cat] }}>{TITLES[cat] ?? cat}</div>
          {items.map((e) => (
            <div key={e.type} className="palette-item" draggable data-testid={`palette-${e.type}`} title={e.doc}
                 onDragStart={(ev) => { ev.dataTransfer.setData("application/nutty-block", e.type); ev.dataTransfer.effectAllowed = "move"; }}
                 onDoubleClick={() => onAdd(e.type)}>
              <span className="dot" style={{ background: CATEGORY_COLOURS[cat] }} />
              <span className="name">{e.title}</span>
              <span className="summary">{e.summary}</span>
            </div>
          ))}
        </div>
      ))}
    </div>
  );
}
