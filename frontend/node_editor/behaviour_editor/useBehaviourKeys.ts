// The behaviour editor's keys while it shows: undo/redo, save and preview (Space) as the clip editor's
// (../clip_editor/useClipKeys, which also keeps the program's shortcuts away), plus Delete / Backspace
// for the selected item outside text fields.
import { useEffect } from "react";
import { useClipKeys } from "../clip_editor/useClipKeys";
import { useLatest } from "../clip_editor/useLatest";

const TYPING = ["INPUT", "TEXTAREA", "SELECT"];

export function useBehaviourKeys(active: boolean, keys: { undo: () => void; redo: () => void; save: () => void; togglePreview: () => void; deleteItem: () => void }): void {
  useClipKeys(active, { undo: keys.undo, redo: keys.redo, save: keys.save, togglePlay: keys.togglePreview });
  const latest = useLatest(keys);
  useEffect(() => {
    if (!active) return;
    const onKey = (e: KeyboardEvent) => {
      const target = e.target as HTMLElement | null;
      if (target && (TYPING.includes(target.tagName) || target.isContentEditable)) return;
      if (e.key !== "Delete" && e.key !== "Backspace") return;
      e.preventDefault();
      // the program graph (hidden) must not delete its selection too
      e.stopImmediatePropagation();
      latest.current.deleteItem();
    };
    document.addEventListener("keydown", onKey, true);
    return () => document.removeEventListener("keydown", onKey, true);
  }, [active, latest]);
}
