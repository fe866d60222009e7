// The Nutty editor: the running Animation Program as a live node graph, side by side with the Pre-Viz.
import {
  applyEdgeChanges, applyNodeChanges, Background, MiniMap, ReactFlow, ReactFlowProvider, useReactFlow,
  type Connection, type EdgeChange, type NodeChange,
} from "@xyflow/react";
import "@xyflow/react/dist/style.css";
import { useCallback, useEffect, useMemo, useRef, useState } from "react";
import { api, ApiError, wsUrl, type BlockEntry, type Program, type Report, type Robot } from "./api";
import { BlockNode, PORT_COLOURS } from "./BlockNode";
import { CatalogContext, LiveContext, type Live } from "./context";
import { CurvePanel, type Samples } from "./CurvePanel";
import {
  connectionProblem, defaultParams, edgeId, flowToProgram, freshId, pasteClipboard, portsOf, programToFlow,
  type FlowEdge, type FlowNode, type Meta,
} from "./graph";
import * as H from "./history";
import { Palette } from "./Palette";
import { ParamPanel } from "./ParamPanel";

type Graph = { nodes: FlowNode[]; edges: FlowEdge[] };
const nodeTypes = { block: BlockNode };
const TELEMETRY_HZ = 30;
const CURVE_SECONDS = 8;

function structureKey(g: Graph, meta: Meta | null): string {
  return JSON.stringify(flowToProgram(g.nodes.map((n) => ({ ...n, position: { x: 0, y: 0 } })), g.edges, meta ?? ({} as Meta)));
}

