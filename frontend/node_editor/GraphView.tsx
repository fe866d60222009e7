// The graph: the program's blocks and edges on a React Flow canvas. Edits go to the store; a wire the
// rules refuse is not drawn, and dropping it says why; one dropped on an occupied input replaces its wire.
// Dropping a wire in empty space, Tab / Shift+A / Space, and the context menus open the quick-add search;
// one dropped on a block's body goes to its first port that fits, and ports that cannot take a dragged
// wire fade. F2 renames the selected block in place; inside a subgraph, Group Input / Output stand-ins
// show where its exposed ports go.
import {
  Background, MiniMap, ReactFlow, SelectionMode, useReactFlow, type Connection as FlowConnection, type EdgeChange,
  type FinalConnectionState, type NodeChange,
} from "@xyflow/react";
import { useCallback, useEffect, useLayoutEffect, useMemo, useRef, useState } from "react";
import { withRoutes } from "./annotations";
import { layoutGraph } from "./autoLayout";
import { BlockNode, PORT_COLOURS } from "./BlockNode";
import { CanvasControls } from "./CanvasControls";
import { nodeMenuExtras, wireMenuExtras } from "./canvasMenus";
import { CommentFrame } from "./CommentFrame";
import { ContextMenu, type MenuEntry } from "./ContextMenu";
import { type FlowEdge, type FlowNode, type SubgraphDef } from "./graph";
import { groupIO, isGroupIO } from "./groupIO";
import { GroupIONode } from "./GroupIONode";
import { RenameContext, type Renaming } from "./NodeTitle";
import { useCanvasKeys } from "./hooks/useCanvasKeys";
import {
  AT_POINTER, BLOCK_HEADER_HEIGHT, BLOCK_WIDTH, DRAG_BLOCK, DRAG_SUBGRAPH, LAYER_ROW_HEIGHT, LAYERS_PADDING, LIVE_ROW_HEIGHT, MINIMAP_SIZE, PORT_ROW_HEIGHT, PORT_ROWS_TOP,
} from "./layout/constants";
import { OrganiseContext } from "./organise/context";
import { useOrganise } from "./organise/useOrganise";
import { SubgraphBar } from "./panels/SubgraphBar";
import { QuickAdd } from "./QuickAdd";
import { replacingProblem, type Offer, type PortRef, type QuickAddMode } from "./quickAdd";
import { RerouteNode, RoutedEdge } from "./Reroute";
import { useActions, useEditor } from "./store/EditorStore";
import { warningsByNode } from "./live/logic";
import { WarningsContext } from "./live/NodeBadges";
import { WireOverlay, wireHoverHandlers } from "./live/WireProbes";
import { errorsByNode, type Position } from "./store/state";
import { SubgraphNode } from "./SubgraphNode";
import { CANVAS_MAX_ZOOM, CANVAS_MIN_ZOOM, clearSpot, fitReadable, frameOpening, refitOnResize, trackPointer } from "./viewport";
import { DimContext, dropOnBody, incompatiblePorts } from "./wireDrop";

const nodeTypes = { block: BlockNode, subgraph: SubgraphNode, comment: CommentFrame, reroute: RerouteNode, groupIO: GroupIONode };
const NO_DIM: ReadonlySet<string> = new Set();
const edgeTypes = { routed: RoutedEdge };
export const FIT_VIEW = { padding: 0.15, maxZoom: 1.1 };
/** A freshly loaded program is fitted into view once React Flow has measured its nodes. */
const FIT_AFTER_LOAD_MS = 50;
const TOAST_MS = 4000;
/** The background grid's spacing. */
const GRID_GAP = 22;
/** Room below a block's last row in the auto-layout's estimate of its height (body padding, borders). */
const BODY_BOTTOM = 8;
/** Gap between a port dragged into empty space and the block the quick-add puts there. */
const PORT_GAP = 40;
/** Where the quick-add's block goes, from the point it was opened at: anywhere, centred on that point
 * with its title under it; on a wire, a little higher, so the wire meets its ports; from a dragged port,
 * beside the port (right of an output, left of an input), its first ports about level with it. */
const QUICK_ADD_OFFSET = {
  any: AT_POINTER,
  insert: { x: -BLOCK_WIDTH / 2, y: -40 },
  fromOutput: { x: PORT_GAP, y: -45 },
  fromInput: { x: -(BLOCK_WIDTH + PORT_GAP), y: -45 },
};

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
  const standIn = isGroupIO(e.source) || isGroupIO(e.target);
  return { ...e, style: { stroke: PORT_COLOURS[type], strokeWidth: type === "frame" ? 2.5 : 1.5, ...(standIn ? { strokeDasharray: "6 4" } : {}) },
    ...(standIn ? { selectable: false, deletable: false } : {}) };
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

