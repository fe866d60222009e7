// Asking for the Save-as dialog from anywhere (the toolbar, Ctrl+S on a program never saved): the
// dialog (./SaveAsDialog) reads the request; the file is saved by whoever it calls back.
import { useSyncExternalStore } from "react";

/** What is saved: the program (the default), or another kind of library file with its own list and
 * save (a subgraph definition: the subgraph bar). */
export interface SaveAsTarget {
  what: string;
  existing: string[];
  save: (file: string) => void;
}

export interface SaveAsRequest { name: string; target?: SaveAsTarget }

/** The request the dialog opens with, or null while it is closed. */
let suggested: SaveAsRequest | null = null;
const listeners = new Set<() => void>();
const notify = () => listeners.forEach((l) => l());

export function requestSaveAs(name: string, target?: SaveAsTarget): void {
  suggested = { name, target };
  notify();
}

export function closeSaveAs(): void {
  suggested = null;
  notify();
}

export function useSaveAsRequest(): SaveAsRequest | null {
  return useSyncExternalStore((l) => { listeners.add(l); return () => listeners.delete(l); }, () => suggested);
}