function Editor() {
  const flow = useReactFlow();
  const [catalog, setCatalog] = useState<Record<string, BlockEntry>>({});
  const [robot, setRobot] = useState<Robot | null>(null);
  const [meta, setMeta] = useState<Meta | null>(null);
  const [hist, setHist] = useState<H.History<Graph>>(H.init({ nodes: [], edges: [] }));
  const [report, setReport] = useState<Report | null>(null);
  const [syncing, setSyncing] = useState(false);
  const [toast, setToast] = useState<string | null>(null);
  const [libName, setLibName] = useState<string | null>(null);
  const [library, setLibrary] = useState<string[]>([]);
  const [clips, setClips] = useState<string[]>([]);
  const [dirty, setDirty] = useState(false);
  const [live, setLive] = useState<Live>({ values: {}, history: {}, layers: {} });
  const [samples, setSamples] = useState<Samples>({ t: [], final: {}, stage1: {}, classes: [] });
  const [curveDof, setCurveDof] = useState("head_yaw");
  const [consoleLines, setConsoleLines] = useState<string[]>([]);
  const [inputs, setInputs] = useState<{ decls: any[]; values: Record<string, any> }>({ decls: [], values: {} });
  const [previz, setPreviz] = useState<{ url: string | null; ghost: boolean | null }>({ url: null, ghost: null });
  const serverKey = useRef<string>("");
  const clipboard = useRef<Graph | null>(null);
  const lastParamEdit = useRef<{ key: string; at: number } | null>(null);
  const graph = hist.present;

  const say = useCallback((msg: string) => {
    setToast(msg);
    window.setTimeout(() => setToast((t) => (t === msg ? null : t)), 4000);
  }, []);
  const log = useCallback((line: string) => setConsoleLines((c) => [...c.slice(-199), `${new Date().toLocaleTimeString()}  ${line}`]), []);

  // --- loading --------------------------------------------------------------------------------------
  const loadProgram = useCallback((program: Program, cat: Record<string, BlockEntry>, fromServer: boolean) => {
    const { nodes, edges, meta } = programToFlow(program, cat);
    setMeta(meta);
    setHist(H.init({ nodes, edges }));
    if (fromServer) serverKey.current = structureKey({ nodes, edges }, meta);
    window.setTimeout(() => flow.fitView({ padding: 0.15, maxZoom: 1.1 }), 50);
  }, [flow]);

  useEffect(() => {
    (async () => {
      const [blocks, rob, running, pv] = await Promise.all([api.blocks(), api.robot(), api.program(), api.previz()]);
      const cat = Object.fromEntries(blocks.map((b) => [b.type, b]));
      setCatalog(cat);
      setRobot(rob);
      setPreviz(pv);
      if (running.program) loadProgram(running.program, cat, true);
      setReport(running.report);
      api.list("programs").then(setLibrary).catch(() => {});
      api.list("clips").then(setClips).catch(() => {});
      api.inputs().then((r) => setInputs({ decls: r.declarations, values: r.values })).catch(() => {});
    })().catch((e) => say(`cannot reach the server: ${e}`));
  }, [loadProgram, say]);

  // --- server sync: every structural edit is validated and hot-swapped ----------------------------------
  const errorsByNode = useMemo(() => {
    const out: Record<string, string[]> = {};
    for (const e of report?.errors ?? []) if (e.node) (out[e.node] ??= []).push(`${e.port ? e.port + ": " : ""}${e.message}`);
    return out;
  }, [report]);

  useEffect(() => {
    if (!meta) return;
    const key = structureKey(graph, meta);
    if (key === serverKey.current) return;
    const timer = window.setTimeout(async () => {
      const program = flowToProgram(graph.nodes, graph.edges, meta);
      setSyncing(true);
      try {
        const res = await api.putProgram(program);
        serverKey.current = key;
        setReport(res.report);
        api.inputs().then((r) => setInputs({ decls: r.declarations, values: r.values })).catch(() => {});
      } catch (e) {
        // the report now describes this graph (the robot keeps the last valid program)
        if (e instanceof ApiError && e.detail?.report) { serverKey.current = key; setReport(e.detail.report); }
        else say(String(e));
      } finally {
        setSyncing(false);
      }
    }, 90);
    return () => window.clearTimeout(timer);
  }, [graph, meta, say]);

  // --- telemetry ------------------------------------------------------------------------------------------
  const signalList = useMemo(
    () => graph.nodes.flatMap((n) => Object.keys(n.data.outputs).map((port) => ({ node: n.id, port }))),
    [graph.nodes],
  );
  const wsRef = useRef<WebSocket | null>(null);
  useEffect(() => {
    let closed = false;
    const connect = () => {
      const ws = new WebSocket(wsUrl("/ws/telemetry"));
      wsRef.current = ws;
      ws.onopen = () => ws.send(JSON.stringify({ type: "subscribe", signals: signalList, frames: true, rate: TELEMETRY_HZ }));
      ws.onmessage = (ev) => {
        const msg = JSON.parse(ev.data);
        if (msg.type !== "telemetry") return;
        setLive((prev) => {
          const history = { ...prev.history };
          for (const [k, v] of Object.entries(msg.signals ?? {})) {
            const num = typeof v === "number" ? v : v && typeof v === "object" && "values" in (v as any)
              ? (Object.values((v as any).values)[0] as number | undefined) : undefined;
            if (typeof num === "number") history[k] = [...(history[k] ?? []).slice(-59), num];
          }
          return { values: msg.signals ?? {}, history, layers: msg.layers ?? {} };
        });
        if (msg.frame) {
          setSamples((prev) => {
            const keep = CURVE_SECONDS * TELEMETRY_HZ;
            const final = { ...prev.final }, stage1 = { ...prev.stage1 };
            for (const [k, v] of Object.entries(msg.frame.position as Record<string, number>)) final[k] = [...(final[k] ?? []).slice(-keep + 1), v];
            for (const [k, v] of Object.entries(msg.frame.stage1 as Record<string, number>)) stage1[k] = [...(stage1[k] ?? []).slice(-keep + 1), v];
            return { t: [...prev.t.slice(-keep + 1), msg.t], final, stage1, classes: [...prev.classes.slice(-keep + 1), msg.frame.classes ?? {}] };
          });
        }
      };
      ws.onclose = () => { if (!closed) window.setTimeout(connect, 1000); };
    };
    connect();
    return () => { closed = true; wsRef.current?.close(); };
  }, []);
  useEffect(() => {
    const ws = wsRef.current;
    if (ws && ws.readyState === WebSocket.OPEN) ws.send(JSON.stringify({ type: "subscribe", signals: signalList, frames: true, rate: TELEMETRY_HZ }));
  }, [signalList]);

  // --- command console ----------------------------------------------------------------------------------------
  const controlRef = useRef<WebSocket | null>(null);
  useEffect(() => {
    const ws = new WebSocket(wsUrl("/ws/control"));
    controlRef.current = ws;
    ws.onmessage = (ev) => {
      const m = JSON.parse(ev.data);
      if (m.type === "event") log(`event ${m.event}${m.command ? " " + m.command : ""}${m.id ? " #" + m.id : ""}${m.node ? " @" + m.node : ""}`);
      else if (m.type === "ack") log(`ack #${m.id} ${m.status}`);
      else if (m.type === "error") log(`error ${m.code}: ${m.message}`);
    };
    return () => ws.close();
  }, [log]);
  const sendCommand = useCallback((cmd: Record<string, unknown>) => {
    const ws = controlRef.current;
    log(`> ${JSON.stringify(cmd)}`);
    if (ws && ws.readyState === WebSocket.OPEN) ws.send(JSON.stringify(cmd));
    else api.command(cmd).catch((e) => log(`error ${e}`));
  }, [log]);

  // --- editing -------------------------------------------------------------------------------------------------
  const commit = useCallback((next: Graph) => { setHist((h) => H.push(h, next)); setDirty(true); }, []);
  const withErrors = useMemo(() => graph.nodes.map((n) => (
    (errorsByNode[n.id]?.length ?? 0) === n.data.errors.length && (errorsByNode[n.id] ?? []).every((e, i) => e === n.data.errors[i])
      ? n : { ...n, data: { ...n.data, errors: errorsByNode[n.id] ?? [] } }
  )), [graph.nodes, errorsByNode]);

  const onNodesChange = useCallback((changes: NodeChange[]) => {
    setHist((h) => {
      const nodes = applyNodeChanges(changes, h.present.nodes as any) as unknown as FlowNode[];
      const removed = changes.filter((c) => c.type === "remove").map((c: any) => c.id);
      const edges = removed.length ? h.present.edges.filter((e) => !removed.includes(e.source) && !removed.includes(e.target)) : h.present.edges;
      const next = { nodes, edges };
      const meaningful = changes.some((c) => c.type === "remove" || (c.type === "position" && c.dragging === false));
      if (meaningful) setDirty(true);
      return meaningful ? H.push(h, next) : H.replace(h, next);
    });
  }, []);
  const onEdgesChange = useCallback((changes: EdgeChange[]) => {
    setHist((h) => {
      const edges = applyEdgeChanges(changes, h.present.edges as any) as unknown as FlowEdge[];
      const meaningful = changes.some((c) => c.type === "remove");
      if (meaningful) setDirty(true);
      return meaningful ? H.push(h, { ...h.present, edges }) : H.replace(h, { ...h.present, edges });
    });
  }, []);
  const onConnect = useCallback((c: Connection) => {
    const problem = connectionProblem(graph.nodes, graph.edges, c.source!, c.sourceHandle!, c.target!, c.targetHandle!);
    if (problem) { say(`refused: ${problem}`); return; }
    const src = graph.nodes.find((n) => n.id === c.source)!;
    const fe = { source: c.source!, sourceHandle: c.sourceHandle!, target: c.target!, targetHandle: c.targetHandle! };
    commit({ ...graph, edges: [...graph.edges, { ...fe, id: edgeId(fe), data: { type: src.data.outputs[c.sourceHandle!].type } }] });
  }, [graph, commit, say]);
  const lastProblem = useRef<string | null>(null);
  const isValidConnection = useCallback((c: any) => {
    const problem = connectionProblem(graph.nodes, graph.edges, c.source, c.sourceHandle, c.target, c.targetHandle);
    lastProblem.current = problem;
    return problem === null;
  }, [graph]);
  const onConnectEnd = useCallback((_: unknown, state: any) => {
    // dropped on a port that refused the wire: say why
    if (state && state.isValid === false && state.toHandle && lastProblem.current) say(`refused: ${lastProblem.current}`);
  }, [say]);

  const addBlock = useCallback((type: string, position?: { x: number; y: number }) => {
    const entry = catalog[type];
    if (!entry) return;
    if (type === "output" && graph.nodes.some((n) => n.data.type === "output")) { say("a program has exactly one output"); return; }
    const params = defaultParams(entry);
    const id = freshId(graph.nodes, type);
    const { inputs, outputs } = portsOf(entry, params);
    const pos = position ?? flow.screenToFlowPosition({ x: window.innerWidth * 0.4, y: window.innerHeight * 0.3 });
    // never drop a new block exactly on top of another one
    while (graph.nodes.some((n) => Math.abs(n.position.x - pos.x) < 240 && Math.abs(n.position.y - pos.y) < 140)) pos.y += 150;
    const node: FlowNode = { id, type: "block", position: pos, data: { type, params, ui: {}, inputs, outputs, errors: [] }, selected: true };
    commit({ nodes: [...graph.nodes.map((n) => ({ ...n, selected: false })), node], edges: graph.edges });
  }, [catalog, graph, commit, flow, say]);

  const onParams = useCallback(async (id: string, params: Record<string, unknown>, liveEdit: boolean) => {
    const node = graph.nodes.find((n) => n.id === id);
    if (!node) return;
    const clean = Object.fromEntries(Object.entries(params).filter(([, v]) => v !== null && v !== undefined));
    const { inputs, outputs } = portsOf(catalog[node.data.type], clean);
    const next = { ...graph, nodes: graph.nodes.map((n) => (n.id === id ? { ...n, data: { ...n.data, params: clean, inputs, outputs } } : n)) };
    const key = `${id}`;
    const now = performance.now();
    const coalesce = lastParamEdit.current?.key === key && now - lastParamEdit.current.at < 600;
    lastParamEdit.current = { key, at: now };
    setHist((h) => (coalesce ? H.replace(h, next) : H.push(h, next)));
    setDirty(true);
    const structural = JSON.stringify(inputs) !== JSON.stringify(node.data.inputs) || JSON.stringify(outputs) !== JSON.stringify(node.data.outputs);
    if (liveEdit && !structural && report?.valid) {
      try {
        await api.patchParams(id, clean);  // live: applied at the next tick, nothing rebuilt
        serverKey.current = structureKey(next, meta);
      } catch (e) {
        if (e instanceof ApiError && e.detail?.report) setReport({ ...e.detail.report, valid: false });
      }
    }
  }, [graph, catalog, report, meta]);

  const undo = useCallback(() => setHist((h) => H.undo(h)), []);
  const redo = useCallback(() => setHist((h) => H.redo(h)), []);
  const copy = useCallback(() => {
    const sel = graph.nodes.filter((n) => n.selected);
    const ids = new Set(sel.map((n) => n.id));
    clipboard.current = { nodes: sel, edges: graph.edges.filter((e) => ids.has(e.source) && ids.has(e.target)) };
  }, [graph]);
  const paste = useCallback(() => {
    if (!clipboard.current?.nodes.length) return;
    const pasted = pasteClipboard(graph.nodes, clipboard.current);
    commit({ nodes: [...graph.nodes.map((n) => ({ ...n, selected: false })), ...pasted.nodes], edges: [...graph.edges, ...pasted.edges] });
  }, [graph, commit]);

  // --- files and library ---------------------------------------------------------------------------------------
  const currentProgram = useCallback(() => flowToProgram(graph.nodes, graph.edges, meta!), [graph, meta]);
  const save = useCallback(async (asName?: string) => {
    const name = asName ?? libName ?? window.prompt("Save program as", meta?.name?.replace(/[^A-Za-z0-9_.-]+/g, "_") ?? "program");
    if (!name) return;
    try {
      await api.saveProgram(name, currentProgram());
      setLibName(name);
      setDirty(false);
      setLibrary(await api.list("programs"));
      say(`saved '${name}'`);
    } catch (e) {
      say(e instanceof ApiError ? `not saved: ${e.detail?.message ?? e.message}` : String(e));
    }
  }, [libName, meta, currentProgram, say]);
  const open = useCallback(async (name: string) => {
    if (dirty && !window.confirm("Discard unsaved changes?")) return;
    const p = await api.getProgram(name);
    loadProgram(p, catalog, false);
    setLibName(name);
    setDirty(false);
  }, [dirty, catalog, loadProgram]);
  const newProgram = useCallback(() => {
    if (dirty && !window.confirm("Discard unsaved changes?")) return;
    loadProgram({ format: "nutty-program/1", name: "untitled", max_level: 3, inputs: [], ui: {},
      nodes: [{ id: "rest", type: "rest_pose", params: {}, ui: { x: 0, y: 0 } }, { id: "output", type: "output", params: {}, ui: { x: 300, y: 0 } }],
      edges: [{ from: { node: "rest", port: "out" }, to: { node: "output", port: "in" } }] } as any, catalog, false);
    setLibName(null);
  }, [dirty, catalog, loadProgram]);
  const exportJson = useCallback(() => {
    const blob = new Blob([JSON.stringify(currentProgram(), null, 2)], { type: "application/json" });
    const a = document.createElement("a");
    a.href = URL.createObjectURL(blob);
    a.download = `${meta?.name ?? "program"}.json`;
    a.click();
  }, [currentProgram, meta]);
  const importJson = useCallback(async (file: File) => {
    try {
      const p = JSON.parse(await file.text());
      const rep = await api.validate(p);
      if (!rep.valid) say(`imported with ${rep.errors.length} error(s): they are shown on the nodes`);
      loadProgram(p, catalog, false);
      setReport(rep);
    } catch (e) {
      say(`cannot import: ${e}`);
    }
  }, [catalog, loadProgram, say]);

  useEffect(() => {
    const warn = (e: BeforeUnloadEvent) => { if (dirty) { e.preventDefault(); e.returnValue = ""; } };
    window.addEventListener("beforeunload", warn);
    return () => window.removeEventListener("beforeunload", warn);
  }, [dirty]);

  useEffect(() => {
    const onKey = (e: KeyboardEvent) => {
      const target = e.target as HTMLElement;
      if (target && ["INPUT", "TEXTAREA", "SELECT"].includes(target.tagName)) return;
      const mod = e.ctrlKey || e.metaKey;
      if (mod && e.key.toLowerCase() === "z") { e.preventDefault(); e.shiftKey ? redo() : undo(); }
      else if (mod && e.key.toLowerCase() === "y") { e.preventDefault(); redo(); }
      else if (mod && e.key.toLowerCase() === "c") copy();
      else if (mod && e.key.toLowerCase() === "v") paste();
      else if (mod && e.key.toLowerCase() === "s") { e.preventDefault(); save(); }
      else if (e.key === "f" && !mod) flow.fitView({ padding: 0.15, maxZoom: 1.1 });
    };
    window.addEventListener("keydown", onKey);
    return () => window.removeEventListener("keydown", onKey);
  }, [undo, redo, copy, paste, save, flow]);

  const liveWithActions = useMemo(() => ({
    ...live, setLayer: (mixer: string, layer: string, active: boolean) => sendCommand({ type: "set_layer", mixer, layer, active }),
  }), [live, sendCommand]);
  const selected = graph.nodes.find((n) => n.selected) ?? null;
  const continuous = robot?.dofs.filter((d) => d.type === "continuous").map((d) => d.name) ?? [];
  const status = !report ? "…" : report.valid
    ? `valid · level ${report.level}${report.warnings.length ? ` · ${report.warnings.length} warning(s)` : ""}`
    : `${report.errors.length} error(s) — the robot keeps the last valid program`;

  return (
    <CatalogContext.Provider value={catalog}>
    <LiveContext.Provider value={liveWithActions}>
    <div className="app">
      <header className="topbar">
        <span className="logo">Nutty</span>
        <input className="prog-name" aria-label="program name" value={meta?.name ?? ""} onChange={(e) => meta && (setMeta({ ...meta, name: e.target.value }), setDirty(true))} />
        {dirty && <span className="dirty" title="unsaved changes">●</span>}
        <span className={`status ${report?.valid ? "ok" : "bad"}`} data-testid="status">{syncing ? "syncing…" : status}</span>
        <span className="spacer" />
        <button onClick={newProgram}>New</button>
        <select aria-label="open program" value="" onChange={(e) => e.target.value && open(e.target.value)}>
          <option value="">Open…</option>
          {library.map((p) => <option key={p} value={p}>{p}</option>)}
        </select>
        <button onClick={() => save()} data-testid="save">Save</button>
        <button onClick={() => { const n = window.prompt("Save as"); if (n) save(n); }}>Save as</button>
        <label className="button">Import<input type="file" accept=".json" hidden onChange={(e) => e.target.files?.[0] && importJson(e.target.files[0])} /></label>
        <button onClick={exportJson}>Export</button>
        <button onClick={undo} disabled={!hist.past.length} data-testid="undo" title="Ctrl+Z">Undo</button>
        <button onClick={redo} disabled={!hist.future.length} data-testid="redo" title="Ctrl+Shift+Z">Redo</button>
        <button onClick={() => flow.fitView({ padding: 0.15, maxZoom: 1.1 })} title="F">Fit</button>
      </header>
      <aside className="left"><Palette onAdd={(t) => addBlock(t)} /></aside>
      <main className="graph" onDragOver={(e) => e.preventDefault()}
            onDrop={(e) => { const t = e.dataTransfer.getData("application/nutty-block"); if (t) addBlock(t, flow.screenToFlowPosition({ x: e.clientX, y: e.clientY })); }}>
        <ReactFlow nodes={withErrors as any} edges={graph.edges.map((e) => ({ ...e, style: { stroke: PORT_COLOURS[e.data?.type ?? "frame"], strokeWidth: e.data?.type === "frame" ? 2.5 : 1.5 } })) as any}
                   nodeTypes={nodeTypes as any} onNodesChange={onNodesChange} onEdgesChange={onEdgesChange} onConnect={onConnect}
                   onConnectEnd={onConnectEnd as any} isValidConnection={isValidConnection} deleteKeyCode={["Delete", "Backspace"]} multiSelectionKeyCode="Shift"
                   minZoom={0.2} fitView fitViewOptions={{ padding: 0.15, maxZoom: 1.1 }} proOptions={{ hideAttribution: true }}>
          <Background color="#2b313b" gap={22} />
          <MiniMap pannable zoomable nodeColor="#3a4150" maskColor="rgba(10,12,16,0.6)" style={{ width: 180, height: 110 }} />
        </ReactFlow>
        {toast && <div className="toast" role="alert" data-testid="toast">{toast}</div>}
      </main>
      <aside className="right">
        <ParamPanel node={selected} robot={robot} clips={clips} errors={selected ? errorsByNode[selected.id] ?? [] : []} onChange={onParams} />
      </aside>
      <section className="bottom">
        <div className="previz">
          <div className="previz-head">
            <span>Pre-Viz</span>
            <label><input type="checkbox" checked={previz.ghost ?? false} disabled={previz.url === null}
                          onChange={(e) => api.ghost(e.target.checked).then(() => setPreviz({ ...previz, ghost: e.target.checked }))} /> ghost</label>
          </div>
          {previz.url ? <iframe title="Pre-Viz" src={previz.url} /> : <div className="muted pad">Pre-Viz disabled on this server.</div>}
        </div>
        <div className="livecol">
          <CurvePanel samples={samples} dof={curveDof} info={robot?.dofs.find((d) => d.name === curveDof)} rate={TELEMETRY_HZ}
                      onDof={setCurveDof} dofs={continuous} />
          <div className="controls-strip" data-testid="controls">
            {inputs.decls.map((d) => (
              <InputControl key={d.name} decl={d} value={inputs.values[d.name]}
                            onSet={(v) => { setInputs((s) => ({ ...s, values: { ...s.values, [d.name]: v } })); api.setInput(d.name, v).catch((e) => log(`error ${e}`)); }} />
            ))}
            <div className="buttons">
              {(robot?.postures ?? []).map((p) => <button key={p} onClick={() => sendCommand({ type: "go_posture", posture: p })}>{p}</button>)}
              {clips.map((c) => <button key={c} onClick={() => sendCommand({ type: "play_clip", clip: c, layer: "gesture" })}>▶ {c}</button>)}
              <button onClick={() => sendCommand({ type: "say", text: "Hello!" })}>say hello</button>
              <button onClick={() => sendCommand({ type: "reset" })}>reset</button>
            </div>
          </div>
          <pre className="console" data-testid="console">{consoleLines.slice(-40).join("\n")}</pre>
        </div>
      </section>
    </div>
    </LiveContext.Provider>
    </CatalogContext.Provider>
  );
}