/** Size of a block when not collapsed (what the layout makes room for, whatever the zoom now). */
function fullSize(n: FlowNode, measured?: { width?: number; height?: number }) {
  const ins = Object.keys(n.data.inputs).length, outs = Object.keys(n.data.outputs).length;
  const layers = Array.isArray(n.data.params.layers) ? n.data.params.layers.length * LAYER_ROW_HEIGHT + LAYERS_PADDING : 0;
  const height = BLOCK_HEADER_HEIGHT + Math.max(ins, outs, 1) * PORT_ROW_HEIGHT + PORT_ROWS_TOP + outs * LIVE_ROW_HEIGHT + BODY_BOTTOM + layers;
  return { width: Math.max(BLOCK_WIDTH, measured?.width ?? 0), height };
}

type QuickState = { x: number; y: number; at: Position; mode: QuickAddMode };
type MenuTarget = { kind: "pane" } | { kind: "node"; ids: string[] } | { kind: "port"; port: PortRef } | { kind: "wire"; edge: string };
type MenuState = { x: number; y: number; at: Position; client: Position } & MenuTarget;

export function GraphView() {
  const flow = useReactFlow();
  const { state, dispatch } = useEditor();
  const { addBlock, say, copy, paste } = useActions();
  const graph = state.history.present;
  const inside = state.meta?.inside?.path;
  const errors = useMemo(() => errorsByNode(state.report, inside), [state.report, inside]);
  // the open subgraph's Group Input / Output stand-ins: drawn, never in the store's graph
  // (React Flow shows a node once it has been measured: their sizes are kept here, as the store keeps blocks')
  const [ioSizes, setIoSizes] = useState<Record<string, { width: number; height: number }>>({});
  const io = useMemo(() => groupIO(graph.nodes, state.meta?.inside), [graph.nodes, state.meta?.inside]);
  const nodes = useMemo(() => [...withErrors(graph.nodes, errors), ...io.nodes.map((n) => ({ ...n, measured: ioSizes[n.id] }))],
    [graph.nodes, errors, io.nodes, ioSizes]);
  const edges = useMemo(() => withRoutes([...graph.edges, ...io.edges].map(styled), graph.nodes), [graph.edges, io.edges, graph.nodes]);
  const organise = useOrganise();
  const canvas = useRef<HTMLElement>(null);
  const [quick, setQuick] = useState<QuickState | null>(null);
  const [menu, setMenu] = useState<MenuState | null>(null);
  const closeQuick = useCallback(() => setQuick(null), []);
  const closeMenu = useCallback(() => setMenu(null), []);
  const [dimmed, setDimmed] = useState<ReadonlySet<string>>(NO_DIM);
  const [renaming, setRenaming] = useState<string | null>(null);
  const rename: Renaming = useMemo(() => ({
    id: renaming, cancel: () => setRenaming(null),
    commit: (from, to) => { setRenaming(null); dispatch({ type: "nodeRenamed", from, to }); },
  }), [renaming, dispatch]);
  useEffect(() => (canvas.current ? trackPointer(canvas.current) : undefined), []);
  useEffect(() => (canvas.current ? refitOnResize(flow, canvas.current) : undefined), [flow]);
  // the graph as it is now, for the layout's callbacks and timers (set once a render is committed)
  const graphRef = useRef(graph);
  useLayoutEffect(() => { graphRef.current = graph; }, [graph]);

  const autoLayout = useCallback(async (undoable = true) => {
    const g = graphRef.current;
    const measured = Object.fromEntries(flow.getNodes().map((n) => [n.id, n.measured]));
    const sizes = Object.fromEntries(g.nodes.map((n) => [n.id, fullSize(n, measured[n.id])]));
    // blocks and subgraph nodes are laid out; comment frames and reroute points stay where they were put
    const blocks = g.nodes.filter((n) => n.type === "block" || n.type === "subgraph");
    const positions = await layoutGraph(blocks, g.edges, state.catalog, sizes);
    dispatch({ type: "laidOut", positions, undoable });
    // framed as on opening: all of it when readable, else the output chain and what feeds it
    window.setTimeout(() => frameOpening(flow, graphRef.current.nodes, graphRef.current.edges, state.catalog), FIT_AFTER_LOAD_MS);
  }, [flow, dispatch, state.catalog]);
  const warnings = useMemo(() => warningsByNode(state.report), [state.report]);

  useEffect(() => {
    if (!state.loaded.count) return;
    const timer = window.setTimeout(() => {
      const g = graphRef.current;
      // a program without positions is laid out (not an undo step: it is how it arrives)
      if (g.nodes.some((n) => typeof n.data.ui.x !== "number" || typeof n.data.ui.y !== "number")) autoLayout(false);
      else frameOpening(flow, g.nodes, g.edges, state.catalog);
    }, FIT_AFTER_LOAD_MS);
    return () => window.clearTimeout(timer);
  }, [state.loaded.count, flow]);  // eslint-disable-line react-hooks/exhaustive-deps -- once per program loaded: a new catalog or autoLayout must not frame the view again

  // deletions come as one `deleted` action (onDelete): a node and its wires are one undo step
  const onNodesChange = useCallback((changes: NodeChange<FlowNode>[]) => {
    const sized = changes.flatMap((c) => (c.type === "dimensions" && c.dimensions && isGroupIO(c.id) ? [[c.id, c.dimensions] as const] : []));
    if (sized.length) setIoSizes((s) => ({ ...s, ...Object.fromEntries(sized) }));
    const rest = changes.filter((c) => c.type !== "remove" && !isGroupIO("id" in c ? c.id : ""));
    if (rest.length) dispatch({ type: "nodesChanged", changes: rest });
  }, [dispatch]);
  const onEdgesChange = useCallback((changes: EdgeChange<FlowEdge>[]) => {
    const rest = changes.filter((c) => c.type !== "remove");
    if (rest.length) dispatch({ type: "edgesChanged", changes: rest });
  }, [dispatch]);
  const onDelete = useCallback(({ nodes: ns, edges: es }: { nodes: { id: string }[]; edges: { id: string }[] }) => {
    dispatch({ type: "deleted", nodes: ns.map((n) => n.id), edges: es.map((e) => e.id) });
  }, [dispatch]);
  const onConnect = useCallback((c: FlowConnection) => dispatch({
    type: "connected", connection: { source: c.source, sourceHandle: c.sourceHandle!, target: c.target, targetHandle: c.targetHandle! },
  }), [dispatch]);
  const lastProblem = useRef<string | null>(null);
  const isValidConnection = useCallback((c: FlowConnection | FlowEdge) => {
    lastProblem.current = replacingProblem(graph.nodes, graph.edges, c.source, c.sourceHandle ?? "", c.target, c.targetHandle ?? "");
    return lastProblem.current === null;
  }, [graph]);

  const openQuick = useCallback((clientX: number, clientY: number, mode: QuickAddMode) => {
    const r = canvas.current!.getBoundingClientRect();
    setMenu(null);
    setQuick({ x: clientX - r.left, y: clientY - r.top, at: flow.screenToFlowPosition({ x: clientX, y: clientY }), mode });
  }, [flow]);
  const pick = useCallback((o: Offer) => {
    const q = quick;
    setQuick(null);
    if (!q) return;
    const { at, mode } = q;
    // beside the point it was opened at, but in view and never under the minimap or the canvas's buttons
    const near = (offset: Position) => {
      const spot = { x: at.x + offset.x, y: at.y + offset.y };
      return clearSpot(flow, spot) ?? spot;
    };
    if (mode.kind === "any") dispatch({ type: "blockAdded", blockType: o.type, position: near(QUICK_ADD_OFFSET.any) });
    else if (mode.kind === "insert") dispatch({ type: "blockInserted", blockType: o.type, position: near(QUICK_ADD_OFFSET.insert), edge: mode.edge });
    else dispatch({
      type: "blockAddedFrom", blockType: o.type, port: mode.port,
      position: near(mode.port.side === "source" ? QUICK_ADD_OFFSET.fromOutput : QUICK_ADD_OFFSET.fromInput),
    });
  }, [quick, dispatch, flow]);

  const onConnectStart = useCallback((_: unknown, p: { nodeId: string | null; handleId: string | null; handleType: "source" | "target" | null }) => {
    if (p.nodeId && p.handleType) setDimmed(incompatiblePorts(graph.nodes, graph.edges, { node: p.nodeId, handle: p.handleId ?? "", side: p.handleType }));
  }, [graph]);
  const onConnectEnd = useCallback((event: MouseEvent | TouchEvent, end: FinalConnectionState) => {
    setDimmed(NO_DIM);
    // dropped on a port that refused the wire: say why
    if (end && end.isValid === false && end.toHandle && lastProblem.current) { say(`refused: ${lastProblem.current}`); return; }
    if (!end?.fromHandle || end.toHandle) return;
    const h = end.fromHandle;
    const from = { node: h.nodeId, handle: h.id ?? "", side: h.type };
    const p = "changedTouches" in event ? event.changedTouches[0] : event;
    // dropped on a block's body: its first port that fits
    const onto = (document.elementFromPoint(p.clientX, p.clientY) ?? (event.target as Element | null))?.closest?.(".react-flow__node") as HTMLElement | null;
    if (onto) {
      const id = onto.dataset.id ?? "";
      if (!id || isGroupIO(id) || id === from.node || !graph.nodes.some((n) => n.id === id && (n.type === "block" || n.type === "subgraph"))) return;
      const c = dropOnBody(graph.nodes, graph.edges, from, id);
      if (typeof c === "string") say(`refused: ${c}`);
      else dispatch({ type: "connected", connection: c });
      return;
    }
    // dropped in empty space: the search for a block to wire it to, there
    openQuick(p.clientX, p.clientY, { kind: "from", port: from });
  }, [say, openQuick, graph, dispatch]);
  const onDrop = (e: React.DragEvent) => {
    const at = flow.screenToFlowPosition({ x: e.clientX, y: e.clientY });
    const type = e.dataTransfer.getData(DRAG_BLOCK);
    if (type) return addBlock(type, at);
    const sub = e.dataTransfer.getData(DRAG_SUBGRAPH);
    if (!sub) return;
    const { name, definition } = JSON.parse(sub) as { name: string; definition: SubgraphDef };
    dispatch({ type: "subgraphInserted", name, definition, position: { x: at.x + AT_POINTER.x, y: at.y + AT_POINTER.y } });
  };

  const selectAll = useCallback(() => dispatch({ type: "selectedAll" }), [dispatch]);
  const quickAtPointer = useCallback((x: number, y: number) => openQuick(x, y, { kind: "any" }), [openQuick]);
  const renameSelected = useCallback(() => {
    const chosen = graphRef.current.nodes.filter((n) => n.selected && (n.type === "block" || n.type === "subgraph"));
    if (chosen.length === 1) setRenaming(chosen[0].id);
  }, []);
  useCanvasKeys(canvas, { quickAdd: quickAtPointer, selectAll, busy: quick !== null || menu !== null || renaming !== null, rename: renameSelected });

  const openMenu = (e: React.MouseEvent | MouseEvent, what: MenuTarget) => {
    e.preventDefault();
    const r = canvas.current!.getBoundingClientRect();
    setQuick(null);
    setMenu({ ...what, x: e.clientX - r.left, y: e.clientY - r.top, client: { x: e.clientX, y: e.clientY },
              at: flow.screenToFlowPosition({ x: e.clientX, y: e.clientY }) } as MenuState);
  };
  const onNodeContextMenu = (e: React.MouseEvent, node: { id: string; selected?: boolean }) => {
    const handle = (e.target as Element).closest?.(".react-flow__handle") as HTMLElement | null;
    if (handle?.dataset.handleid) {
      const side = handle.classList.contains("source") ? "source" : "target";
      return openMenu(e, { kind: "port", port: { node: node.id, handle: handle.dataset.handleid, side } });
    }
    const selected = graph.nodes.filter((n) => n.selected).map((n) => n.id);
    const ids = node.selected && selected.length ? selected : [node.id];
    if (!node.selected) dispatch({ type: "selectedOnly", nodes: ids });
    openMenu(e, { kind: "node", ids });
  };

  const entries = (m: MenuState): { title?: string; entries: MenuEntry[] } => {
    const fit = () => fitReadable(flow);
    switch (m.kind) {
      case "pane":
        return { entries: [
          { label: "Add block…", hint: "Tab", run: () => openQuick(m.client.x, m.client.y, { kind: "any" }) },
          { label: "Paste", hint: "Ctrl+V", run: paste },
          { label: "Select all", hint: "Ctrl+A", run: selectAll },
          { label: "Auto-layout", run: () => autoLayout(true) },
          { label: "Fit view", hint: "F", run: fit },
        ] };
      case "node": {
        const extras = m.ids.length === 1 ? graph.nodes.filter((n) => n.id === m.ids[0]) : [];
        return { title: m.ids.length === 1 ? m.ids[0] : `${m.ids.length} blocks`, entries: [
          { label: "Duplicate", hint: "Shift+D", run: () => dispatch({ type: "duplicated", nodes: m.ids,  // at the pointer, like Shift+D
            at: { x: m.at.x + AT_POINTER.x, y: m.at.y + AT_POINTER.y } }) },
          { label: "Copy", hint: "Ctrl+C", run: copy },
          { label: "Disconnect all", run: () => dispatch({ type: "deleted", nodes: [],  // one undo step, however many blocks
            edges: graph.edges.filter((e) => m.ids.includes(e.source) || m.ids.includes(e.target)).map((e) => e.id) }) },
          { label: "Delete", hint: "Del", run: () => dispatch({ type: "deleted", nodes: m.ids, edges: [] }) },
          ...extras.filter((n) => n.type === "block" || n.type === "subgraph").map((n) => ({ label: "Rename", hint: "F2", run: () => setRenaming(n.id) })),
          ...extras.filter((n) => n.type === "subgraph").map((n) => ({ label: "Ungroup", run: () => dispatch({ type: "ungrouped", node: n.id }) })),
          ...nodeMenuExtras.flatMap((x) => extras.filter((n) => !x.when || x.when(n)).map((n) => ({ label: x.label, run: () => x.run(n) }))),
        ] };
      }
      case "port": {
        const wired = graph.edges.some((e) => (m.port.side === "source" ? e.source === m.port.node && e.sourceHandle === m.port.handle
          : e.target === m.port.node && e.targetHandle === m.port.handle));
        return { title: `${m.port.node}.${m.port.handle}`, entries: [
          { label: "Disconnect", disabled: !wired, run: () => dispatch({ type: "disconnected", node: m.port.node, handle: m.port.handle, side: m.port.side }) },
          { label: m.port.side === "source" ? "Add block fed from here…" : "Add block feeding this…",
            run: () => openQuick(m.client.x, m.client.y, { kind: "from", port: m.port }) },
        ] };
      }
      case "wire": {
        const edge = graph.edges.find((e) => e.id === m.edge);
        return { title: "wire", entries: [
          { label: "Insert block…", run: () => openQuick(m.client.x, m.client.y, { kind: "insert", edge: m.edge }) },
          { label: "Delete wire", hint: "Del", run: () => dispatch({ type: "deleted", nodes: [], edges: [m.edge] }) },
          ...(edge ? wireMenuExtras.filter((x) => !x.when || x.when(edge)).map((x) => ({ label: x.label, run: () => x.run(edge) })) : []),
        ] };
      }
    }
  };

  return (
    <main ref={canvas} className="graph" onDragOver={(e) => e.preventDefault()} onDrop={onDrop}>
      <OrganiseContext.Provider value={organise.context}>
      <WarningsContext.Provider value={warnings}>
      <RenameContext.Provider value={rename}>
      <DimContext.Provider value={dimmed}>
      <ReactFlow nodes={nodes} edges={edges} nodeTypes={nodeTypes} edgeTypes={edgeTypes} {...wireHoverHandlers}
                 onEdgeDoubleClick={organise.onEdgeDoubleClick} onNodeDoubleClick={organise.onNodeDoubleClick}
                 onNodesChange={onNodesChange} onEdgesChange={onEdgesChange} onConnect={onConnect} onDelete={onDelete}
                 onConnectStart={onConnectStart} onConnectEnd={onConnectEnd} isValidConnection={isValidConnection}
                 deleteKeyCode={["Delete", "Backspace"]} multiSelectionKeyCode="Shift"
                 // Blender/Unreal hands: left-drag on empty canvas box-selects, middle-drag (or Space+drag) pans, wheel zooms
                 selectionOnDrag panOnDrag={[1]} selectionMode={SelectionMode.Partial}
                 onPaneContextMenu={(e) => openMenu(e, { kind: "pane" })}
                 onNodeContextMenu={onNodeContextMenu}
                 onSelectionContextMenu={(e) => openMenu(e, { kind: "node", ids: graph.nodes.filter((n) => n.selected).map((n) => n.id) })}
                 onEdgeContextMenu={(e, edge) => openMenu(e, { kind: "wire", edge: edge.id })}
                 minZoom={CANVAS_MIN_ZOOM} maxZoom={CANVAS_MAX_ZOOM} proOptions={{ hideAttribution: true }}>
        <Background color="#2b313b" gap={GRID_GAP} />
        <MiniMap pannable zoomable nodeColor="#3a4150" maskColor="rgba(10,12,16,0.6)" style={MINIMAP_SIZE} />
        <CanvasControls fit={() => fitReadable(flow)} autoLayout={() => autoLayout(true)} />
        <WireOverlay edges={graph.edges} />
      </ReactFlow>
      {quick && <QuickAdd x={quick.x} y={quick.y} mode={quick.mode} onPick={pick} onClose={closeQuick} />}
      {menu && <ContextMenu x={menu.x} y={menu.y} {...entries(menu)} onClose={closeMenu} />}
      <SubgraphBar />
      </DimContext.Provider>
      </RenameContext.Provider>
      </WarningsContext.Provider>
      </OrganiseContext.Provider>
      <Toast />
    </main>
  );
}
