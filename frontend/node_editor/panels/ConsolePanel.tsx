// The command console: what was sent and what the control socket answered.
import { useEditor } from "../store/EditorStore";

const SHOWN_LINES = 40;

export function ConsolePanel() {
  const { consoleLines } = useEditor().state;
  return <pre className="console" data-testid="console">{consoleLines.slice(-SHOWN_LINES).join("\n")}</pre>;
}
