// Keyboard shortcuts that work anywhere but in a text field (the table: ../shortcuts): undo/redo,
// copy/paste, save, go live, fit, frame the selection, the find-block box and the shortcut list.
import { useReactFlow } from "@xyflow/react";
import { useEffect } from "react";
import { frameNodes } from "../framing";
import { shortcutOf } from "../shortcuts";
import { useEditor, type EditorActions } from "../store/EditorStore";

const TYPING = ["INPUT", "TEXTAREA", "SELECT"];

export function useShortcuts({ copy, paste, save, fitView, goLive }: Pick<EditorActions, "copy" | "paste" | "save" | "fitView" | "goLive">): void {
  const { state, dispatch } = useEditor();
  const flow = useReactFlow();
  const overlay = state.overlay;
  useEffect(() => {
    const onKey = (e: KeyboardEvent) => {
      const target = e.target as HTMLElement | null;
      if (target && (TYPING.includes(target.tagName) || target.isContentEditable)) return;
      const id = shortcutOf(e, "anywhere");
      if (!id || id === "selectAll") return;  // Ctrl+A is the canvas's (../hooks/useCanvasKeys)
      if (id !== "copy" && id !== "paste") e.preventDefault();
      switch (id) {
        case "undo": return dispatch({ type: "undo" });
        case "redo": return dispatch({ type: "redo" });
        case "copy": return copy();
        case "paste": return paste();
        case "save": return save();
        case "goLive": return void goLive();
        case "fit": return fitView();
        case "frameSelected": return frameNodes(flow, flow.getNodes().filter((n) => n.selected).map((n) => n.id));
        case "find": return dispatch({ type: "overlayShown", overlay: "find" });
        case "help": return dispatch({ type: "overlayShown", overlay: overlay === "help" ? null : "help" });
      }
    };
    window.addEventListener("keydown", onKey);
    return () => window.removeEventListener("keydown", onKey);
  }, [dispatch, copy, paste, save, fitView, goLive, flow, overlay]);
}
