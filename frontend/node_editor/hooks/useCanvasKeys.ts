// Keys over the canvas (never while typing in a field; the table: ../shortcuts): Tab, Shift+A or a tap
// of Space open the quick-add search at the pointer; Ctrl/Cmd+A selects every block; M bypasses the
// selected blocks; Shift+D duplicates them at the pointer; F2 renames the selected block.
import { useReactFlow } from "@xyflow/react";
import { useEffect, useRef, type RefObject } from "react";
import { AT_POINTER } from "../layout/constants";
import { shortcutOf } from "../shortcuts";
import { useEditor } from "../store/EditorStore";

const TYPING = ["INPUT", "TEXTAREA", "SELECT"];
/** A Space held longer than this (ms), or with a drag (a pan), is not a tap. */
const TAP_MS = 300;

export function useCanvasKeys(canvas: RefObject<HTMLElement | null>, { quickAdd, selectAll, busy, rename }: {
  quickAdd: (clientX: number, clientY: number) => void; selectAll: () => void; busy: boolean;
  /** F2 on a selected block (the canvas's in-place rename), when the canvas has one. */
  rename?: () => void;
}) {
  const { dispatch } = useEditor();
  const flow = useReactFlow();
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
      const p = pointer.current;
      if (shortcutOf(e, "anywhere") === "selectAll") { e.preventDefault(); selectAll(); return; }
      const id = p.inside ? shortcutOf(e, "canvas") : null;
      if (!id) return;
      if (id === "quickAdd" && e.key === " ") {  // a tap, told apart from a held Space (a pan) on its release
        if (!e.repeat) { space.current = performance.now(); p.dragged = false; }
        return;
      }
      if (id === "rename" && !rename) return;
      e.preventDefault();
      if (id === "quickAdd") quickAdd(p.x, p.y);
      else if (id === "bypass") dispatch({ type: "bypassToggled" });
      else if (id === "duplicate") {
        const at = flow.screenToFlowPosition({ x: p.x, y: p.y });
        dispatch({ type: "duplicated", at: { x: at.x + AT_POINTER.x, y: at.y + AT_POINTER.y } });
      }
      else if (id === "rename") rename?.();
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
  }, [busy, quickAdd, selectAll, rename, dispatch, flow]);
}
