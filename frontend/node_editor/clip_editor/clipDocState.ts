// The open clip's document as one pure reducer: undo history over (document, selection) snapshots, the
// views' transient edit protocol (drag steps replace the present; the commit pushes ONE step from the
// pre-drag document), the selection, and what was last saved (for the dirty mark). Tested with vitest.
import * as H from "../history";
import { clipEnd } from "./model/markers";
import type { Clip, Edited, KeyRef } from "./model/types";

export interface Snapshot {
  doc: Clip;
  selection: KeyRef[];
  /** The edit that produced this snapshot ("" for a load): shown as "Undo <label>". */
  label: string;
}

export interface ClipDocState {
  name: string;
  history: H.History<Snapshot>;
  /** The document as last loaded or saved: the working copy is dirty when it differs. */
  saved: Clip;
  /** Whether the server has this clip (false for a new clip until its first save). */
  onServer: boolean;
  /** The present before a drag's first transient step; null when no drag is under way. */
  dragBase: Snapshot | null;
}

export type ClipDocAction =
  | { type: "loaded"; name: string; doc: Clip; fresh?: boolean }
  | { type: "changed"; next: Edited; commit: { label: string } | null }
  | { type: "selected"; selection: KeyRef[] }
  | { type: "undo" }
  | { type: "redo" }
  /** `sent`: the working document the save started from; `doc`: what was PUT (its required fields set). */
  | { type: "saved"; sent: Clip; doc: Clip };

export function initClipDoc(name: string, doc: Clip, fresh = false): ClipDocState {
  return { name, history: H.init({ doc, selection: [], label: "" }), saved: doc, onServer: !fresh, dragBase: null };
}

const sameSnapshot = (a: Snapshot, b: Snapshot) => a.doc === b.doc;

export function clipDocReducer(state: ClipDocState, action: ClipDocAction): ClipDocState {
  switch (action.type) {
    case "loaded":
      return initClipDoc(action.name, action.doc, action.fresh);
    case "changed": {
      const next: Snapshot = { doc: action.next.doc, selection: action.next.selection, label: action.commit?.label ?? "" };
      if (!action.commit) {
        // a drag's step: shown, not recorded; the first one remembers where the drag started
        return { ...state, dragBase: state.dragBase ?? state.history.present, history: H.replace(state.history, next) };
      }
      const base = state.dragBase ?? state.history.present;
      if (next.doc === base.doc) {
        // a drag that came back to where it started (or an edit that changed nothing): no step
        return { ...state, dragBase: null, history: H.replace(state.history, { ...base, selection: next.selection }) };
      }
      return { ...state, dragBase: null, history: H.push({ ...state.history, present: base }, next, sameSnapshot) };
    }
    case "selected":
      return { ...state, history: H.replace(state.history, { ...state.history.present, selection: action.selection }) };
    case "undo": {
      // an undo in the middle of a drag drops the drag first (back to its start), then undoes
      const h = state.dragBase ? { ...state.history, present: state.dragBase } : state.history;
      return { ...state, dragBase: null, history: H.undo(h) };
    }
    case "redo":
      if (state.dragBase) return state;
      return { ...state, history: H.redo(state.history) };
    case "saved":
      // unedited since: the working copy becomes what was PUT (the same curves), so it is clean
      if (state.history.present.doc === action.sent && !state.dragBase)
        return { ...state, saved: action.doc, onServer: true, history: H.replace(state.history, { ...state.history.present, doc: action.doc }) };
      return { ...state, saved: action.doc, onServer: true };
  }
}

/** A document's content as text, object keys sorted (a save may write the same fields in another
 * order) and unset (undefined) fields left out, as JSON leaves them out. */
export function docKey(doc: unknown): string {
  return JSON.stringify(doc, (_k, v: unknown) => (v && typeof v === "object" && !Array.isArray(v)
    ? Object.fromEntries(Object.entries(v as Record<string, unknown>).sort(([a], [b]) => (a < b ? -1 : a > b ? 1 : 0)))
    : v));
}

/** Whether the working document differs from the one last loaded or saved (a new clip nobody has
 * edited yet is not dirty: closing it loses nothing). */
export function isDirty(state: ClipDocState): boolean {
  const present = state.history.present.doc;
  return present !== state.saved && docKey(present) !== docKey(state.saved);
}

/** The document to PUT: the working copy with the fields the format requires set. */
export function documentToSave(doc: Clip, name: string, robot: string | null, fallbackFps: number): Clip {
  const out: Clip = { ...doc, format: "nutty-clip/1", name, robot: doc.robot || robot, fps: doc.fps ?? fallbackFps };
  // a clip ends at its last key unless it says otherwise: an anchor or event after the last key
  // (keys moved or deleted from under it) keeps the clip long enough to hold it, rather than a refusal
  const marks = [...Object.values(doc.anchors ?? {}), ...(doc.events ?? []).map((e) => e.t)];
  const latest = Math.max(0, ...marks);
  if (doc.duration == null && latest > clipEnd(doc)) out.duration = latest;
  return out;
}
