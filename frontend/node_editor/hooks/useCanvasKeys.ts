// Keys over the canvas (never while typing in a field): Tab, Shift+A or a tap of Space open the
// quick-add search at the pointer; Ctrl/Cmd+A selects every block.
import { useEffect, useRef, type RefObject } from "react";

const TYPING = ["INPUT", "TEXTAREA", "SELECT"];
/** A Space held longer than this (ms), or with a drag (a pan), is not a tap. */
const TAP_MS = 300;

export function useCanvasKeys(canvas: RefObject<HTMLElement | null>, { quickAdd, selectAll, busy }: {
  quickAdd: (clientX: number, clientY: number) => void; selectAll: () => void; busy: boolean;
}) {
  const pointer = useRef({ x: 0, y: 0, inside: false, dragged: false });
  const space = useRef<number | null>(null);
  useEffect(() => {
    const el = canvas.current;
    if (!el) return;
    const move = (e: PointerEvent) => {
      const r = el.getBoundingClientRect();
      const inside = e.clientX >= r.left && e.clientX <= r.right && e.clientY >= r.top && e.clientY <= r.bottom;
      pointer.current = { x: e.clientX, y: e.clientY, inside, dragged: pointer.current.dragged || e.buttons !== 0 };
    };
    window.addEventListener("pointermove", move, true);
    return () => window.removeEventListener("pointermove", move, true);
  }, [canvas]);
  useEffect(() => {
    const typing = (e: KeyboardEvent) => {
      const t = e.target as HTMLElement | null;
      return !!t && (TYPING.includes(t.tagName) || t.isContentEditable);
    };
    const down = (e: KeyboardEvent) => {
      if (busy || typing(e)) return;
      const mod = e.ctrlKey || e.metaKey;
      const p = pointer.current;
      if (mod && !e.shiftKey && !e.altKey && e.key.toLowerCase() === "a") { e.preventDefault(); selectAll(); return; }
      if (mod || e.altKey || !p.inside) return;
      if (e.key === "Tab" && !e.shiftKey) { e.preventDefault(); quickAdd(p.x, p.y); }
      else if (e.key === "A" && e.shiftKey) { e.preventDefault(); quickAdd(p.x, p.y); }
      else if (e.key === " " && !e.repeat) { space.current = performance.now(); p.dragged = false; }
    };
    const up = (e: KeyboardEvent) => {
      if (e.key !== " " || space.current === null) return;
      const held = performance.now() - space.current;
      space.current = null;
      const p = pointer.current;
      if (busy || typing(e) || !p.inside || p.dragged || held > TAP_MS) return;
      e.preventDefault();
      quickAdd(p.x, p.y);
    };
    window.addEventListener("keydown", down);
    window.addEventListener("keyup", up);
    return () => { window.removeEventListener("keydown", down); window.removeEventListener("keyup", up); };
  }, [busy, quickAdd, selectAll]);
}
