// The selected subgraph node: its definition's description and exposed ports (each the inner block's
// port it stands for), with a button to open it. Blocks are edited inside (Open); nothing to set here.
import { useEditor } from "../store/EditorStore";
import { errorsByNode } from "../store/state";
import { SUBGRAPH, selectedBlocks, type SubgraphDef } from "../subgraphs";

export function SubgraphInfo() {
  const { state, dispatch } = useEditor();
  const blocks = selectedBlocks(state.history.present);
  const node = blocks.length === 1 && blocks[0].data.type === SUBGRAPH ? blocks[0] : null;
  if (!node) return null;
  const name = String(node.data.params.subgraph);
  const def = (state.meta?.subgraphs ?? {})[name] as SubgraphDef | undefined;
  const errors = errorsByNode(state.report, state.meta?.inside?.path)[node.id] ?? [];
  const ports = (list: SubgraphDef["inputs"] | undefined, specs: Record<string, { type: string }>) => (list ?? []).map((p) => (
    <div key={p.name} className="exposed-row"><span className="port-name">{p.name}</span>
      <span className="muted">{p.node}.{p.port} · {specs[p.name]?.type ?? "?"}</span></div>
  ));
  return (
    <div className="panel params subgraph-info" data-testid="subgraph-info">
      <h3>▣ {name} <span className="muted">{node.id}</span></h3>
      <p className="doc">{def?.description || `A subgraph of ${def?.nodes?.length ?? 0} blocks; its blocks run as '${node.id}/<block>'.`}</p>
      {errors.map((e, i) => <div key={i} className="error-line">{e}</div>)}
      <div className="group-title">Inputs</div>
      {ports(def?.inputs, node.data.inputs)}
      <div className="group-title">Outputs</div>
      {ports(def?.outputs, node.data.outputs)}
      <button data-testid="info-open" onClick={() => dispatch({ type: "subgraphOpened", node: node.id })}>Open to edit its blocks</button>
    </div>
  );
}
