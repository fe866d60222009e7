// Values on wires: hovering a wire shows its source port's live value (a tooltip with a pin button;
// double-clicking the wire pins it too); a pinned wire gets a probe, a small live plot of the last seconds with min/max/last, anchored at the
// wire's midpoint (it follows pan and zoom); several can be pinned, × unpins. Frame wires show their
// DoF count and first DoFs. Also the canvas's live bar: the warning count (a click frames the first
// node concerned) and the cook-time heat toggle.
import { Panel, useInternalNode, useViewport, type Edge } from "@xyflow/react";
import { useContext, useEffect, useMemo, useState, useSyncExternalStore } from "react";
import type { SignalRef } from "../api";
import { LiveContext } from "../context";
import type { FlowEdge } from "../graph";
import { useEditor } from "../store/EditorStore";
import { useFocusNode } from "./focus";
import { wireMenuExtras } from "../canvasMenus";
import { getLiveUi, pinProbe, setHeat, unpinProbe, useLiveUi } from "./liveUi";
import { cookText, firstWarnedNode, isFrame, plotted, signed, stats, summarise } from "./logic";

const PROBE_SECONDS = 3;
const LEAVE_MS = 350;  // time to reach the tooltip's pin button after leaving the wire
/** The wire tooltip's offset from the pointer (screen px), and how far the pointer moves along a wire
 * before the tooltip follows it. */
const TOOLTIP_OFFSET = 8;
const TOOLTIP_FOLLOW_PX = 3;
/** A probe's plot: its size, and the margin keeping its line off the top and bottom edges. */
const PLOT = { width: 168, height: 44, inset: 3 };

// ---- hover state (outside React: the graph view does not re-render on a hover) -----------------

interface Hover { edge: string; x: number; y: number }
let hover: Hover | null = null;
let leaveTimer: number | undefined;
const hoverListeners = new Set<() => void>();
function setHover(h: Hover | null) {
  hover = h;
  for (const l of hoverListeners) l();
}
function keepHover() { window.clearTimeout(leaveTimer); }
function dropHoverSoon() {
  window.clearTimeout(leaveTimer);
  leaveTimer = window.setTimeout(() => setHover(null), LEAVE_MS);
}
function useHover(): Hover | null {
  return useSyncExternalStore((l) => { hoverListeners.add(l); return () => hoverListeners.delete(l); }, () => hover);
}

function localPoint(ev: React.MouseEvent): { x: number; y: number } {
  const box = (ev.currentTarget as Element).closest(".react-flow")?.getBoundingClientRect();
  return { x: ev.clientX - (box?.left ?? 0), y: ev.clientY - (box?.top ?? 0) };
}

// A wire's context menu pins and unpins its probe (a double-click on a wire adds a reroute point).
wireMenuExtras.push(
  { label: "Add a probe", when: (e) => !getLiveUi().probes.includes(e.id), run: (e) => pinProbe(e.id) },
  { label: "Remove the probe", when: (e) => getLiveUi().probes.includes(e.id), run: (e) => unpinProbe(e.id) },
);

/** React Flow's edge-hover props for the graph view. */
export const wireHoverHandlers = {
  onEdgeMouseEnter: (ev: React.MouseEvent, edge: Edge) => { keepHover(); setHover({ edge: edge.id, ...localPoint(ev) }); },
  onEdgeMouseMove: (ev: React.MouseEvent, edge: Edge) => {
    keepHover();
    if (hover?.edge !== edge.id || Math.hypot(hover.x - localPoint(ev).x, hover.y - localPoint(ev).y) > TOOLTIP_FOLLOW_PX) setHover({ edge: edge.id, ...localPoint(ev) });
  },
  onEdgeMouseLeave: () => dropHoverSoon(),
};

const signalOf = (e: FlowEdge) => `${e.source}.${e.sourceHandle}`;

/** The signals the wire overlays watch (the hovered wire's source, the probes'), first in the telemetry
 * subscription so that the server's signal cap never leaves them out. */
