// The canvas viewport: the level of detail of the blocks (collapsed titles grow as the zoom shrinks, so a
// block's name stays >= 11 px on screen at any zoom), the part of the graph a program opens on, and
// spots for new blocks in view: at the pointer, clear of the canvas's overlays.
import { useStore, type ReactFlowInstance } from "@xyflow/react";
import type { Catalog } from "./api";
import type { FlowEdge, FlowNode } from "./graph";
import { AT_POINTER, BLOCK_WIDTH, FALLBACK_CANVAS_SIZE } from "./layout/constants";

/** Below this zoom blocks collapse to an enlarged title and their ports (see .block.compact). */
export const LOD_ZOOM = 0.7;
/** Title sizes (px, at zoom 1) of a full and a collapsed block: 16 × 0.7 is ≥ 11 px; a collapsed title
 * is at least COMPACT_TITLE_PX and grows to READABLE_PX / zoom (styles.css reads --zoom). */
export const TITLE_PX = 16;
export const COMPACT_TITLE_PX = 28;
/** A block name's least size on screen (px; styles.css's .block.compact .block-title says it again). */
export const READABLE_PX = 11.5;
/** Below this zoom a collapsed title no longer fits in COMPACT_TITLE_PX. */
export const READABLE_ZOOM = READABLE_PX / COMPACT_TITLE_PX;
export const MAX_FIT_ZOOM = 1.1;
/** The zooms the canvas allows (wheel, buttons, minimap). */
export const CANVAS_MIN_ZOOM = 0.12;
export const CANVAS_MAX_ZOOM = 2.5;
const PADDING = 0.06;
/** Screen px along the canvas's edges that a framed view leaves to what floats over it (none: a view
 * framed a little smaller would cross the level of detail's zoom for programs that fit just above it). */
const FIT_INSETS = { top: 0, bottom: 0, left: 0, right: 0 };
/** Flow-space size of a block, for bounds of blocks not measured yet. */
const BLOCK = { width: BLOCK_WIDTH, height: 150 };
/** Blocks change size with the zoom (a collapsed title grows as it shrinks): a view is framed again this
 * long (ms) after it was framed, once they have been measured at the new zoom. */
const REFRAME_MS = 250;
/** A zoom just below another one (the level of detail's threshold). */
const ZOOM_STEP = 0.005;
/** At most this many framings after the first, each once the blocks have been measured at the last. */
const SETTLE_PASSES = 3;
/** Screen px that a program's output chain is kept inside the view's edges when it opens. */
const CHAIN_MARGIN = 40;
/** A free spot for a new block: inside the view's edges by this much (screen px), on rings around the
 * view's centre (this many, each a step across and down), this far from other blocks. */
const SPOT_INSET = 20;
const SPOT_RINGS = 12;
const SPOT_STEP = { x: BLOCK.width / 2 + 10, y: 80 };
const SPOT_CLEARANCE = { x: BLOCK.width + 10, y: 150 };
/** What floats over the canvas: a new block never lands under one of them. */
const OVERLAYS = ".graph .react-flow__minimap, .graph .canvas-controls, .graph .toast, .graph .subgraph-bar > *, .graph .live-bar";
/** Screen px a block put near the pointer keeps from an overlay it would have covered. */
const OVERLAY_GAP = 6;

/** Whether blocks are collapsed: re-renders a node only when the zoom crosses LOD_ZOOM. */
export function useCompact(): boolean {
  return useStore((s) => s.transform[2] < LOD_ZOOM);
}


type Rect = { x: number; y: number; width: number; height: number };
type Position = { x: number; y: number };

function boundsOf(flow: ReactFlowInstance, ids: Set<string>): Rect | null {
  const nodes = flow.getNodes().filter((n) => ids.has(n.id));
  if (!nodes.length) return null;
  let x0 = Infinity, y0 = Infinity, x1 = -Infinity, y1 = -Infinity;
  for (const n of nodes) {
    const w = n.measured?.width ?? BLOCK.width, h = n.measured?.height ?? BLOCK.height;
    x0 = Math.min(x0, n.position.x); y0 = Math.min(y0, n.position.y);
    x1 = Math.max(x1, n.position.x + w); y1 = Math.max(y1, n.position.y + h);
  }
  return { x: x0, y: y0, width: x1 - x0, height: y1 - y0 };
}

