// The graph: the program's blocks and edges on a React Flow canvas. Edits go to the store; a wire the
// rules refuse is not drawn, and dropping it says why.
import {
  Background, MiniMap, ReactFlow, useReactFlow, type Connection as FlowConnection, type EdgeChange, type NodeChange,
} from "@xyflow/react";
import { useCallback, useEffect, useMemo, useRef } from "react";
import { BlockNode, PORT_COLOURS } from "./BlockNode";
import { connectionProblem, type FlowEdge, type FlowNode } from "./graph";
import { useActions, useEditor } from "./store/EditorStore";
import { errorsByNode } from "./store/state";
import { warningsByNode } from "./live/logic";
import { WarningsContext } from "./live/NodeBadges";
import { WireOverlay, wireHoverHandlers } from "./live/WireProbes";

const nodeTypes = { block: BlockNode };
export const FIT_VIEW = { padding: 0.15, maxZoom: 1.1 };
/** A freshly loaded program is fitted into view once React Flow has measured its nodes. */
const FIT_AFTER_LOAD_MS = 50;
const TOAST_MS = 4000;

/** The nodes with the report's errors on them (unchanged nodes keep their identity: no re-render). */
function withErrors(nodes: FlowNode[], errors: Record<string, string[]>): FlowNode[] {
  return nodes.map((n) => {
    const mine = errors[n.id] ?? [];
    const same = mine.length === n.data.errors.length && mine.every((e, i) => e === n.data.errors[i]);
    return same ? n : { ...n, data: { ...n.data, errors: mine } };
  });
}

function styled(e: FlowEdge) {
  const type = e.data?.type ?? "frame";
  return { ...e, style: { stroke: PORT_COLOURS[type], strokeWidth: type === "frame" ? 2.5 : 1.5 } };
}

function Toast() {
  const { state, dispatch } = useEditor();
  const { toast } = state;
  useEffect(() => {
    if (!toast) return;
    const timer = window.setTimeout(() => dispatch({ type: "toastExpired", message: toast }), TOAST_MS);
    return () => window.clearTimeout(timer);
  }, [toast, dispatch]);
  return toast ? <div className="toast" role="alert" data-testid="toast">{toast}</div> : null;
}

export function GraphView() {
  const flow = useReactFlow();
  const { state, dispatch } = useEditor();
  const { addBlock, say } = useActions();
  const graph = state.history.present;
  const errors = useMemo(() => errorsByNode(state.report), [state.report]);
  const nodes = useMemo(() => withErrors(graph.nodes, errors), [graph.nodes, errors]);
  const edges = useMemo(() => graph.edges.map(styled), [graph.edges]);
  const warnings = useMemo(() => warningsByNode(state.report), [state.report]);

  useEffect(() => {
    if (!state.loaded.count) return;
    const timer = window.setTimeout(() => flow.fitView(FIT_VIEW), FIT_AFTER_LOAD_MS);
    return () => window.clearTimeout(timer);
  }, [state.loaded.count, flow]);

  const onNodesChange = useCallback((changes: NodeChange[]) => dispatch({ type: "nodesChanged", changes }), [dispatch]);
  const onEdgesChange = useCallback((changes: EdgeChange[]) => dispatch({ type: "edgesChanged", changes }), [dispatch]);
  const onConnect = useCallback((c: FlowConnection) => dispatch({
    type: "connected", connection: { source: c.source, sourceHandle: c.sourceHandle!, target: c.target, targetHandle: c.targetHandle! },
  }), [dispatch]);
  const lastProblem = useRef<string | null>(null);
  const isValidConnection = useCallback((c: any) => {
    lastProblem.current = connectionProblem(graph.nodes, graph.edges, c.source, c.sourceHandle, c.target, c.targetHandle);
    return lastProblem.current === null;
  }, [graph]);
  const onConnectEnd = useCallback((_: unknown, end: any) => {
    // dropped on a port that refused the wire: say why
    if (end && end.isValid === false && end.toHandle && lastProblem.current) say(`refused: ${lastProblem.current}`);
  }, [say]);
  const onDrop = (e: React.DragEvent) => {
    const type = e.dataTransfer.getData("application/nutty-block");
    if (type) addBlock(type, flow.screenToFlowPosition({ x: e.clientX, y: e.clientY }));
  };

  return (
    <main className="graph" onDragOver={(e) => e.preventDefault()} onDrop={onDrop}>
      <WarningsContext.Provider value={warnings}>
      <ReactFlow nodes={nodes as any} edges={edges as any} nodeTypes={nodeTypes as any} {...wireHoverHandlers}
                 onNodesChange={onNodesChange} onEdgesChange={onEdgesChange} onConnect={onConnect}
                 onConnectEnd={onConnectEnd as any} isValidConnection={isValidConnection}
                 deleteKeyCode={["Delete", "Backspace"]} multiSelectionKeyCode="Shift"
                 minZoom={0.2} fitView fitViewOptions={FIT_VIEW} proOptions={{ hideAttribution: true }}>
        <Background color="#2b313b" gap={22} />
        <MiniMap pannable zoomable nodeColor="#3a4150" maskColor="rgba(10,12,16,0.6)" style={{ width: 180, height: 110 }} />
        <WireOverlay edges={graph.edges} />
      </ReactFlow>
      </WarningsContext.Provider>
      <Toast />
    </main>
  );
}
