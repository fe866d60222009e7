// Telling the user something: a toast over the graph, a line in the console.
import { useCallback } from "react";
import { useEditor } from "../store/EditorStore";

export function useNotices() {
  const { dispatch } = useEditor();
  const say = useCallback((message: string) => dispatch({ type: "toast", message }), [dispatch]);
  const log = useCallback(
    (line: string) => dispatch({ type: "logged", line: `${new Date().toLocaleTimeString()}  ${line}` }), [dispatch]);
  return { say, log };
}
