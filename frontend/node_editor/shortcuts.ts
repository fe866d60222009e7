// Every keyboard shortcut of the editor, in one table: the handlers (hooks/useShortcuts,
// hooks/useCanvasKeys) look keys up here and the overlay (ShortcutHelp, "?") lists it, so the help
// cannot drift from what the keys do. Keys React Flow handles itself are listed with `by: "canvas"`.
// Pure (tested with vitest).

/** Where a shortcut works: anywhere but a text field, or only with the pointer over the canvas. */
export type Scope = "anywhere" | "canvas";

export type ShortcutId =
  | "undo" | "redo" | "copy" | "paste" | "save" | "goLive" | "fit" | "selectAll" | "quickAdd" | "delete" | "boxSelect"
  | "bypass" | "rename" | "duplicate" | "find" | "frameSelected" | "help";

export interface Shortcut {
  id: ShortcutId;
  /** Alternatives, each as `Mod+Shift+Z` (Mod: Ctrl, or Cmd on a Mac); single characters match the key typed. */
  keys: string[];
  what: string;
  scope: Scope;
  /** Who handles it: the editor's hooks (default) or React Flow itself (only listed here). */
  by?: "editor" | "canvas";
}

export const SHORTCUTS: Shortcut[] = [
  { id: "quickAdd", keys: ["Tab", "Shift+A", "Space"], what: "add a block at the pointer (a tap of Space)", scope: "canvas" },
  { id: "duplicate", keys: ["Shift+D"], what: "duplicate the selection at the pointer", scope: "canvas" },
  { id: "bypass", keys: ["M"], what: "bypass the selected blocks (their frame passes through)", scope: "canvas" },
  { id: "rename", keys: ["F2"], what: "rename the selected block", scope: "canvas" },
  { id: "delete", keys: ["Delete", "Backspace"], what: "delete the selection", scope: "canvas", by: "canvas" },
  { id: "boxSelect", keys: ["Shift+Click"], what: "add to the selection (drag on empty canvas: box select)", scope: "canvas", by: "canvas" },
  { id: "selectAll", keys: ["Mod+A"], what: "select every block", scope: "anywhere" },
  { id: "fit", keys: ["F"], what: "fit the whole program (with a selection: frame it)", scope: "anywhere" },
  { id: "frameSelected", keys: ["."], what: "frame the selected blocks", scope: "anywhere" },
  { id: "find", keys: ["Mod+F"], what: "find a block by name or type", scope: "anywhere" },
  { id: "undo", keys: ["Mod+Z"], what: "undo", scope: "anywhere" },
  { id: "redo", keys: ["Mod+Shift+Z", "Mod+Y"], what: "redo", scope: "anywhere" },
  { id: "copy", keys: ["Mod+C"], what: "copy the selection", scope: "anywhere" },
  { id: "paste", keys: ["Mod+V"], what: "paste", scope: "anywhere" },
  { id: "save", keys: ["Mod+S"], what: "save to the robot's library", scope: "anywhere" },
  { id: "goLive", keys: ["Mod+Enter"], what: "go live: swap the draft into the robot", scope: "anywhere" },
  { id: "help", keys: ["?"], what: "show or hide this list", scope: "anywhere" },
];

const NAMED: Record<string, string> = { space: " ", delete: "Delete", backspace: "Backspace", tab: "Tab", enter: "Enter", f2: "F2", escape: "Escape" };

type KeyLike = Pick<KeyboardEvent, "key" | "ctrlKey" | "metaKey" | "shiftKey" | "altKey">;

/** Whether a key event is the combination `spec` (e.g. `Mod+Shift+Z`). A single punctuation character
 * (`?`, `.`) matches whatever Shift it takes to type it. */
export function matches(spec: string, e: KeyLike): boolean {
  const parts = spec.split("+");
  const key = parts.pop()!;
  const mods = new Set(parts.map((p) => p.toLowerCase()));
  if ((e.ctrlKey || e.metaKey) !== mods.has("mod") || e.altKey !== mods.has("alt")) return false;
  const named = NAMED[key.toLowerCase()];
  if (named) return e.key === named && e.shiftKey === mods.has("shift");
  if (/^[a-z0-9]$/i.test(key)) return e.key.toLowerCase() === key.toLowerCase() && e.shiftKey === mods.has("shift");
  return e.key === key;
}

/** The editor-handled shortcut of `scope` a key event is, or null. */
export function shortcutOf(e: KeyLike, scope: Scope): ShortcutId | null {
  const hit = SHORTCUTS.find((s) => s.scope === scope && s.by !== "canvas" && s.keys.some((k) => matches(k, e)));
  return hit?.id ?? null;
}

/** How a key combination reads on this platform (Mod as Ctrl or ⌘). */
export function keyLabel(spec: string, mac = /Mac|iPhone|iPad/.test(globalThis.navigator?.platform ?? "")): string {
  return spec.replace(/^Mod\b/, mac ? "⌘" : "Ctrl");
}
