// The quick-add search at the pointer: blocks that fit what it was opened for (a dragged port, a wire,
// or anything), filtered as one types; arrows + Enter or a click picks, Escape closes.
import { useEffect, useLayoutEffect, useMemo, useRef, useState } from "react";
import { CATEGORY_COLOURS } from "./BlockNode";
import { MENU_EDGE_MARGIN } from "./layout/constants";
import { CATEGORIES } from "./ports";
import { matching, offers, type Offer, type QuickAddMode } from "./quickAdd";
import { useEditor } from "./store/EditorStore";

const TITLES: Record<string, string> = Object.fromEntries(CATEGORIES.map((c) => [c.name, c.title]));

function heading(mode: QuickAddMode): string {
  if (mode.kind === "any") return "Add block";
  if (mode.kind === "insert") return "Insert on wire";
  return mode.port.side === "source" ? `Feed ${mode.port.node}.${mode.port.handle} into…` : `Feed ${mode.port.node}.${mode.port.handle} from…`;
}

export function QuickAdd({ x, y, mode, onPick, onClose }: {
  x: number; y: number; mode: QuickAddMode; onPick: (offer: Offer) => void; onClose: () => void;
}) {
  const { state } = useEditor();
  const graph = state.history.present;
  const [query, setQuery] = useState("");
  const [active, setActive] = useState(0);
  const box = useRef<HTMLDivElement>(null);
  const list = useRef<HTMLDivElement>(null);
  // offers are fixed when the search opens (the graph may change under it with live edits)
  const all = useMemo(() => offers(state.catalog, graph.nodes, graph.edges, mode), [mode]);  // eslint-disable-line react-hooks/exhaustive-deps -- fixed when the search opens, see above
  const shown = useMemo(() => matching(all, query), [all, query]);
  // a new query starts again from its first match
  const search = (text: string) => { setQuery(text); setActive(0); };
  useEffect(() => {
    const away = (e: PointerEvent) => { if (!box.current?.contains(e.target as Node)) onClose(); };
    window.addEventListener("pointerdown", away, true);
    return () => window.removeEventListener("pointerdown", away, true);
  }, [onClose]);
  useEffect(() => {
    list.current?.querySelector(".qa-item.active")?.scrollIntoView({ block: "nearest" });
  }, [active, shown]);

  const onKey = (e: React.KeyboardEvent) => {
    if (e.key === "ArrowDown") { e.preventDefault(); setActive((a) => Math.min(shown.length - 1, a + 1)); }
    else if (e.key === "ArrowUp") { e.preventDefault(); setActive((a) => Math.max(0, a - 1)); }
    else if (e.key === "Enter") { e.preventDefault(); if (shown[active]) onPick(shown[active]); }
    else if (e.key === "Escape" || e.key === "Tab") { e.preventDefault(); onClose(); }
    e.stopPropagation();
  };

  // at the pointer, moved to stay inside the canvas (measured once rendered)
  const [place, setPlace] = useState({ left: x, top: y });
  useLayoutEffect(() => {
    const el = box.current, parent = el?.parentElement;
    if (!el || !parent) return;
    // right of and below the pointer, or left of / above it when there is no room
    const m = MENU_EDGE_MARGIN;
    const left = Math.max(m, x + el.offsetWidth + m <= parent.clientWidth ? x : Math.min(x - el.offsetWidth, parent.clientWidth - el.offsetWidth - m));
    const top = Math.max(m, y + el.offsetHeight + m <= parent.clientHeight ? y : Math.min(y - el.offsetHeight, parent.clientHeight - el.offsetHeight - m));
    setPlace((p) => (p.left === left && p.top === top ? p : { left, top }));
  }, [x, y, shown.length]);
  const { left, top } = place;
  return (
    <div ref={box} className="quick-add" data-testid="quick-add" style={{ left, top }} onContextMenu={(e) => e.preventDefault()}>
      <div className="qa-head">{heading(mode)}</div>
      <input autoFocus className="qa-search" placeholder="Search blocks…" aria-label="quick add search" value={query}
             onChange={(e) => search(e.target.value)} onKeyDown={onKey} />
      <div className="qa-list" ref={list} role="listbox">
        {shown.length === 0 && <div className="qa-empty">{all.length ? "no block matches" : "no block fits here"}</div>}
        {shown.map((o, i) => {
          // a category's title above its first block (none while searching)
          const previous = i > 0 ? shown[i - 1].entry.category : "";
          const head = !query && o.entry.category !== previous ? TITLES[o.entry.category] ?? o.entry.category : null;
          return (
            <div key={o.type}>
              {head && <div className="qa-group">{head}</div>}
              <div className={`qa-item ${i === active ? "active" : ""}`} role="option" aria-selected={i === active}
                   data-testid={`qa-${o.type}`} onMouseEnter={() => setActive(i)} onClick={() => onPick(o)}>
                <span className="dot" style={{ background: CATEGORY_COLOURS[o.entry.category] }} />
                <span className="name">{o.entry.title}</span>
                {(o.input || o.output) && <span className="qa-port">{mode.kind === "insert" ? `${o.input} → ${o.output}` : o.input ?? o.output}</span>}
                <span className="summary">{o.entry.summary}</span>
              </div>
            </div>
          );
        })}
      </div>
    </div>
  );
}
