// Which clip the clip editor has open (shown in the graph's area, with a tab back to the program) and
// a pending request to open another or close it, which the clip editor grants once nothing unsaved is
// lost (it asks first when its clip is dirty). Pure; the reducer (./state) delegates these cases here.
import type { ClipTab, EditorState } from "./types";

export type { ClipRequest, ClipTab, OpenClip } from "./types";

export type ClipAction =
  /** Open a clip (from the library, a clip_player block or a deep link), or a new one by name. */
  | { type: "clipRequested"; name: string; fresh?: boolean }
  | { type: "clipCloseRequested" }
  /** The clip editor granted the pending request (or closes itself). */
  | { type: "clipRequestGranted" }
  | { type: "clipRequestDropped" }
  | { type: "clipTabShown"; tab: ClipTab }
  /** The open clip was saved: the library has it now (its address can name it). */
  | { type: "clipSaved" };

const open = (state: EditorState, name: string, fresh: boolean): EditorState => ({
  ...state, clip: { name, fresh, seq: (state.clip?.seq ?? 0) + 1 }, clipTab: "clip", clipRequest: null,
});

export function clipReducer(state: EditorState, action: ClipAction): EditorState {
  switch (action.type) {
    case "clipRequested":
      // nothing open: nothing to lose
      if (!state.clip) return open(state, action.name, !!action.fresh);
      return { ...state, clipTab: "clip", clipRequest: { kind: "open", name: action.name, fresh: !!action.fresh } };
    case "clipCloseRequested":
      return state.clip ? { ...state, clipTab: "clip", clipRequest: { kind: "close" } } : state;
    case "clipRequestGranted": {
      const r = state.clipRequest;
      if (r?.kind === "open") return open(state, r.name, r.fresh);
      return { ...state, clip: null, clipTab: "program", clipRequest: null };
    }
    case "clipRequestDropped":
      return { ...state, clipRequest: null };
    case "clipSaved":
      return state.clip?.fresh ? { ...state, clip: { ...state.clip, fresh: false } } : state;
    case "clipTabShown":
      if (action.tab === "behaviour" && !state.behaviour) return { ...state, clipTab: "behaviours" };
      return { ...state, clipTab: action.tab === "clip" && !state.clip ? "library" : action.tab };
  }
}