export function useWatchedSignals(edges: FlowEdge[]): SignalRef[] {
  const h = useHover();
  const { probes } = useLiveUi();
  const ids = [...probes, ...(h ? [h.edge] : [])];
  const key = ids.join("|") + "#" + edges.length;
  return useMemo(() => {
    const out: SignalRef[] = [];
    for (const id of ids) {
      const e = edges.find((x) => x.id === id);
      if (e && !out.some((s) => s.node === e.source && s.port === e.sourceHandle)) out.push({ node: e.source, port: e.sourceHandle });
    }
    return out;
  }, [key]);  // eslint-disable-line react-hooks/exhaustive-deps -- new only when the watched wires or the number of wires change (`key`): no resubscription otherwise
}

function WireTooltip({ edges }: { edges: FlowEdge[] }) {
  const h = useHover();
  const live = useContext(LiveContext);
  const { probes } = useLiveUi();
  const edge = h ? edges.find((e) => e.id === h.edge) : undefined;
  if (!h || !edge) return null;
  const value = live.values[signalOf(edge)];
  return (
    <div className="wire-tip nodrag nopan" data-testid="wire-tooltip" style={{ left: h.x + TOOLTIP_OFFSET, top: h.y + TOOLTIP_OFFSET }}
         onMouseEnter={keepHover} onMouseLeave={dropHoverSoon}>
      <div className="wire-tip-head">
        {!probes.includes(edge.id) && (
          <button className="pin" data-testid="wire-pin" title="pin a probe on this wire (or right-click the wire)"
                  onClick={() => { pinProbe(edge.id); setHover(null); }}>pin</button>
        )}
        <span>{edge.source}.{edge.sourceHandle} → {edge.target}.{edge.targetHandle}</span>
      </div>
      <div className="wire-tip-value" data-testid="wire-value">{summarise(value)}</div>
    </div>
  );
}

/** Where a wire's midpoint is on the canvas (flow coordinates), or null before its nodes are measured. */
function useWireMidpoint(edge: FlowEdge): { x: number; y: number } | null {
  const s = useInternalNode(edge.source);
  const t = useInternalNode(edge.target);
  const sh = s?.internals.handleBounds?.source?.find((h) => h.id === edge.sourceHandle);
  const th = t?.internals.handleBounds?.target?.find((h) => h.id === edge.targetHandle);
  if (!s || !t || !sh || !th) return null;
  const a = { x: s.internals.positionAbsolute.x + sh.x + sh.width / 2, y: s.internals.positionAbsolute.y + sh.y + sh.height / 2 };
  const b = { x: t.internals.positionAbsolute.x + th.x + th.width / 2, y: t.internals.positionAbsolute.y + th.y + th.height / 2 };
  // a default (bezier) edge's control points are symmetric: its midpoint is the endpoints' midpoint
  return { x: (a.x + b.x) / 2, y: (a.y + b.y) / 2 };
}

/** A probe's samples (the last PROBE_SECONDS of its wire's number) and the time of the last one taken. */
interface Trace { t: number; pts: { t: number; v: number }[] }
const NO_TRACE: Trace = { t: -1, pts: [] };

/** The trace with the sample `v` at time `t` (a stream that went back in time, restarted, starts afresh). */
function traced(trace: Trace, t: number, v: number): Trace {
  const last = trace.pts[trace.pts.length - 1];
  const kept = last && t < last.t ? [] : trace.pts;
  return { t, pts: [...kept, { t, v }].filter((p) => p.t >= t - PROBE_SECONDS) };
}