/** The canvas's size on screen (the React Flow pane). */
function paneSize(): { width: number; height: number } {
  const el = document.querySelector(".graph .react-flow");
  const r = el?.getBoundingClientRect();
  return { width: r?.width || FALLBACK_CANVAS_SIZE.width, height: r?.height || FALLBACK_CANVAS_SIZE.height };
}

function fitZoom(rect: Rect): number {
  const { width, height } = paneSize();
  const w = width - FIT_INSETS.left - FIT_INSETS.right, h = height - FIT_INSETS.top - FIT_INSETS.bottom;
  return Math.min(w / (rect.width * (1 + 2 * PADDING)), h / (rect.height * (1 + 2 * PADDING)));
}

/** Show the flow point (cx, cy) at the centre of the canvas at `zoom`. */
function centreOn(flow: ReactFlowInstance, cx: number, cy: number, zoom: number, duration = 0) {
  const { width, height } = paneSize();
  // the middle of the part of the canvas the overlays leave
  const mx = (FIT_INSETS.left + width - FIT_INSETS.right) / 2, my = (FIT_INSETS.top + height - FIT_INSETS.bottom) / 2;
  framed = { x: mx - cx * zoom, y: my - cy * zoom, zoom };
  flow.setViewport(framed, { duration });
}

/** The viewport the editor last framed: a second framing is for it only, not for one the user (or another
 * framing) has moved since. */
let framed = { x: 0, y: 0, zoom: 1 };

/** The last framing (opening, Fit), to run again when the canvas changes size under a view it framed. */
let lastFraming: (() => void) | null = null;

/** Whether the view is still where the editor framed it (nobody panned or zoomed since). */
function untouched(flow: ReactFlowInstance, mine = framed): boolean {
  const v = flow.getViewport();
  return mine === framed && Math.abs(v.x - mine.x) < 1 && Math.abs(v.y - mine.y) < 1 && Math.abs(v.zoom - mine.zoom) < 1e-3;
}

/** Frame again what was framed last when `canvas` changes size (panels folded, the bottom panels filling
 * in) while the view is as it was framed; returns the unsubscribe. */
export function refitOnResize(flow: ReactFlowInstance, canvas: HTMLElement): () => void {
  let size = "";
  const seen = new ResizeObserver(() => {
    const r = canvas.getBoundingClientRect(), now = `${Math.round(r.width)}x${Math.round(r.height)}`;
    if (size && now !== size && lastFraming && untouched(flow)) lastFraming();
    size = now;
  });
  seen.observe(canvas);
  return () => seen.disconnect();
}

type Tried = { full?: number; compact?: number };

/** After `ms`, while the view is still as framed and the blocks changed size since `before` (their
 * sizesKey then): `zoomNow()` is the zoom that fits them as now measured; frame at it (`apply`) and go on
 * until the level of detail it lands on is the one it was measured in. When neither fits (full blocks
 * need a zoom below the level of detail's, collapsed ones one above it), collapsed, just below it. */
function settle(flow: ReactFlowInstance, before: string, ms: number, zoomNow: () => number | null, apply: (zoom: number) => void,
  tried: Tried = {}, passes = SETTLE_PASSES) {
  const mine = framed;
  window.setTimeout(() => {
    if (!untouched(flow, mine) || sizesKey(flow) === before) return;
    const z = zoomNow();
    if (z === null) return;
    const full = flow.getViewport().zoom >= LOD_ZOOM;
    const seen = { ...tried, [full ? "full" : "compact"]: z };
    if (full ? z >= LOD_ZOOM : z < LOD_ZOOM) return apply(z);
    const neither = seen.full !== undefined && seen.full < LOD_ZOOM && seen.compact !== undefined && seen.compact >= LOD_ZOOM;
    if (neither || passes <= 1) return apply(Math.min(z, LOD_ZOOM - ZOOM_STEP));
    const now = sizesKey(flow);
    apply(z);
    settle(flow, now, REFRAME_MS, zoomNow, apply, seen, passes - 1);
  }, ms);
}

