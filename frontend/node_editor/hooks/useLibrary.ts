// Programs as files: save to and open from the robot's library, start afresh, import and export JSON,
// go back to what the robot runs; and a warning before leaving with unsaved changes. New, Open and
// Import open drafts: the robot keeps its program until "Go live" (../hooks/useProgramSync).
import { useCallback, useEffect, useMemo } from "react";
import { api, ApiError, type Program } from "../api";
import { flowToProgram } from "../graph";
import { useEditor } from "../store/EditorStore";
import { suggestedName } from "../saveAs/libraryName";
import { requestSaveAs } from "../saveAs/saveAsRequest";

/** What "New" starts from: the rest pose on the output. */
const BLANK_PROGRAM = {
  format: "nutty-program/1", name: "untitled", max_level: 3, inputs: [], ui: {},
  nodes: [
    { id: "rest", type: "rest_pose", params: {}, ui: { x: 0, y: 0 } },
    { id: "output", type: "output", params: {}, ui: { x: 300, y: 0 } },
  ],
  edges: [{ from: { node: "rest", port: "out" }, to: { node: "output", port: "in" } }],
} as Program;

const DISCARD = "Discard unsaved changes?";

export function useLibrary(say: (message: string) => void) {
  const { state, dispatch } = useEditor();
  const { history, meta, libName, dirty } = state;
  const graph = history.present;
  const current = useCallback(() => flowToProgram(graph.nodes, graph.edges, meta!), [graph, meta]);

  const save = useCallback(async (asName?: string) => {
    const name = asName ?? libName;
    // never saved: the dialog asks for a name and calls back with it
    if (!name) return requestSaveAs(suggestedName(meta?.name));
    // a program saved under a new name is called by that name (its title follows the file)
    const rename = asName !== undefined;
    try {
      const program = current();
      await api.saveProgram(name, rename ? { ...program, name } : program);
      dispatch({ type: "saved", name, rename });
      dispatch({ type: "libraryListed", names: await api.list("programs") });
      say(`saved '${name}'`);
    } catch (e) {
      say(e instanceof ApiError ? `not saved: ${e.detail?.message ?? e.message}` : String(e));
    }
  }, [libName, meta, current, dispatch, say]);

  const saveAs = useCallback(() => requestSaveAs(suggestedName(libName ?? meta?.name)), [libName, meta]);

  const open = useCallback(async (name: string) => {
    if (dirty && !window.confirm(DISCARD)) return;
    try {
      dispatch({ type: "programLoaded", program: await api.getProgram(name), libName: name });
    } catch (e) {
      say(`cannot open '${name}': ${e}`);
    }
  }, [dirty, dispatch, say]);

  const newProgram = useCallback(() => {
    if (dirty && !window.confirm(DISCARD)) return;
    dispatch({ type: "programLoaded", program: structuredClone(BLANK_PROGRAM), libName: null });
  }, [dirty, dispatch]);

  const openRunning = useCallback(async () => {
    if (dirty && !window.confirm(DISCARD)) return;
    try {
      const running = await api.program();
      if (running.program) dispatch({ type: "programLoaded", program: running.program, fromServer: true, report: running.report, libName: null });
    } catch (e) {
      say(`cannot read the running program: ${e}`);
    }
  }, [dirty, dispatch, say]);

  const exportJson = useCallback(() => {
    const blob = new Blob([JSON.stringify(current(), null, 2)], { type: "application/json" });
    const a = document.createElement("a");
    a.href = URL.createObjectURL(blob);
    a.download = `${meta?.name ?? "program"}.json`;
    a.click();
  }, [current, meta]);

  const importJson = useCallback(async (file: File) => {
    if (dirty && !window.confirm(DISCARD)) return;
    try {
      const program = JSON.parse(await file.text()) as Program;
      const report = await api.validate(program);
      if (!report.valid) say(`imported with ${report.errors.length} error(s): they are shown on the nodes`);
      dispatch({ type: "programLoaded", program, report });
    } catch (e) {
      say(`cannot import: ${e}`);
    }
  }, [dirty, dispatch, say]);

  useEffect(() => {
    const warn = (e: BeforeUnloadEvent) => { if (dirty) { e.preventDefault(); e.returnValue = ""; } };
    window.addEventListener("beforeunload", warn);
    return () => window.removeEventListener("beforeunload", warn);
  }, [dirty]);

  return useMemo(() => ({ save, saveAs, open, openRunning, newProgram, exportJson, importJson }),
    [save, saveAs, open, openRunning, newProgram, exportJson, importJson]);
}