function Probe({ edge }: { edge: FlowEdge }) {
  const live = useContext(LiveContext);
  const { x: vx, y: vy, zoom } = useViewport();
  const mid = useWireMidpoint(edge);
  const [trace, setTrace] = useState(NO_TRACE);
  const value = live.values[signalOf(edge)];
  const num = plotted(value);
  // each new message adds its sample while rendering (React renders again at once with it): the trace is
  // this probe's own, derived from the stream it renders
  if (live.t !== trace.t && num !== undefined) setTrace(traced(trace, live.t, num));
  if (!mid) return null;
  const pts = trace.pts;
  const st = stats(pts.map((p) => p.v));
  const lo = st ? st.min : 0, hi = st ? st.max : 1;
  const span = hi - lo || 1;
  const t0 = live.t - PROBE_SECONDS;
  const { width: W, height: H, inset } = PLOT;
  const y = (v: number) => H - inset - ((v - lo) / span) * (H - 2 * inset);
  const line = pts.map((p) => `${(((p.t - t0) / PROBE_SECONDS) * W).toFixed(1)},${y(p.v).toFixed(1)}`).join(" ");
  const zeroY = lo < 0 && hi > 0 ? y(0) : null;
  return (
    <div className="probe nodrag nopan nowheel" data-testid={`probe-${edge.id}`} data-points={pts.length}
         data-last={st ? st.last : ""} style={{ left: mid.x * zoom + vx, top: mid.y * zoom + vy }}>
      <div className="probe-head">
        <span className="probe-name" title={`${edge.source}.${edge.sourceHandle} → ${edge.target}.${edge.targetHandle}`}>
          {edge.source}.{edge.sourceHandle}{isFrame(value) ? ` (${Object.keys(value.values)[0] ?? "–"})` : ""}
        </span>
        <button className="probe-close" data-testid="probe-close" title="unpin" onClick={() => unpinProbe(edge.id)}>×</button>
      </div>
      <svg width={W} height={H} className="probe-plot" aria-label={`probe of ${edge.source}.${edge.sourceHandle}`}>
        {zeroY !== null && <line x1={0} x2={W} y1={zeroY} y2={zeroY} className="probe-zero" />}
        {pts.length > 1 && <polyline points={line} fill="none" stroke="#8fd3ff" strokeWidth={1.3} />}
      </svg>
      <div className="probe-stats" data-testid="probe-stats">
        {st ? <>min {signed(st.min)} · max {signed(st.max)} · <b>{signed(st.last)}</b></> : <span>no number on this wire</span>}
      </div>
      {isFrame(value) && <div className="probe-frame">{summarise(value)}</div>}
    </div>
  );
}

export function WireOverlay({ edges }: { edges: FlowEdge[] }) {
  const { probes } = useLiveUi();
  const pinned = probes.map((id) => edges.find((e) => e.id === id)).filter((e): e is FlowEdge => !!e);
  useEffect(() => {  // a wire removed (an edit, another program) takes its probe with it
    if (!edges.length) return;
    const ids = new Set(edges.map((e) => e.id));
    probes.filter((p) => !ids.has(p)).forEach(unpinProbe);
  }, [edges, probes]);
  return (
    <>
      {pinned.map((e) => <Probe key={e.id} edge={e} />)}
      <WireTooltip edges={edges} />
      <LiveBar />
    </>
  );
}

/** The canvas's live bar: warnings (a click frames the first node concerned), heat on/off, tick time. */
function LiveBar() {
  const { report } = useEditor().state;
  const { heat } = useLiveUi();
  const { profile } = useContext(LiveContext);
  const focus = useFocusNode();
  const count = report?.warnings.length ?? 0;
  const first = firstWarnedNode(report);
  return (
    <Panel position="bottom-center" className="live-bar">
      {count > 0 && (
        <button className="warn-count" data-testid="warning-count" disabled={!first}
                title={report!.warnings.map((w) => `${w.node ?? "program"}: ${w.message}`).join("\n")}
                onClick={() => first && focus(first)}>⚠ {count} warning{count === 1 ? "" : "s"}</button>
      )}
      <label className="heat-toggle" title="colour nodes by their cook time (cool → hot)">
        <input type="checkbox" data-testid="heat-toggle" checked={heat} onChange={(e) => setHeat(e.target.checked)} /> heat
      </label>
      {profile && <span className="tick-time" title="the whole program's median cook time per tick">tick {cookText(profile.apu.p50_us)}</span>}
    </Panel>
  );
}