/** The zoom that shows `rect` whole, within [minZoom, maxZoom]. */
const fittingZoom = (rect: Rect, minZoom: number, maxZoom: number) => Math.max(minZoom, Math.min(maxZoom, fitZoom(rect)));

/** Frame what `target()` gives at its fitting zoom, then settle it (the blocks change size with the zoom). */
function frameSettled(flow: ReactFlowInstance, target: () => { rect: Rect; min: number; max: number } | null, duration = 0) {
  const before = sizesKey(flow);
  const t = target();
  if (!t) return;
  frame(flow, t.rect, t.min, t.max, duration);
  const centre = (r: Rect, zoom: number) => centreOn(flow, r.x + r.width / 2, r.y + r.height / 2, zoom);
  settle(flow, before, duration + REFRAME_MS, () => { const n = target(); return n && fittingZoom(n.rect, n.min, n.max); },
    (zoom) => { const n = target(); if (n) centre(n.rect, zoom); });
}

/** Frame `rect` at the largest zoom that shows it within [minZoom, maxZoom]; centred when it cannot fit. */
function frame(flow: ReactFlowInstance, rect: Rect, minZoom = READABLE_ZOOM, maxZoom = MAX_FIT_ZOOM, duration = 0) {
  centreOn(flow, rect.x + rect.width / 2, rect.y + rect.height / 2, fittingZoom(rect, minZoom, maxZoom), duration);
}

/** The chain the output is fed by: the output and its frame feeds back to the first block mixing several. */
export function outputChain(nodes: FlowNode[], edges: FlowEdge[], catalog: Catalog): string[] {
  let at = nodes.find((n) => catalog[n.data.type]?.role === "output")?.id;
  const chain: string[] = [];
  while (at && !chain.includes(at) && chain.length < 8) {
    chain.push(at);
    const feeds = edges.filter((e) => e.target === at && (e.data?.type ?? "frame") === "frame");
    if (feeds.length !== 1) break;
    at = feeds[0].source;
  }
  return chain;
}

/** The part of the graph a program opens on: all of it (collapsed names stay readable at any zoom) when it
 * fits at the canvas's least zoom; else the selection, or the output chain with the blocks feeding it,
 * keeping the chain (the output end) in view. */
export function frameOpening(flow: ReactFlowInstance, nodes: FlowNode[], edges: FlowEdge[], catalog: Catalog) {
  lastFraming = () => frameOpening(flow, nodes, edges, catalog);
  // every node the canvas draws (an open subgraph's Group Input / Output too)
  const all = () => boundsOf(flow, new Set(flow.getNodes().map((n) => n.id)));
  const whole = all();
  if (!whole) return;
  if (fitZoom(whole) < CANVAS_MIN_ZOOM) return frameLarge(flow, nodes, edges, catalog, whole);
  frameSettled(flow, () => { const rect = all(); return rect && { rect, min: CANVAS_MIN_ZOOM, max: MAX_FIT_ZOOM }; });
}

/** What a view's second framing depends on: whether blocks were collapsed (their size follows the zoom
 * then, or changed with the level of detail) and the nodes' measured sizes. A view is framed again only
 * when the blocks were or are collapsed and their sizes changed: never moving it, under a pointer already
 * at work, for a live value that widened a block. */
function sizesKey(flow: ReactFlowInstance): string {
  if (flow.getViewport().zoom >= LOD_ZOOM) return "full";
  return flow.getNodes().map((n) => `${n.id}:${Math.round(n.measured?.width ?? 0)}x${Math.round(n.measured?.height ?? 0)}`).join(",");
}

