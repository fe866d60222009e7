// The canvas viewport: a readable zoom (block titles ≥ 11 px on screen), the level of detail of the
// blocks, the part of the graph a program opens on, and free spots for new blocks in view.
import { useStore, type ReactFlowInstance } from "@xyflow/react";
import type { Catalog } from "./api";
import type { FlowEdge, FlowNode } from "./graph";
import { BLOCK_WIDTH, FALLBACK_CANVAS_SIZE } from "./layout/constants";

/** Below this zoom blocks collapse to an enlarged title and their ports (see .block.compact). */
export const LOD_ZOOM = 0.7;
/** Title sizes (px, at zoom 1) of a full and a collapsed block: 16 × 0.7 and 28 × 0.42 are ≥ 11 px. */
export const TITLE_PX = 16;
export const COMPACT_TITLE_PX = 28;
/** The least zoom the editor picks itself (opening, fit): collapsed titles stay ≥ 11 px on screen. */
export const READABLE_ZOOM = 0.42;
export const MAX_FIT_ZOOM = 1.1;
/** The zooms the canvas allows (wheel, buttons, minimap). */
export const CANVAS_MIN_ZOOM = 0.2;
export const CANVAS_MAX_ZOOM = 2.5;
const PADDING = 0.12;
/** Flow-space size of a block, for bounds of blocks not measured yet. */
const BLOCK = { width: BLOCK_WIDTH, height: 130 };
/** Screen px that a program's output chain is kept inside the view's edges when it opens. */
const CHAIN_MARGIN = 40;
/** A free spot for a new block: inside the view's edges by this much (screen px), on rings around the
 * view's centre (this many, each a step across and down), this far from other blocks. */
const SPOT_INSET = 20;
const SPOT_RINGS = 12;
const SPOT_STEP = { x: BLOCK.width / 2 + 10, y: 80 };
const SPOT_CLEARANCE = { x: BLOCK.width + 10, y: 150 };

/** Whether blocks are collapsed: re-renders a node only when the zoom crosses LOD_ZOOM. */
export function useCompact(): boolean {
  return useStore((s) => s.transform[2] < LOD_ZOOM);
}

type Rect = { x: number; y: number; width: number; height: number };

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
  return Math.min(width / (rect.width * (1 + 2 * PADDING)), height / (rect.height * (1 + 2 * PADDING)));
}

/** Show the flow point (cx, cy) at the centre of the canvas at `zoom`. */
function centreOn(flow: ReactFlowInstance, cx: number, cy: number, zoom: number, duration = 0) {
  const { width, height } = paneSize();
  flow.setViewport({ x: width / 2 - cx * zoom, y: height / 2 - cy * zoom, zoom }, { duration });
}

/** Frame `rect` at the largest zoom that shows it within [minZoom, maxZoom]; centred when it cannot fit. */
function frame(flow: ReactFlowInstance, rect: Rect, minZoom = READABLE_ZOOM, maxZoom = MAX_FIT_ZOOM, duration = 0) {
  const zoom = Math.max(minZoom, Math.min(maxZoom, fitZoom(rect)));
  centreOn(flow, rect.x + rect.width / 2, rect.y + rect.height / 2, zoom, duration);
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

/** The part of the graph a program opens on: all of it when that is readable; else the selection, or the
 * output chain with the blocks feeding it, at a readable zoom, keeping the chain (the output end) in view. */
export function frameOpening(flow: ReactFlowInstance, nodes: FlowNode[], edges: FlowEdge[], catalog: Catalog) {
  const all = boundsOf(flow, new Set(nodes.map((n) => n.id)));
  if (!all) return;
  if (fitZoom(all) >= READABLE_ZOOM) return frame(flow, all);
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

/** Fit: the whole graph, never below a readable zoom; with a selection, frame it close enough to see its
 * values (like Blender's View Selected). */
export function fitReadable(flow: ReactFlowInstance, duration = 200) {
  const nodes = flow.getNodes();
  const selected = nodes.filter((n) => n.selected);
  const rect = boundsOf(flow, new Set((selected.length ? selected : nodes).map((n) => n.id)));
  if (rect) frame(flow, rect, selected.length ? LOD_ZOOM : READABLE_ZOOM, MAX_FIT_ZOOM, duration);
}

/** A spot for a new block in the visible part of the canvas, off the other blocks (flow coordinates). */
export function visibleSpot(flow: ReactFlowInstance, nodes: FlowNode[]): { x: number; y: number } {
  const el = document.querySelector(".graph .react-flow");
  const r = el?.getBoundingClientRect() ?? { left: 0, top: 0, width: window.innerWidth, height: window.innerHeight };
  const a = flow.screenToFlowPosition({ x: r.left + SPOT_INSET, y: r.top + SPOT_INSET });
  const b = flow.screenToFlowPosition({ x: r.left + r.width - SPOT_INSET, y: r.top + r.height - SPOT_INSET });
  const w = BLOCK.width, h = BLOCK.height;
  const cx = (a.x + b.x) / 2 - w / 2, cy = (a.y + b.y) / 2 - h / 2;
  const free = (x: number, y: number) => !nodes.some((n) => Math.abs(n.position.x - x) < SPOT_CLEARANCE.x && Math.abs(n.position.y - y) < SPOT_CLEARANCE.y);
  const inView = (x: number, y: number) => x >= a.x && y >= a.y && x + w <= b.x && y + h <= b.y;
  // rings around the centre of the view, nearest first
  for (let ring = 0; ring < SPOT_RINGS; ring++) {
    for (let i = -ring; i <= ring; i++) {
      for (const [dx, dy] of [[i, -ring], [i, ring], [-ring, i], [ring, i]]) {
        const x = cx + dx * SPOT_STEP.x, y = cy + dy * SPOT_STEP.y;
        if (inView(x, y) && free(x, y)) return { x, y };
      }
    }
  }
  return { x: cx, y: cy };
}
