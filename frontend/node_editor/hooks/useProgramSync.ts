// Keeps the server's running program in step with the graph: every structural edit is validated and
// hot-swapped (PUT, shortly after the last edit), a parameter drag is applied live (PATCH, nothing
// rebuilt), and the server's validation report comes back into the store.
import { useCallback, useEffect, useRef } from "react";
import { api, ApiError } from "../api";
import { flowToProgram } from "../graph";
import { useEditor } from "../store/EditorStore";
import { structureKey, withParams } from "../store/state";
import { refreshInputs } from "./useBootstrap";

/** Edits closer together than this (ms) go to the server as one program. */
const SYNC_DELAY_MS = 90;
/** After a live parameter patch, the report is asked for again once edits pause this long (ms). */
const REVALIDATE_MS = 300;

export function useProgramSync(say: (message: string) => void) {
  const { state, dispatch } = useEditor();
  const { history, meta, catalog, report, loaded } = state;
  const graph = history.present;
  const synced = useRef("");  // structure key of what the server runs (or has judged)
  const revalidate = useRef<number | undefined>(undefined);

  useEffect(() => {
    if (loaded.fromServer) synced.current = structureKey(graph, meta);
    // only when a program arrives: the graph and meta are the loaded ones then
  }, [loaded]);

  useEffect(() => {
    if (!meta) return;
    const key = structureKey(graph, meta);
    if (key === synced.current) return;
    const timer = window.setTimeout(async () => {
      dispatch({ type: "syncing", on: true });
      try {
        const res = await api.putProgram(flowToProgram(graph.nodes, graph.edges, meta));
        synced.current = key;
        dispatch({ type: "reportReceived", report: res.report });
        refreshInputs(dispatch);
      } catch (e) {
        // the report now describes this graph (the robot keeps the last valid program)
        if (e instanceof ApiError && e.detail?.report) {
          synced.current = key;
          dispatch({ type: "reportReceived", report: e.detail.report });
        } else say(String(e));
      } finally {
        dispatch({ type: "syncing", on: false });
      }
    }, SYNC_DELAY_MS);
    return () => window.clearTimeout(timer);
  }, [graph, meta, dispatch, say]);

  /** Change a node's parameters; `live` (a slider drag) patches the running program when its ports stay. */
  return useCallback(async (id: string, params: Record<string, unknown>, live: boolean) => {
    const next = withParams(graph, catalog, id, params);
    if (!next) return;
    dispatch({ type: "paramsEdited", node: id, params, at: performance.now() });
    if (!live || next.structural || !report?.valid) return;
    // The patch brings the server to this graph: no hot swap for it (set now, before the sync effect runs).
    synced.current = structureKey(next.graph, meta);
    try {
      await api.patchParams(id, next.params);  // applied at the next tick, nothing rebuilt
      // the patch answers no report: judge the patched graph once the drag pauses (its warnings, e.g. a
      // layer's weight dragged to 0, show on the graph)
      window.clearTimeout(revalidate.current);
      const program = flowToProgram(next.graph.nodes, next.graph.edges, meta ?? ({} as any));
      revalidate.current = window.setTimeout(() => {
        api.validate(program).then((r) => { if (r.valid) dispatch({ type: "reportReceived", report: r }); }).catch(() => {});
      }, REVALIDATE_MS);
    } catch (e) {
      if (e instanceof ApiError && e.detail?.report) dispatch({ type: "reportReceived", report: { ...e.detail.report, valid: false } });
      else say(String(e));
    }
  }, [graph, catalog, report, meta, dispatch, say]);
}