/** A program too large to show whole: the selection, or the output chain with the blocks feeding it. */
function frameLarge(flow: ReactFlowInstance, nodes: FlowNode[], edges: FlowEdge[], catalog: Catalog, all: Rect) {
  const selected = nodes.filter((n) => n.selected).map((n) => n.id);
  if (selected.length) return frame(flow, boundsOf(flow, new Set(selected)) ?? all);
  const chain = outputChain(nodes, edges, catalog);
  const core = boundsOf(flow, new Set(chain));
  if (!core) return frame(flow, all);
  const feeds = new Set([...chain, ...edges.filter((e) => chain.includes(e.target)).map((e) => e.source)]);
  const near = boundsOf(flow, feeds) ?? core;
  const zoom = Math.max(READABLE_ZOOM, Math.min(MAX_FIT_ZOOM, fitZoom(near)));
  const { width, height } = paneSize();
  const halfW = width / 2 / zoom, halfH = height / 2 / zoom, margin = CHAIN_MARGIN / zoom;
  // centre on the neighbourhood, moved so that the chain stays in view (its output end, its top first)
  const keep = (c: number, lo: number, hi: number, otherwise: number) => (lo <= hi ? Math.min(hi, Math.max(lo, c)) : otherwise);
  const xLo = core.x + core.width + margin - halfW, xHi = core.x - margin + halfW;
  const yLo = core.y + core.height + margin - halfH, yHi = core.y - margin + halfH;
  const cx = keep(near.x + near.width / 2, xLo, xHi, xLo);
  const cy = keep(near.y + near.height / 2, yLo, yHi, yHi);
  centreOn(flow, cx, cy, zoom);
}

/** Fit: the whole graph (names stay readable at any zoom); with a selection, frame it close enough to see
 * its values (like Blender's View Selected). */
export function fitReadable(flow: ReactFlowInstance, duration = 200) {
  lastFraming = () => fitReadable(flow, 0);
  frameSettled(flow, () => {
    const nodes = flow.getNodes();
    const selected = nodes.filter((n) => n.selected);
    const rect = boundsOf(flow, new Set((selected.length ? selected : nodes).map((n) => n.id)));
    // a selection is framed full, its values shown
    return rect && { rect, min: selected.length ? LOD_ZOOM : CANVAS_MIN_ZOOM, max: MAX_FIT_ZOOM };
  }, duration);
}

/** The size (flow px) of a group of nodes' bounds, measured where they have been drawn. */
export function sizeOf(nodes: FlowNode[]): { width: number; height: number } {
  if (!nodes.length) return BLOCK;
  const x0 = Math.min(...nodes.map((n) => n.position.x)), y0 = Math.min(...nodes.map((n) => n.position.y));
  const x1 = Math.max(...nodes.map((n) => n.position.x + (n.measured?.width ?? BLOCK.width)));
  const y1 = Math.max(...nodes.map((n) => n.position.y + (n.measured?.height ?? BLOCK.height)));
  return { width: x1 - x0, height: y1 - y0 };
}

/** Where the pointer was last seen (client px), and whether it was over the canvas. */
const pointer = { x: 0, y: 0, inside: false };

/** Follow the pointer over `canvas` (for new blocks and pastes at the pointer); returns the unsubscribe. */
export function trackPointer(canvas: HTMLElement): () => void {
  const move = (e: PointerEvent) => {
    const r = canvas.getBoundingClientRect();
    Object.assign(pointer, { x: e.clientX, y: e.clientY, inside: e.clientX >= r.left && e.clientX <= r.right && e.clientY >= r.top && e.clientY <= r.bottom });
  };
  const leave = () => { pointer.inside = false; };
  window.addEventListener("pointermove", move, true);
  canvas.addEventListener("pointerleave", leave);
  return () => { window.removeEventListener("pointermove", move, true); canvas.removeEventListener("pointerleave", leave); };
}

type Box = { left: number; top: number; right: number; bottom: number };
const overlaps = (a: Box, b: Box) => a.left < b.right && b.left < a.right && a.top < b.bottom && b.top < a.bottom;

/** The canvas's visible part for new blocks (screen px), the overlays on it, and a test of whether a block
 * of `size` at a flow position is inside that part and clear of every overlay. */
