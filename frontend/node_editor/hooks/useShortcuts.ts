// Keyboard shortcuts (not while typing in a field): undo/redo, copy/paste, save, go live, fit the view.
import { useEffect } from "react";
import { useEditor, type EditorActions } from "../store/EditorStore";

const TYPING = ["INPUT", "TEXTAREA", "SELECT"];

export function useShortcuts({ copy, paste, save, fitView, goLive }: Pick<EditorActions, "copy" | "paste" | "save" | "fitView" | "goLive">): void {
  const { dispatch } = useEditor();
  useEffect(() => {
    const onKey = (e: KeyboardEvent) => {
      const target = e.target as HTMLElement | null;
      if (target && TYPING.includes(target.tagName)) return;
      const mod = e.ctrlKey || e.metaKey;
      const key = e.key.toLowerCase();
      if (mod && key === "z") { e.preventDefault(); dispatch({ type: e.shiftKey ? "redo" : "undo" }); }
      else if (mod && key === "y") { e.preventDefault(); dispatch({ type: "redo" }); }
      else if (mod && key === "c") copy();
      else if (mod && key === "v") paste();
      else if (mod && key === "s") { e.preventDefault(); save(); }
      else if (mod && e.key === "Enter") { e.preventDefault(); goLive(); }
      else if (e.key === "f" && !mod) fitView();
    };
    window.addEventListener("keydown", onKey);
    return () => window.removeEventListener("keydown", onKey);
  }, [dispatch, copy, paste, save, fitView, goLive]);
}
