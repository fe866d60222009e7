// Keeps the server in step with the graph. Live: every structural edit is validated and hot-swapped
// (PUT, shortly after the last edit; a burst of undo/redo steps once it ends) and a parameter drag is
// applied live (PATCH, throttled, nothing rebuilt; inside a subgraph, to the definition's node). Draft: edits are only validated (POST /api/program/validate) and the robot keeps its
// program until "Go live" swaps the draft in (the engine blends the swap within the robot's limits).
import { useCallback, useEffect, useMemo, useRef } from "react";
import { api, ApiError, type Program } from "../api";
import { flowToProgram } from "../graph";
import { useEditor } from "../store/EditorStore";
import type { Meta } from "../graph";
import { structureKey, withParams, type Graph } from "../store/state";
import { refreshInputs } from "./useBootstrap";
import { gestureTime, useSyncDelay, type Gesture } from "./syncTiming";

/** A parameter drag sends at most one PATCH per node this often (ms); the last value is always sent. */
export const PATCH_INTERVAL_MS = 50;

/** What the server has of a graph: run (live) or only judged (draft). */
const syncKey = (live: boolean, graph: Graph, meta: Meta | null) => (live ? "live:" : "draft:") + structureKey(graph, meta);

/** Sends `params` of a node at most every PATCH_INTERVAL_MS, always ending with the latest ones. */
class PatchThrottle {
  private pending = new Map<string, Record<string, unknown>>();
  private timers = new Map<string, number>();
  constructor(private send: (node: string, params: Record<string, unknown>) => Promise<void>) {}

  push(node: string, params: Record<string, unknown>): void {
    this.pending.set(node, params);
    if (this.timers.has(node)) return;
    this.flush(node);
  }

  private flush(node: string): void {
    const params = this.pending.get(node);
    if (!params) { this.timers.delete(node); return; }
    this.pending.delete(node);
    this.send(node, params).finally(() => {
      this.timers.set(node, window.setTimeout(() => this.flush(node), PATCH_INTERVAL_MS));
    });
    this.timers.set(node, -1);  // in flight
  }
}

/** After a live parameter patch, the report is asked for again once edits pause this long (ms). */
const REVALIDATE_MS = 300;

export function useProgramSync(say: (message: string) => void) {
  const { state, dispatch } = useEditor();
  const { history, meta, catalog, report, loaded, live } = state;
  const graph = history.present;
  const synced = useRef("");  // structure key of what the server runs (live) or has judged (draft)
  const program = useCallback((): Program => flowToProgram(graph.nodes, graph.edges, meta!), [graph, meta]);
  const revalidate = useRef<number | undefined>(undefined);

  useEffect(() => {
    // a subgraph opened or closed is the same program (its key composes the whole of it): what the server
    // has stays known, so only an edit not yet sent makes the next sync differ
    if (loaded.view) return;
    synced.current = loaded.fromServer ? syncKey(true, graph, meta) : "";
  }, [loaded]);  // eslint-disable-line react-hooks/exhaustive-deps -- only when a program arrives: the graph and meta are the loaded ones then

  const syncDelay = useSyncDelay(history);  // an undo burst is one swap when it ends

  useEffect(() => {
    if (!meta) return;
    const key = syncKey(live, graph, meta);
    if (key === synced.current) return;
    const timer = window.setTimeout(async () => {
      dispatch({ type: "syncing", on: true });
      // what the server has from now on: an edit made while this PUT is in flight (an undo back to the
      // previous program) must be sent too, not compared with what the server had before this one
      const previous = synced.current;
      synced.current = key;
      try {
        if (live) {
          const res = await api.putProgram(program());
          dispatch({ type: "reportReceived", report: res.report });
          refreshInputs(dispatch);
        } else {
          dispatch({ type: "reportReceived", report: await api.validate(program()) });
        }
      } catch (e) {
        // the report now describes this graph (the robot keeps the last valid program)
        if (e instanceof ApiError && e.detail?.report) {
          dispatch({ type: "reportReceived", report: e.detail.report });
        } else {
          if (synced.current === key) synced.current = previous;  // not sent: the next edit sends it again
          say(String(e));
        }
      } finally {
        dispatch({ type: "syncing", on: false });
      }
    }, syncDelay());
    return () => window.clearTimeout(timer);
  }, [graph, meta, live, program, dispatch, say, syncDelay]);

  const throttle = useMemo(() => new PatchThrottle(async (node, params) => {
    try {
      await api.patchParams(node, params);  // applied at the next tick, nothing rebuilt
    } catch (e) {
      if (e instanceof ApiError && e.detail?.report) dispatch({ type: "reportReceived", report: { ...e.detail.report, valid: false } });
      else say(String(e));
    }
  }), [dispatch, say]);

  const gesture = useRef<Gesture | null>(null);

  /** Change a node's parameters: `inProgress` for a drag's steps, not for its end nor a typed value.
   * Live, a change that keeps the node's ports is a throttled PATCH: the server is then at this graph
   * with no hot swap. Inside an open subgraph it patches the definition's node (`<instance path>/<id>`),
   * which the server applies to every instance. One that changes ports, or returns a parameter to its
   * default (a PATCH merges, it cannot unset), is structural and goes as a PUT with the next sync. */
  const editParams = useCallback((id: string, params: Record<string, unknown>, inProgress = false) => {
    const before = graph.nodes.find((n) => n.id === id)?.data.params ?? {};
    const next = withParams(graph, catalog, id, params);
    if (!next) return;
    dispatch({ type: "paramsEdited", node: id, params, at: gestureTime(gesture, id, inProgress, performance.now()) });
    const unset = Object.keys(before).some((k) => !(k in next.params));
    if (!live || next.structural || unset || !report?.valid) return;
    synced.current = syncKey(true, next.graph, meta);  // before the sync effect runs
    throttle.push(meta?.inside ? `${meta.inside.path}/${id}` : id, next.params);
    // a PATCH answers no report: judge the patched graph once the edits pause, so its warnings (a layer's
    // weight dragged to 0) show on the graph
    window.clearTimeout(revalidate.current);
    const patched = flowToProgram(next.graph.nodes, next.graph.edges, meta!);
    revalidate.current = window.setTimeout(() => {
      api.validate(patched).then((r) => { if (r.valid) dispatch({ type: "reportReceived", report: r }); }).catch(() => {});
    }, REVALIDATE_MS);
  }, [graph, catalog, report, meta, live, throttle, dispatch]);

  /** Swap the draft into the robot; false (and the reasons on the nodes) when the server refuses it. */
  const goLive = useCallback(async (): Promise<boolean> => {
    if (!meta) return false;
    if (live) return true;  // already the robot's program
    dispatch({ type: "syncing", on: true });
    try {
      const res = await api.putProgram(program());
      synced.current = syncKey(true, graph, meta);
      dispatch({ type: "wentLive", report: res.report });
      refreshInputs(dispatch);
      say(`'${meta.name}' is live`);
      return true;
    } catch (e) {
      if (e instanceof ApiError && e.detail?.report) {
        dispatch({ type: "reportReceived", report: e.detail.report });
        say(`not live: ${e.detail.report.errors.length} error(s), shown on the nodes; the robot keeps its program`);
      } else say(`not live: ${e}`);
      return false;
    } finally {
      dispatch({ type: "syncing", on: false });
    }
  }, [meta, live, graph, program, dispatch, say]);

  return { editParams, goLive };
}
