// The find-block box (Ctrl+F): type part of a block's name or type; arrows + Enter or a click selects
// the block and frames it; Escape (or a click elsewhere) closes.
import { useReactFlow } from "@xyflow/react";
import { useEffect, useMemo, useRef, useState } from "react";
import { findBlocks } from "./findBlock";
import { frameNodes } from "./framing";
import { useEditor } from "./store/EditorStore";

/** At most this many matches are listed. */
const MAX_SHOWN = 14;

export function FindBlock() {
  const { state, dispatch } = useEditor();
  const flow = useReactFlow();
  const [query, setQuery] = useState("");
  const [active, setActive] = useState(0);
  const box = useRef<HTMLDivElement>(null);
  const nodes = state.history.present.nodes;
  const shown = useMemo(() => findBlocks(nodes, state.catalog, query).slice(0, MAX_SHOWN), [nodes, state.catalog, query]);
  const close = () => dispatch({ type: "overlayShown", overlay: null });
  useEffect(() => {
    const away = (e: PointerEvent) => {
      if (!box.current?.contains(e.target as Node)) dispatch({ type: "overlayShown", overlay: null });
    };
    window.addEventListener("pointerdown", away, true);
    return () => window.removeEventListener("pointerdown", away, true);
  }, [dispatch]);

  const pick = (id: string) => {
    dispatch({ type: "selectedOnly", nodes: [id] });
    close();
    frameNodes(flow, [id]);
  };
  const onKey = (e: React.KeyboardEvent) => {
    e.stopPropagation();
    if (e.key === "ArrowDown") { e.preventDefault(); setActive((a) => Math.min(shown.length - 1, a + 1)); }
    else if (e.key === "ArrowUp") { e.preventDefault(); setActive((a) => Math.max(0, a - 1)); }
    else if (e.key === "Enter") { e.preventDefault(); if (shown[active]) pick(shown[active].id); }
    else if (e.key === "Escape") { e.preventDefault(); close(); }
  };
  return (
    <div ref={box} className="find-block quick-add" data-testid="find-block" role="dialog" aria-label="find a block">
      <div className="qa-head">Find block</div>
      <input autoFocus className="qa-search" placeholder="name or type…" aria-label="find block" value={query}
             onChange={(e) => { setQuery(e.target.value); setActive(0); }} onKeyDown={onKey} />
      <div className="qa-list" role="listbox">
        {shown.length === 0 && <div className="qa-empty">no block matches</div>}
        {shown.map((f, i) => (
          <div key={f.id} className={`qa-item ${i === active ? "active" : ""}`} role="option" aria-selected={i === active}
               data-testid={`find-${f.id}`} onMouseEnter={() => setActive(i)} onClick={() => pick(f.id)}>
            <span />
            <span className="name">{f.id}</span>
            <span className="summary">{f.title}</span>
          </div>
        ))}
      </div>
    </div>
  );
}
