// Pure logic of the editor's live views (tested with vitest): numbers with their sign, the summary of
// a signal value, the cook-time heat scale, which wire drives a parameter, warnings by node, and the
// layer stack's solo/mute/reorder plans.
import type { SignalRef, ValidationReport } from "../api";
import type { FlowEdge } from "../graph";

/** The typographic minus (U+2212): visible and as wide as a plus. */
export const MINUS = "\u2212";

/** A number with its sign always shown (+0.120, −0.031); `digits` decimals below 100, none above. */
export function signed(v: number, digits = 3): string {
  if (!Number.isFinite(v)) return String(v);
  const abs = Math.abs(v);
  const text = abs >= 100 ? abs.toFixed(0) : abs.toFixed(digits);
  if (Number(text) === 0) return text;  // no sign on a value that rounds to zero
  return (v < 0 ? MINUS : "+") + text;
}

/** An axis tick: negative numbers with a visible minus, positive ones bare. */
export function tick(v: number, digits = 2): string {
  if (!Number.isFinite(v)) return "";
  const text = Math.abs(v).toFixed(digits);
  return v < 0 && Number(text) !== 0 ? MINUS + text : text;
}

/** Tick labels with as many decimals as the spacing between ticks needs. */
export function ticks(splits: number[]): string[] {
  const step = splits.length > 1 ? Math.abs(splits[1] - splits[0]) : 1;
  const digits = step > 0 ? Math.min(6, Math.max(0, -Math.floor(Math.log10(step) + 1e-9))) : 2;
  return splits.map((v) => tick(v, digits));
}

export interface FrameValue {
  mask: number;
  values: Record<string, number>;
}

export function isFrame(v: unknown): v is FrameValue {
  return typeof v === "object" && v !== null && "mask" in v && "values" in v;
}

/** A signal value as one short line: numbers signed, frames as their DoF count and first DoFs. */
export function summarise(v: unknown, firstDofs = 3): string {
  if (v === null || v === undefined) return "–";
  if (typeof v === "number") return signed(v);
  if (typeof v === "boolean") return v ? "true" : "false";
  if (isFrame(v)) {
    const entries = Object.entries(v.values);
    if (!entries.length) return "empty frame";
    const shown = entries.slice(0, firstDofs).map(([k, x]) => `${k} ${signed(x)}`).join(", ");
    return `${v.mask} DoF${v.mask === 1 ? "" : "s"} · ${shown}${entries.length > firstDofs ? ", …" : ""}`;
  }
  if (Array.isArray(v)) return "[" + v.map((x) => (typeof x === "number" ? signed(x, 2) : String(x))).join(", ") + "]";
  return String(v);
}

/** The number a probe plots for a value: the number itself, or a frame's first DoF. */
export function plotted(v: unknown): number | undefined {
  if (typeof v === "number" && Number.isFinite(v)) return v;
  if (typeof v === "boolean") return v ? 1 : 0;
  if (isFrame(v)) return Object.values(v.values)[0];
  return undefined;
}

/** Min, max and last of a history (undefined when empty). */
export function stats(values: number[]): { min: number; max: number; last: number } | undefined {
  if (!values.length) return undefined;
  let min = Infinity, max = -Infinity;
  for (const v of values) { if (v < min) min = v; if (v > max) max = v; }
  return { min, max, last: values[values.length - 1] };
}

// ---- cook times -------------------------------------------------------------------------------

/** A cook time for a badge: "42 µs", "1.3 ms". */
export function cookText(us: number): string {
  if (!Number.isFinite(us)) return "–";
  if (us >= 1000) return `${(us / 1000).toFixed(us >= 10000 ? 0 : 1)} ms`;
  return `${us >= 10 ? Math.round(us) : us.toFixed(1)} µs`;
}

/** Heat of a cook time 0..1: its share of `scale` (the tick budget or the most expensive node),
 * on a square-root scale so cheap nodes still tell apart. */
export function heat(us: number, scale: number): number {
  if (!(scale > 0) || !(us > 0)) return 0;
  return Math.min(1, Math.sqrt(us / scale));
}

/** Cool (blue) → warm (yellow) → hot (red) for a heat 0..1, as an `hsl()` colour. */
export function heatColour(h: number): string {
  const x = Math.min(1, Math.max(0, h));
  const hue = Math.round(210 - 210 * x);  // 210 blue, 60 yellow, 0 red
  const light = Math.round(42 + 8 * Math.sin(Math.PI * x));
  return `hsl(${hue}, 75%, ${light}%)`;
}

