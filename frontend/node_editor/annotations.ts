// Comment frames and reroute points: editor-only annotations kept in the program's `ui`
// (`ui.comments`, `ui.reroutes`, docs/program-format.md "Editor data"). On the canvas they are React
// Flow nodes of their own types ("comment", "reroute"), so dragging, selecting, deleting and undo work
// as for blocks; they never reach the compiler as blocks. A reroute bends the drawing of one edge and
// the edge stays one program edge. Pure functions (tested with vitest).
import type { FlowEdge, FlowNode } from "./flowTypes";

export interface Comment { id: string; x: number; y: number; w: number; h: number; title: string; colour: string }
export interface Endpoint { node: string; port: string }
export interface Reroute { id: string; x: number; y: number; edge: { from: Endpoint; to: Endpoint } }

export const COMMENT_COLOURS = ["#4a5a78", "#6a4a78", "#3f6b55", "#7a5a2e", "#7a3a44", "#505560"];
export const COMMENT_SIZE = { w: 420, h: 260 };
/** The least size a comment frame can be resized to: room for its title and colour swatches. */
export const COMMENT_MIN_SIZE = { w: 120, h: 60 };
/** Comment frames are drawn behind every block and wire. */
const COMMENT_Z_INDEX = -1000;
/** A routed wire leaves and reaches each point horizontally, over at least this distance. */
const MIN_TANGENT = 20;
/** A reroute dot's size on the canvas: its position is its top-left corner, wires go through its centre. */
export const REROUTE_SIZE = 14;

const num = (v: unknown, d: number) => (typeof v === "number" && Number.isFinite(v) ? v : d);

export function commentNode(c: Partial<Comment> & { id: string }): FlowNode {
  const w = num(c.w, COMMENT_SIZE.w), h = num(c.h, COMMENT_SIZE.h);
  return {
    id: c.id, type: "comment", position: { x: num(c.x, 0), y: num(c.y, 0) }, width: w, height: h, zIndex: COMMENT_Z_INDEX,
    data: { type: "comment", params: { title: c.title ?? "Comment", colour: c.colour ?? COMMENT_COLOURS[0] }, ui: {}, inputs: {}, outputs: {}, errors: [] },
  };
}

export function rerouteNode(r: { id: string; x: number; y: number; edge: string }): FlowNode {
  return {
    id: r.id, type: "reroute", position: { x: r.x, y: r.y },
    data: { type: "reroute", params: { edge: r.edge }, ui: {}, inputs: {}, outputs: {}, errors: [] },
  };
}

const endpointKey = (e: { from: Endpoint; to: Endpoint }) => `${e.from.node}.${e.from.port}->${e.to.node}.${e.to.port}`;

/** The annotation nodes of a program's `ui`, and the rest of its `ui`. */
export function annotationsToFlow(ui: Record<string, unknown> | undefined): { nodes: FlowNode[]; rest: Record<string, unknown> } {
  const { comments, reroutes, ...rest } = (ui ?? {}) as Record<string, unknown>;
  const nodes: FlowNode[] = [];
  for (const c of Array.isArray(comments) ? comments : []) if (c && typeof c.id === "string") nodes.push(commentNode(c));
  for (const r of Array.isArray(reroutes) ? reroutes : []) {
    if (!r || typeof r.id !== "string" || !r.edge?.from || !r.edge?.to) continue;
    nodes.push(rerouteNode({ id: r.id, x: num(r.x, 0), y: num(r.y, 0), edge: endpointKey(r.edge) }));
  }
  return { nodes, rest };
}

export const isAnnotation = (n: FlowNode) => n.type === "comment" || n.type === "reroute";

/** `ui.comments` and `ui.reroutes` from the canvas (reroutes of edges that are gone are dropped). */
export function annotationsFromFlow(nodes: FlowNode[], edges: FlowEdge[]): { comments: Comment[]; reroutes: Reroute[] } {
  const byId = new Map(edges.map((e) => [e.id, e]));
  const comments: Comment[] = [];
  const reroutes: Reroute[] = [];
  for (const n of nodes) {
    if (n.type === "comment") {
      const p = n.data.params as Record<string, unknown>;
      comments.push({
        id: n.id, x: Math.round(n.position.x), y: Math.round(n.position.y),
        w: Math.round(num(n.width ?? n.measured?.width, COMMENT_SIZE.w)), h: Math.round(num(n.height ?? n.measured?.height, COMMENT_SIZE.h)),
        title: String(p.title ?? ""), colour: String(p.colour ?? COMMENT_COLOURS[0]),
      });
    } else if (n.type === "reroute") {
      const e = byId.get(String(n.data.params.edge));
      if (!e) continue;
      reroutes.push({
        id: n.id, x: Math.round(n.position.x), y: Math.round(n.position.y),
        edge: { from: { node: e.source, port: e.sourceHandle }, to: { node: e.target, port: e.targetHandle } },
      });
    }
  }
  return { comments, reroutes };
}

/** Edges that pass through reroute points become "routed" edges carrying those points (left to right). */
export function withRoutes<E extends FlowEdge>(edges: E[], nodes: FlowNode[]): E[] {
  const via: Record<string, { x: number; y: number }[]> = {};
  for (const n of nodes) {
    if (n.type !== "reroute") continue;
    (via[String(n.data.params.edge)] ??= []).push({ x: n.position.x + REROUTE_SIZE / 2, y: n.position.y + REROUTE_SIZE / 2 });
  }
  if (!Object.keys(via).length) return edges;
  return edges.map((e) => (via[e.id] ? { ...e, type: "routed", data: { ...e.data, via: via[e.id].sort((a, b) => a.x - b.x) } } : e));
}

/** An SVG path from source to target through `via`, each stretch a horizontal-tangent bezier. */
export function routedPath(sx: number, sy: number, tx: number, ty: number, via: { x: number; y: number }[]): string {
  const pts = [{ x: sx, y: sy }, ...via, { x: tx, y: ty }];
  let d = `M ${sx},${sy}`;
  for (let i = 1; i < pts.length; i++) {
    const a = pts[i - 1], b = pts[i];
    const dx = Math.max(Math.abs(b.x - a.x) / 2, MIN_TANGENT);
    d += ` C ${a.x + dx},${a.y} ${b.x - dx},${b.y} ${b.x},${b.y}`;
  }
  return d;
}

/** A fresh id with a prefix, unique among `nodes`. */
export function freshAnnotationId(nodes: FlowNode[], prefix: string): string {
  const ids = new Set(nodes.map((n) => n.id));
  for (let k = 1; ; k++) if (!ids.has(`${prefix}${k}`)) return `${prefix}${k}`;
}
