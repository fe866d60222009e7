// The Nutty editor: the running Animation Program as a live node graph, side by side with the Pre-Viz.
// State lives in the store (./store), effects in the hooks (./hooks), views in the panels (./panels).
import { ReactFlowProvider, useReactFlow } from "@xyflow/react";
import "@xyflow/react/dist/style.css";
import { useCallback, useMemo, type ReactNode } from "react";
import { api } from "./api";
import { CatalogContext, LiveContext, SamplesContext } from "./context";
import { FIT_VIEW } from "./GraphView";
import { useBootstrap } from "./hooks/useBootstrap";
import { useClipboard } from "./hooks/useClipboard";
import { useControlSocket } from "./hooks/useControlSocket";
import { useLibrary } from "./hooks/useLibrary";
import { useNotices } from "./hooks/useNotices";
import { useProgramSync } from "./hooks/useProgramSync";
import { useShortcuts } from "./hooks/useShortcuts";
import { useSignals, useTelemetry } from "./hooks/useTelemetry";
import { withWatched } from "./live/logic";
import { useWatchedSignals } from "./live/WireProbes";
import { Layout } from "./Layout";
import { ActionsContext, EditorStoreProvider, useActions, useEditor, type EditorActions } from "./store/EditorStore";
import type { Position } from "./store/state";

/** Telemetry for its children, apart from the store: only what shows live values re-renders with it. */
function Telemetry({ children }: { children: ReactNode }) {
  const { nodes, edges } = useEditor().state.history.present;
  const { sendCommand } = useActions();
  const { live, samples } = useTelemetry(withWatched(useSignals(nodes), useWatchedSignals(edges)));
  const value = useMemo(() => ({
    ...live, setLayer: (mixer: string, layer: string, active: boolean) => sendCommand({ type: "set_layer", mixer, layer, active }),
  }), [live, sendCommand]);
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
  const editParams = useProgramSync(say);
  const sendCommand = useControlSocket(log);
  const library = useLibrary(say);
  const { copy, paste } = useClipboard();

  const fitView = useCallback(() => { flow.fitView(FIT_VIEW); }, [flow]);
  const addBlock = useCallback((type: string, position?: Position) => dispatch({
    type: "blockAdded", blockType: type,
    position: position ?? flow.screenToFlowPosition({ x: window.innerWidth * 0.4, y: window.innerHeight * 0.3 }),
  }), [flow, dispatch]);
  const setInput = useCallback((name: string, value: unknown) => {
    dispatch({ type: "inputSet", name, value });
    api.setInput(name, value).catch((e) => log(`error ${e}`));
  }, [dispatch, log]);
  const setGhost = useCallback((visible: boolean) => {
    api.ghost(visible).then(() => dispatch({ type: "ghostShown", visible })).catch((e) => say(String(e)));
  }, [dispatch, say]);

  const actions: EditorActions = useMemo(() => ({
    say, log, sendCommand, editParams, setInput, setGhost, addBlock, copy, paste, fitView, ...library,
  }), [say, log, sendCommand, editParams, setInput, setGhost, addBlock, copy, paste, fitView, library]);
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
