// A context menu at the pointer: a list of entries, closed by a pick, Escape or a click elsewhere.
import { useEffect, useLayoutEffect, useRef, useState } from "react";
import { MENU_EDGE_MARGIN } from "./layout/constants";

export interface MenuEntry {
  label: string;
  hint?: string;
  disabled?: boolean;
  run: () => void;
}

export function ContextMenu({ x, y, title, entries, onClose }: {
  x: number; y: number; title?: string; entries: MenuEntry[]; onClose: () => void;
}) {
  const ref = useRef<HTMLDivElement>(null);
  useEffect(() => {
    const away = (e: PointerEvent) => { if (!ref.current?.contains(e.target as Node)) onClose(); };
    const key = (e: KeyboardEvent) => { if (e.key === "Escape") { e.stopPropagation(); onClose(); } };
    window.addEventListener("pointerdown", away, true);
    window.addEventListener("keydown", key, true);
    ref.current?.querySelector<HTMLButtonElement>("button:not(:disabled)")?.focus();
    return () => { window.removeEventListener("pointerdown", away, true); window.removeEventListener("keydown", key, true); };
  }, [onClose]);
  // at the pointer, or left of / above it when the canvas has no room
  const [place, setPlace] = useState({ left: x, top: y });
  useLayoutEffect(() => {
    const el = ref.current, parent = el?.parentElement;
    if (!el || !parent) return;
    const m = MENU_EDGE_MARGIN;
    const left = Math.max(m, x + el.offsetWidth + m <= parent.clientWidth ? x : x - el.offsetWidth);
    const top = Math.max(m, y + el.offsetHeight + m <= parent.clientHeight ? y : y - el.offsetHeight);
    setPlace({ left, top });
  }, [x, y]);
  return (
    <div ref={ref} className="canvas-menu" role="menu" data-testid="context-menu" style={place}
         onContextMenu={(e) => e.preventDefault()}>
      {title && <div className="canvas-menu-title">{title}</div>}
      {entries.map((e) => (
        <button key={e.label} role="menuitem" disabled={e.disabled} onClick={() => { onClose(); e.run(); }}>
          <span>{e.label}</span>{e.hint && <kbd>{e.hint}</kbd>}
        </button>
      ))}
    </div>
  );
}