function InputControl({ decl, value, onSet }: { decl: any; value: any; onSet: (v: any) => void }) {
  if (decl.type === "vec3") {
    const v = Array.isArray(value) ? value : decl.default ?? [1, 0, 0.3];
    return (
      <div className="gaze-pad" title="drag to set the gaze target (top view: x forward, y left)"
           onMouseDown={(e) => {
             const box = (e.currentTarget as HTMLDivElement).getBoundingClientRect();
             const set = (ev: MouseEvent | React.MouseEvent) => {
               const x = 1.2 - ((ev.clientY - box.top) / box.height) * 1.2;
               const y = 0.8 - ((ev.clientX - box.left) / box.width) * 1.6;
               onSet([Math.round(x * 100) / 100, Math.round(y * 100) / 100, v[2]]);
             };
             set(e);
             const move = (ev: MouseEvent) => set(ev);
             const up = () => { window.removeEventListener("mousemove", move); window.removeEventListener("mouseup", up); };
             window.addEventListener("mousemove", move);
             window.addEventListener("mouseup", up);
           }}>
        <span className="pad-label">{decl.name}</span>
        <span className="pad-dot" style={{ top: `${(1 - v[0] / 1.2) * 100}%`, left: `${((0.8 - v[1]) / 1.6) * 100}%` }} />
      </div>
    );
  }
  if (decl.type === "float" || decl.type === "int") {
    const min = decl.min ?? -1, max = decl.max ?? 1;
    return (
      <label className="input-slider">
        <span>{decl.name}</span>
        <input type="range" min={min} max={max} step={decl.type === "int" ? 1 : (max - min) / 200} value={Number(value ?? decl.default ?? 0)}
               aria-label={`input ${decl.name}`} onChange={(e) => onSet(Number(e.target.value))} />
        <span className="num">{Number(value ?? 0).toFixed(2)}</span>
      </label>
    );
  }
  if (decl.type === "bool") return <label><input type="checkbox" checked={Boolean(value)} onChange={(e) => onSet(e.target.checked)} /> {decl.name}</label>;
  return null;
}

export function App() {
  return (
    <ReactFlowProvider>
      <Editor />
    </ReactFlowProvider>
  );
}
