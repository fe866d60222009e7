// First contact with the server: the block catalog, the robot, the running program and the lists the
// panels offer (programs, clips, exposed inputs).
import { useEffect, type Dispatch } from "react";
import { accessToken, api, setAccessToken } from "../api";
import { useEditor } from "../store/EditorStore";
import type { Action } from "../store/state";

/** The running program's exposed inputs (declarations and values) into the store. */
export function refreshInputs(dispatch: Dispatch<Action>): void {
  api.inputs().then((r) => dispatch({ type: "inputsLoaded", decls: r.declarations, values: r.values })).catch(() => {});
}

export function useBootstrap(say: (message: string) => void): void {
  const { dispatch } = useEditor();
  useEffect(() => {
    (async () => {
      const [blocks, robot, running, previz] = await Promise.all([api.blocks(), api.robot(), api.program(), api.previz()]);
      if (previz.token_required && !accessToken()) {
        const token = window.prompt("This robot's server needs its access token (nutty serve --token …) to change anything. Token:");
        if (token) setAccessToken(token.trim());
        else say("no access token: this editor can watch the robot but not change it");
      }
      dispatch({ type: "serverDescribed", catalog: Object.fromEntries(blocks.map((b) => [b.type, b])), robot, previz });
      if (running.program) dispatch({ type: "programLoaded", program: running.program, fromServer: true, report: running.report });
      else dispatch({ type: "reportReceived", report: running.report });
      api.list("programs").then((names) => dispatch({ type: "libraryListed", names })).catch(() => {});
      api.list("clips").then((names) => dispatch({ type: "clipsListed", names })).catch(() => {});
      refreshInputs(dispatch);
    })().catch((e) => say(`cannot reach the server: ${e}`));
  }, [dispatch, say]);
}
