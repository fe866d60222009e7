// The keyboard commands the dopesheet and graph editor share (delete, insert, copy/paste, select all or
// none, frame all) and the Blender-style modal grab/scale: keys follow the pointer as transient edits
// until a click or Enter commits one undo step, or Esc/right-click puts the document back.
import { useCallback, useRef, useState } from "react";
import type { KeyboardEvent as ReactKeyboardEvent, PointerEvent as ReactPointerEvent } from "react";
import { clipboard, copyKeys, pasteKeys } from "../model/clipboard";
import { deleteKeys, insertKeys } from "../model/edits";
import type { Clip, DofInfo, Edited, KeyRef } from "../model/types";

export type Commit = { label: string } | null;
export type OnChange = (next: Edited, commit: Commit) => void;

/** The letter a key press names; with Alt held the physical key (Alt+A types "å" on a Mac). */
export function letterOf(e: { key: string; code: string; altKey: boolean }): string {
  if (e.altKey && e.code.startsWith("Key")) return e.code.slice(3).toLowerCase();
  return e.key.length === 1 ? e.key.toLowerCase() : e.key;
}

export interface KeyContext {
  doc: Clip;
  selection: KeyRef[];
  setSelection: (sel: KeyRef[]) => void;
  onChange: OnChange;
  playhead: number;
  /** DoFs I/K inserts keys for (DofInfo gives a new track the right rest value) */
  insertDofs: (string | DofInfo)[];
  /** DoFs a one-track clipboard pastes into */
  pasteTargets: string[];
  /** the robot's DoFs, when known: paste skips DoFs it lacks and values of the wrong kind */
  robotDofs?: readonly DofInfo[];
  /** every key the view shows (A selects them) */
  allKeys: () => KeyRef[];
  frame: () => void;
}

/** Run the shared command a key press names; true when it was one (the caller then preventDefaults). */
export function keyCommand(e: ReactKeyboardEvent | KeyboardEvent, c: KeyContext): boolean {
  const k = letterOf(e);
  const ctrl = e.ctrlKey || e.metaKey;
  if ((k === "x" && !ctrl) || k === "Delete") {
    if (c.selection.length) c.onChange(deleteKeys(c.doc, c.selection), { label: "Delete keys" });
    return true;
  }
  if ((k === "i" || k === "k") && !ctrl && !e.altKey) {
    if (c.insertDofs.length) c.onChange(insertKeys(c.doc, c.insertDofs, c.playhead), { label: "Insert keys" });
    return true;
  }
  if (k === "c" && ctrl) {
    if (c.selection.length) clipboard.set(copyKeys(c.doc, c.selection));
    return true;
  }
  if (k === "v" && ctrl) {
    const cb = clipboard.get();
    if (!cb) return true;
    const one = Object.keys(cb.tracks).length === 1;
    const targets = one && c.pasteTargets.length ? c.pasteTargets : undefined;
    c.onChange(pasteKeys(c.doc, cb, c.playhead, targets, c.robotDofs ? { dofs: c.robotDofs } : {}), { label: "Paste keys" });
    return true;
  }
  if (k === "a" && !ctrl) {
    c.setSelection(e.altKey ? [] : c.allKeys());
    return true;
  }
  if (k === "Home") {
    c.frame();
    return true;
  }
  return false;
}

export type ModalKind = "grab" | "scale";

export interface ModalStart {
  kind: ModalKind;
  /** pointer position (px, in the view's own coordinates) when the mode began */
  x0: number;
  y0: number;
  doc: Clip;
  sel: KeyRef[];
}

interface ModalState extends ModalStart {
  last: Edited | null;
}

export interface Mods {
  altKey: boolean;
  ctrlKey: boolean;
  metaKey: boolean;
}

/** What the mode does for a pointer at (x, y): the edit from the start document, and the hint line. */
export type ModalCompute = (m: ModalStart, x: number, y: number, mods: Mods) => { edited: Edited; hint: string };

const TAIL = " — click to confirm, Esc to cancel";

/** A modal grab/scale. `hint` is the line to show while active (null otherwise). */
export function useModal(onChange: OnChange, compute: ModalCompute) {
  const state = useRef<ModalState | null>(null);
  const [hint, setHint] = useState<string | null>(null);
  const start = useCallback((m: ModalStart) => {
    state.current = { ...m, last: null };
    setHint(`${m.kind === "grab" ? "Grab" : "Scale"}: move the pointer${TAIL}`);
  }, []);
  const move = useCallback(
    (x: number, y: number, mods: Mods) => {
      const m = state.current;
      if (!m) return;
      const r = compute(m, x, y, mods);
      m.last = r.edited;
      onChange(r.edited, null);
      setHint(r.hint + TAIL);
    },
    [compute, onChange],
  );
  const confirm = useCallback(() => {
    const m = state.current;
    if (!m) return;
    state.current = null;
    setHint(null);
    if (m.last) onChange(m.last, { label: m.kind === "grab" ? "Move keys" : "Scale keys" });
  }, [onChange]);
  const cancel = useCallback(() => {
    const m = state.current;
    if (!m) return;
    state.current = null;
    setHint(null);
    if (m.last) onChange({ doc: m.doc, selection: m.sel }, null);
  }, [onChange]);
  const active = useCallback(() => state.current !== null, []);
  // the view's pointer: where G or S starts from, and what moves, confirms or cancels the mode
  const pointer = useRef({ x: 0, y: 0 });
  const onPointerMove = useCallback((e: ReactPointerEvent) => {
    pointer.current = { x: e.clientX, y: e.clientY };
    if (state.current) move(e.clientX, e.clientY, e);
  }, [move]);
  const onPointerDownCapture = useCallback((e: ReactPointerEvent) => {
    if (!state.current) return;
    e.stopPropagation();
    e.preventDefault();
    if (e.button === 2) cancel();
    else confirm();
  }, [cancel, confirm]);
  return { hint, start, move, confirm, cancel, active, pointer, onPointerMove, onPointerDownCapture };
}

/** Handle the keys a modal listens to (Enter confirms, Esc cancels); true when consumed. */
export function modalKey(e: { key: string }, modal: { active: () => boolean; confirm: () => void; cancel: () => void }): boolean {
  if (!modal.active()) return false;
  if (e.key === "Enter") modal.confirm();
  else if (e.key === "Escape") modal.cancel();
  return true;
}
