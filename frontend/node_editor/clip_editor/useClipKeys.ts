// The clip editor's keys while it shows: undo/redo, save and play/pause. Listened for on the document
// (after the views' own React handlers, before the program editor's window listeners), and the
// program's shortcuts stop here so Ctrl+Z or Ctrl+V never reach the hidden program graph.
import { useEffect } from "react";
import { shortcutOf } from "../shortcuts";
import { useLatest } from "./useLatest";

const TYPING = ["INPUT", "TEXTAREA", "SELECT"];

export interface ClipKeys {
  undo: () => void;
  redo: () => void;
  save: () => void;
  togglePlay: () => void;
}

/** What a key does in the clip editor, or null (pure, tested). */
export function clipKeyOf(e: Pick<KeyboardEvent, "key" | "ctrlKey" | "metaKey" | "shiftKey" | "altKey">): keyof ClipKeys | null {
  const mod = e.ctrlKey || e.metaKey;
  const key = e.key.toLowerCase();
  if (mod && key === "z") return e.shiftKey ? "redo" : "undo";
  if (mod && key === "y") return "redo";
  if (mod && key === "s") return "save";
  if (!mod && !e.altKey && e.key === " ") return "togglePlay";
  return null;
}

export function useClipKeys(active: boolean, keys: ClipKeys): void {
  const latest = useLatest(keys);
  useEffect(() => {
    if (!active) return;
    const onKey = (e: KeyboardEvent) => {
      const target = e.target as HTMLElement | null;
      const typing = !!target && (TYPING.includes(target.tagName) || target.isContentEditable);
      const what = clipKeyOf(e);
      // in a text field only Ctrl+S is ours (the field keeps its own undo and its spaces)
      if (what && (!typing || what === "save")) {
        e.preventDefault();
        e.stopPropagation();
        latest.current[what]();
        return;
      }
      if (shortcutOf(e, "anywhere")) e.stopPropagation();  // the program editor's: not while a clip shows
    };
    document.addEventListener("keydown", onKey);
    return () => document.removeEventListener("keydown", onKey);
  }, [active, latest]);
}
