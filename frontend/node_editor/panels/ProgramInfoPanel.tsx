// The running program at a glance: its name, APU level and how many blocks and wires it has.
import { useEditor } from "../store/EditorStore";

export function ProgramInfoPanel() {
  const { meta, history, report } = useEditor().state;
  const graph = history.present;
  return (
    <div className="program-info">
      <b>{meta?.name ?? "untitled"}</b> · level {report?.level ?? "?"} ·{" "}
      {graph.nodes.length} blocks · {graph.edges.length} wires
    </div>
  );
}
