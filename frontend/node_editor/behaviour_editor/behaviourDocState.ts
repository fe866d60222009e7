// The open behaviour's working copy as one pure reducer: undo history of whole documents (every edit,
// a drag's release included, is one step), and what was last loaded or saved (the dirty mark). Tested.
import * as H from "../history";
import { docKey } from "../clip_editor/clipDocState";
import type { BehaviourDoc } from "./model/types";

export interface BehaviourSnapshot {
  doc: BehaviourDoc;
  /** the edit that made it ("" for a load), shown as "Undo <label>" */
  label: string;
}

export interface BehaviourDocState {
  name: string;
  history: H.History<BehaviourSnapshot>;
  saved: BehaviourDoc;
  /** false for a new behaviour until its first save */
  onServer: boolean;
}

export type BehaviourDocAction =
  | { type: "loaded"; name: string; doc: BehaviourDoc; fresh?: boolean }
  /** `merge`: part of the previous edit (a drag's move to another lane after its retime): no new step */
  | { type: "edited"; doc: BehaviourDoc; label: string; merge?: boolean }
  | { type: "undo" }
  | { type: "redo" }
  /** `sent`: the working copy the save started from; `doc`: what was PUT, under `name`. */
  | { type: "saved"; name: string; sent: BehaviourDoc; doc: BehaviourDoc };

export function initBehaviourDoc(name: string, doc: BehaviourDoc, fresh = false): BehaviourDocState {
  return { name, history: H.init({ doc, label: "" }), saved: doc, onServer: !fresh };
}

export function behaviourDocReducer(state: BehaviourDocState, action: BehaviourDocAction): BehaviourDocState {
  switch (action.type) {
    case "loaded":
      return initBehaviourDoc(action.name, action.doc, action.fresh);
    case "edited":
      // an edit that changed nothing (a refused retime returns the same document) is no step
      if (action.doc === state.history.present.doc) return state;
      if (action.merge && state.history.past.length) return { ...state, history: H.replace(state.history, { doc: action.doc, label: action.label }) };
      return { ...state, history: H.push(state.history, { doc: action.doc, label: action.label }, (a, b) => a.doc === b.doc) };
    case "undo":
      return { ...state, history: H.undo(state.history) };
    case "redo":
      return { ...state, history: H.redo(state.history) };
    case "saved": {
      const unedited = state.history.present.doc === action.sent;
      return {
        ...state, name: action.name, saved: action.doc, onServer: true,
        history: unedited ? H.replace(state.history, { ...state.history.present, doc: action.doc }) : state.history,
      };
    }
  }
}

/** Whether the working copy differs from what was last loaded or saved. */
export function isDirty(state: BehaviourDocState): boolean {
  const present = state.history.present.doc;
  return present !== state.saved && docKey(present) !== docKey(state.saved);
}

/** A new behaviour's document: one body and one voice track, nothing on them. */
export function newBehaviour(robot: string | null): BehaviourDoc {
  return {
    format: "nutty-behaviour/1", robot, description: "", params: {},
    tracks: [{ name: "body", items: [] }, { name: "voice", items: [] }],
  };
}

/** The document to PUT: the working copy with the format and name set. */
export function documentToSave(doc: BehaviourDoc, name: string, robot: string | null): BehaviourDoc {
  return { ...doc, format: "nutty-behaviour/1", name, robot: doc.robot || robot };
}
