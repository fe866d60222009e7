// The store: the reducer's state and dispatch in one context, and the editor's actions (made by the
// hooks in ../hooks) in another, so panels and views reach both without props.
import { createContext, useContext, useReducer, type Dispatch, type ReactNode } from "react";
import type { Command } from "../api";
import { initialState, reducer, type Action, type EditorState, type Position } from "./state";

interface Store {
  state: EditorState;
  dispatch: Dispatch<Action>;
}

const StoreContext = createContext<Store | null>(null);

export function EditorStoreProvider({ children, initial = initialState }: { children: ReactNode; initial?: EditorState }) {
  const [state, dispatch] = useReducer(reducer, initial);
  return <StoreContext.Provider value={{ state, dispatch }}>{children}</StoreContext.Provider>;
}

export function useEditor(): Store {
  const store = useContext(StoreContext);
  if (!store) throw new Error("useEditor() outside <EditorStoreProvider>");
  return store;
}

/** What panels and views can do beyond dispatching: calls to the server, dialogs, the viewport. */
export interface EditorActions {
  say: (message: string) => void;
  log: (line: string) => void;
  sendCommand: (command: Command) => void;
  /** New parameters of a node; `live` for a drag's steps (its end is not): one drag is one undo step. */
  editParams: (node: string, params: Record<string, unknown>, live?: boolean) => void;
  /** Swap the draft into the robot (false when the server refuses it). */
  goLive: () => Promise<boolean>;
  /** Keep editing the running program as a draft: edits no longer reach the robot. */
  detach: () => void;
  setInput: (name: string, value: unknown) => void;
  setGhost: (visible: boolean) => void;
  addBlock: (type: string, position?: Position) => void;
  copy: () => void;
  paste: () => void;
  fitView: () => void;
  save: (asName?: string) => void;
  saveAs: () => void;
  open: (name: string) => void;
  /** Back to the program the robot runs (discarding the draft). */
  openRunning: () => void;
  newProgram: () => void;
  importJson: (file: File) => void;
  exportJson: () => void;
}

export const ActionsContext = createContext<EditorActions | null>(null);

export function useActions(): EditorActions {
  const actions = useContext(ActionsContext);
  if (!actions) throw new Error("useActions() outside <ActionsContext.Provider>");
  return actions;
}
