// The editor state's shape (what store/state.ts's reducer keeps). Types only, apart from the reducer so
// that the modules it delegates to (../subgraphs) can name them without importing it.
import type { Catalog, ExposedInput, PrevizInfo, RobotDescription, ValidationReport } from "../api";
import type { FlowEdge, FlowNode, Meta } from "../graph";
import type { History } from "../history";

export type Graph = { nodes: FlowNode[]; edges: FlowEdge[] };
export type Connection = { source: string; sourceHandle: string; target: string; targetHandle: string };
export type Position = { x: number; y: number };

export interface EditorState {
  catalog: Catalog;
  robot: RobotDescription | null;
  previz: PrevizInfo | null;
  meta: Meta | null;
  history: History<Graph>;
  report: ValidationReport | null;
  syncing: boolean;
  dirty: boolean;
  /** Name of the program in the robot's library that the graph was opened from or saved as. */
  libName: string | null;
  library: string[];
  clips: string[];
  inputs: { decls: ExposedInput[]; values: Record<string, unknown> };
  toast: string | null;
  consoleLines: string[];
  /** Counts loaded programs (the graph view fits each one into view); `fromServer`: the running one;
   * `view`: the same program seen from another level (a subgraph opened or closed), so what the server
   * has is unchanged. */
  loaded: { count: number; fromServer: boolean; view?: boolean };
  /** The last parameter edit: edits of one node in quick succession are one undo step. */
  lastParamEdit: { node: string; at: number } | null;
  /** Live: the graph is the robot's running program and edits reach it. Draft: edits are only validated
   * until "Go live" swaps the graph in (New, Open and Import open drafts). */
  live: boolean;
  /** Name of the program the robot runs (shown while a draft is edited). */
  runningName: string | null;
  /** The command overlay shown over the editor: the find-block box (Ctrl+F) or the shortcut list (?). */
  overlay: "find" | "help" | null;
  /** The clip open in the clip editor (./clipState), the tab the graph's area shows, and a pending
   * open or close the clip editor has yet to grant. */
  clip: OpenClip | null;
  clipTab: ClipTab;
  clipRequest: ClipRequest | null;
  /** The behaviour open in the behaviour editor and a pending open or close it has yet to grant
   * (./behaviourState; the same shapes as the clip's). */
  behaviour: OpenClip | null;
  behaviourRequest: ClipRequest | null;
}

/** The clip the clip editor has open (./clipState). */
export interface OpenClip {
  name: string;
  /** A new clip not yet saved to the library. */
  fresh: boolean;
  /** Counts opens, so opening the same clip again reloads it. */
  seq: number;
}

export type ClipRequest = { kind: "open"; name: string; fresh: boolean } | { kind: "close" };

/** What the graph's area shows: the program, the clip library, the open clip, the behaviour library or
 * the open behaviour. */
export type ClipTab = "program" | "library" | "clip" | "behaviours" | "behaviour";