function placing(flow: ReactFlowInstance, size: { width: number; height: number }) {
  const el = document.querySelector(".graph .react-flow");
  const r = el?.getBoundingClientRect() ?? { left: 0, top: 0, width: window.innerWidth, height: window.innerHeight };
  const zoom = flow.getViewport().zoom;
  const covers = [...document.querySelectorAll(OVERLAYS)].map((o) => o.getBoundingClientRect());
  const view = { left: r.left + SPOT_INSET, top: r.top + SPOT_INSET, right: r.left + r.width - SPOT_INSET, bottom: r.top + r.height - SPOT_INSET };
  const clear = (x: number, y: number) => {
    const s = flow.flowToScreenPosition({ x, y });
    const box = { left: s.x, top: s.y, right: s.x + size.width * zoom, bottom: s.y + size.height * zoom };
    return box.left >= view.left && box.top >= view.top && box.right <= view.right && box.bottom <= view.bottom
      && !covers.some((c) => overlaps(box, c));
  };
  const a = flow.screenToFlowPosition({ x: view.left, y: view.top });
  const b = flow.screenToFlowPosition({ x: view.right, y: view.bottom });
  return { zoom, covers, clear, a, b };
}

/** The nearest spot to flow position `at` (a block's top-left corner) where a block of `size` is in view
 * and clear of the canvas's overlays: moved into view, then just past any overlay it would cover; null
 * when none of those moves clears it. */
export function clearSpot(flow: ReactFlowInstance, at: Position, size: { width: number; height: number } = BLOCK): Position | null {
  const { zoom, covers, clear, a, b } = placing(flow, size);
  const into = (v: number, lo: number, hi: number) => Math.max(lo, Math.min(hi, v));
  const cx = into(at.x, a.x, b.x - size.width), cy = into(at.y, a.y, b.y - size.height);
  const w = size.width * zoom, h = size.height * zoom, s = flow.flowToScreenPosition({ x: cx, y: cy });
  const shifts = covers.flatMap((c) => [[0, c.top - OVERLAY_GAP - (s.y + h)], [0, c.bottom + OVERLAY_GAP - s.y],
    [c.left - OVERLAY_GAP - (s.x + w), 0], [c.right + OVERLAY_GAP - s.x, 0]]);
  return [[0, 0], ...shifts].sort((p, q) => Math.hypot(p[0], p[1]) - Math.hypot(q[0], q[1]))
    .map(([dx, dy]) => ({ x: cx + dx / zoom, y: cy + dy / zoom })).find((p) => clear(p.x, p.y)) ?? null;
}

/** A spot for a new block (or a pasted group of `size`, flow px), flow coordinates: at the pointer when it
 * is over the canvas and the block fits there, else a free spot in the visible part of the canvas; never
 * under the minimap, the canvas's buttons, a toast or the subgraph bar. */
export function visibleSpot(flow: ReactFlowInstance, nodes: FlowNode[], size: { width: number; height: number } = BLOCK): Position {
  if (pointer.inside) {
    const at = flow.screenToFlowPosition({ x: pointer.x, y: pointer.y });
    const spot = clearSpot(flow, { x: at.x + AT_POINTER.x, y: at.y + AT_POINTER.y }, size);
    if (spot) return spot;
  }
  const { clear, a, b } = placing(flow, size);
  const cx = (a.x + b.x) / 2 - size.width / 2, cy = (a.y + b.y) / 2 - size.height / 2;
  const free = (x: number, y: number) => !nodes.some((n) => Math.abs(n.position.x - x) < SPOT_CLEARANCE.x && Math.abs(n.position.y - y) < SPOT_CLEARANCE.y);
  // rings around the centre of the view, nearest first: a spot off the other blocks, else any clear one
  let fallback: Position | null = null;
  for (let ring = 0; ring < SPOT_RINGS; ring++) {
    for (let i = -ring; i <= ring; i++) {
      for (const [dx, dy] of [[i, -ring], [i, ring], [-ring, i], [ring, i]]) {
        const x = cx + dx * SPOT_STEP.x, y = cy + dy * SPOT_STEP.y;
        if (!clear(x, y)) continue;
        if (free(x, y)) return { x, y };
        fallback ??= { x, y };
      }
    }
  }
  return fallback ?? { x: cx, y: cy };
}
