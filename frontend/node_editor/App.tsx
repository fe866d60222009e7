// The Nutty editor: the running Animation Program as a live node graph, side by side with the Pre-Viz.
// State lives in the store (./store), effects in the hooks (./hooks), views in the panels (./panels).
import { ReactFlowProvider, useReactFlow } from "@xyflow/react";
import "@xyflow/react/dist/style.css";
import { useCallback, useMemo, type ReactNode } from "react";
import { api } from "./api";
import { CatalogContext, LiveContext, SamplesContext } from "./context";
import { useBootstrap } from "./hooks/useBootstrap";
import { useClipboard } from "./hooks/useClipboard";
import { useControlSocket } from "./hooks/useControlSocket";
import { useLibrary } from "./hooks/useLibrary";
import { useNotices } from "./hooks/useNotices";
import { useProgramSync } from "./hooks/useProgramSync";
import { useShortcuts } from "./hooks/useShortcuts";
import { useSignals, useTelemetry } from "./hooks/useTelemetry";
import { withWatched } from "./live/logic";
import { emptyLive } from "./telemetry";
import { useWatchedSignals } from "./live/WireProbes";
import { Layout } from "./Layout";
import { liveInside, signalsInside } from "./organise/liveInside";
import { ActionsContext, EditorStoreProvider, useActions, useEditor, type EditorActions } from "./store/EditorStore";
import type { Graph, Position } from "./store/state";
import type { FlowNode, SubgraphDef } from "./graph";
import { subgraphAliases, withAliasedSignals, withAliasedValues } from "./live/subgraphLive";
import { fitReadable, sizeOf, visibleSpot } from "./viewport";

const NO_NODES: FlowNode[] = [];

/** Telemetry for its children, apart from the store: only what shows live values re-renders with it. */
function Telemetry({ children }: { children: ReactNode }) {
  const { history, meta, live: isLive } = useEditor().state;
  const { sendCommand } = useActions();
  const path = meta?.inside?.path;  // an open subgraph: its blocks run as `<path>/<id>`
  // a draft's nodes are not running: only the live graph subscribes to values
  const nodes = isLive ? history.present.nodes : NO_NODES;
  const signals = useSignals(nodes);
  const watched = useWatchedSignals(history.present.edges);  // hovered and probed wires first
  // a subgraph node's outputs are inner ports the engine runs under flat ids
  const defs = (meta?.subgraphs ?? meta?.inside?.outerMeta.subgraphs) as Record<string, SubgraphDef> | undefined;
  // computed when the graph changes, not on each telemetry message; compared by value, so moving a
  // block does not resubscribe
  const aliasKey = useMemo(() => JSON.stringify(subgraphAliases(nodes, defs)), [nodes, defs]);
  const aliases = useMemo(() => JSON.parse(aliasKey) as ReturnType<typeof subgraphAliases>, [aliasKey]);
  // a draft subscribes to nothing either: its probes' ids may be the running program's too
  const wanted = useMemo(() => isLive ? signalsInside(withAliasedSignals(withWatched(signals, watched), aliases), path) : [],
    [signals, watched, aliases, path, isLive]);
  const { live, samples } = useTelemetry(wanted);
  const value = useMemo(() => ({
    // a draft is not running: the running program's values, sparklines, cook times, layers and safety
    // net are not its own, even where its blocks' ids are the same
    ...(isLive ? withAliasedValues(liveInside(live, path), aliases) : { ...emptyLive, t: live.t }), setLayer: (mixer: string, layer: string, active: boolean) =>
      sendCommand({ type: "set_layer", mixer: path ? `${path}/${mixer}` : mixer, layer, active }),
  }), [live, isLive, path, aliases, sendCommand]);
  return (
    <LiveContext.Provider value={value}>
      <SamplesContext.Provider value={samples}>{children}</SamplesContext.Provider>
    </LiveContext.Provider>
  );
}

function Editor() {
  const flow = useReactFlow();
  const { state, dispatch } = useEditor();
  const { say, log } = useNotices();
  useBootstrap(say);
  const { editParams, goLive } = useProgramSync(say);
  const detach = useCallback(() => dispatch({ type: "draftStarted" }), [dispatch]);
  const sendCommand = useControlSocket(log);
  const library = useLibrary(say);
  const nodes = state.history.present.nodes;
  // pasted at the pointer (over the canvas) or a free spot in view
  const place = useCallback((clip: Graph) => visibleSpot(flow, nodes, sizeOf(clip.nodes)), [flow, nodes]);
  const { copy, paste } = useClipboard(place);

  const fitView = useCallback(() => fitReadable(flow), [flow]);
  // without a position (a palette click, a quick-add): at the pointer over the canvas, else a free spot in view
  const addBlock = useCallback((type: string, position?: Position) => dispatch({
    type: "blockAdded", blockType: type, position: position ?? visibleSpot(flow, nodes),
  }), [flow, dispatch, nodes]);
  const setInput = useCallback((name: string, value: unknown) => {
    dispatch({ type: "inputSet", name, value });
    api.setInput(name, value).catch((e) => log(`error ${e}`));
  }, [dispatch, log]);
  const setGhost = useCallback((visible: boolean) => {
    api.ghost(visible).then(() => dispatch({ type: "ghostShown", visible })).catch((e) => say(String(e)));
  }, [dispatch, say]);

  const actions: EditorActions = useMemo(() => ({
    say, log, sendCommand, editParams, goLive, detach, setInput, setGhost, addBlock, copy, paste, fitView, ...library,
  }), [say, log, sendCommand, editParams, goLive, detach, setInput, setGhost, addBlock, copy, paste, fitView, library]);
  useShortcuts(actions);

  return (
    <ActionsContext.Provider value={actions}>
      <CatalogContext.Provider value={state.catalog}>
        <Telemetry><Layout /></Telemetry>
      </CatalogContext.Provider>
    </ActionsContext.Provider>
  );
}

export function App() {
  return (
    <ReactFlowProvider>
      <EditorStoreProvider>
        <Editor />
      </EditorStoreProvider>
    </ReactFlowProvider>
  );
}
