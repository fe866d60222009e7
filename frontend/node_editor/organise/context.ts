// What the canvas's own node and edge types need from the editor (opening a subgraph, editing a
// comment), without reaching into the store from inside React Flow's memoised components.
import { createContext } from "react";

export interface Organise {
  openSubgraph: (node: string) => void;
  editComment: (node: string, params: Record<string, unknown>) => void;
}

export const OrganiseContext = createContext<Organise>({ openSubgraph: () => {}, editComment: () => {} });