/** The scale heat is measured against: the tick budget (1/rate) when known, else the most expensive
 * node; never below the most expensive node's tenth, so a light program is not all blue. */
export function heatScale(nodesUs: number[], budgetUs?: number): number {
  const top = Math.max(0, ...nodesUs);
  if (budgetUs && budgetUs > 0) return Math.max(Math.min(budgetUs, top * 10), top);
  return top;
}

// ---- report -----------------------------------------------------------------------------------

/** Warnings of the report by node, each as `port: message`. */
export function warningsByNode(report: ValidationReport | null): Record<string, string[]> {
  const out: Record<string, string[]> = {};
  for (const w of report?.warnings ?? []) if (w.node) (out[w.node] ??= []).push(`${w.port ? w.port + ": " : ""}${w.message}`);
  return out;
}

/** The first node the report warns about (in the report's order), or null. */
export function firstWarnedNode(report: ValidationReport | null): string | null {
  return report?.warnings.find((w) => w.node)?.node ?? null;
}

// ---- parameters driven by wires ------------------------------------------------------------------

export interface Driver {
  node: string;
  port: string;
}

/** The wire that drives parameter `param` of node `node`: an edge into its same-named input port. */
export function drivenBy(edges: FlowEdge[], node: string, param: string): Driver | null {
  const e = edges.find((x) => x.target === node && x.targetHandle === param);
  return e ? { node: e.source, port: e.sourceHandle } : null;
}

// ---- layer stack ------------------------------------------------------------------------------

export interface LayerSwitch {
  layer: string;
  active: boolean;
}

/** Solo `name`: the layers to switch (only `name` active) and the active set to restore later. */
export function soloPlan(layers: { name: string; active: boolean }[], name: string): { switches: LayerSwitch[]; saved: string[] } {
  const saved = layers.filter((l) => l.active).map((l) => l.name);
  const switches = layers
    .filter((l) => (l.name === name) !== l.active)
    .map((l) => ({ layer: l.name, active: l.name === name }));
  return { switches, saved };
}

/** Un-solo: the switches that bring back the active set `soloPlan` saved (every layer on exactly when
 * it was on before the solo; layers removed since are ignored). */
export function unsoloPlan(layers: { name: string; active: boolean }[], saved: string[]): LayerSwitch[] {
  const want = new Set(saved);
  return layers.filter((l) => want.has(l.name) !== l.active).map((l) => ({ layer: l.name, active: want.has(l.name) }));
}

/** Mute (or unmute) one layer: the switch to send. */
export function mutePlan(layer: { name: string; active: boolean }): LayerSwitch {
  return { layer: layer.name, active: !layer.active };
}

/** The list with item `i` moved by `by` (−1 up, +1 down); the same list when it cannot move. */
export function moved<T>(list: T[], i: number, by: number): T[] {
  const j = i + by;
  if (i < 0 || i >= list.length || j < 0 || j >= list.length) return list;
  const out = [...list];
  [out[i], out[j]] = [out[j], out[i]];
  return out;
}

/** A layer's DoF mask in a few words. */
export function maskSummary(mask: unknown): string {
  const list = Array.isArray(mask) ? mask.map(String) : ["*"];
  if (!list.length) return "nothing";
  if (list.length === 1 && list[0] === "*") return "all DoFs";
  return list.length > 3 ? `${list.slice(0, 3).join(", ")} +${list.length - 3}` : list.join(", ");
}

// ---- telemetry subscription ---------------------------------------------------------------------

/** How many signals the server follows per subscription (backend/routes/telemetry.py MAX_SIGNALS). */
const SERVER_SIGNAL_CAP = 200;
const watchedCache = new WeakMap<SignalRef[], Map<SignalRef[], SignalRef[]>>();

/** `all` with the `watched` signals first (the same list object while both stay the same). */
export function withWatched(all: SignalRef[], watched: SignalRef[]): SignalRef[] {
  const has = (w: SignalRef) => all.some((s) => s.node === w.node && s.port === w.port);
  if (!watched.length || (all.length <= SERVER_SIGNAL_CAP && watched.every(has))) return all;  // already subscribed
  let byWatched = watchedCache.get(all);
  if (!byWatched) watchedCache.set(all, (byWatched = new Map()));
  let out = byWatched.get(watched);
  if (!out) {
    const seen = new Set(watched.map((s) => `${s.node}.${s.port}`));
    out = [...watched, ...all.filter((s) => !seen.has(`${s.node}.${s.port}`))];
    byWatched.clear();
    byWatched.set(watched, out);
  }
  return out;
}
