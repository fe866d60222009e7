// Which behaviour the behaviour editor has open (a tab "Behaviour: <name>" beside the behaviour library)
// and a pending request to open another or close it, granted by the editor once nothing unsaved is lost.
// Pure; the reducer (./state) delegates these cases here. Mirrors ./clipState.
import type { EditorState } from "./types";

export type BehaviourAction =
  /** Open a behaviour (from the library or a deep link), or a new one (`fresh`: not in the library yet). */
  | { type: "behaviourRequested"; name: string; fresh?: boolean }
  | { type: "behaviourCloseRequested" }
  /** The behaviour editor granted the pending request (or closes itself). */
  | { type: "behaviourRequestGranted" }
  | { type: "behaviourRequestDropped" }
  /** The open behaviour was saved as `name` (a new one gets its name when first saved). */
  | { type: "behaviourSaved"; name: string };

const open = (state: EditorState, name: string, fresh: boolean): EditorState => ({
  ...state, behaviour: { name, fresh, seq: (state.behaviour?.seq ?? 0) + 1 }, clipTab: "behaviour", behaviourRequest: null,
});

export function behaviourReducer(state: EditorState, action: BehaviourAction): EditorState {
  switch (action.type) {
    case "behaviourRequested":
      if (!state.behaviour) return open(state, action.name, !!action.fresh);
      return { ...state, clipTab: "behaviour", behaviourRequest: { kind: "open", name: action.name, fresh: !!action.fresh } };
    case "behaviourCloseRequested":
      return state.behaviour ? { ...state, clipTab: "behaviour", behaviourRequest: { kind: "close" } } : state;
    case "behaviourRequestGranted": {
      const r = state.behaviourRequest;
      if (r?.kind === "open") return open(state, r.name, r.fresh);
      return { ...state, behaviour: null, clipTab: "behaviours", behaviourRequest: null };
    }
    case "behaviourRequestDropped":
      return { ...state, behaviourRequest: null };
    case "behaviourSaved":
      // same seq: the editor keeps its working copy (only the name and freshness change)
      return state.behaviour ? { ...state, behaviour: { ...state.behaviour, name: action.name, fresh: false } } : state;
  }
}
