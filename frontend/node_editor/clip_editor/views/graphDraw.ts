// The graph editor's drawing maths: the value axis (its own vertical view), SVG path strings for curves
// sampled every couple of pixels, the trajectory helper's over-limit spans cut out of a curve, and the
// ghost (the filtered track the engine would play). Pure functions, unit-tested, no React.
import type { TimeView } from "./timeView";
import { decimals, niceStep, timeToX, xToTime } from "./timeView";

/** The values at the bottom (v0) and top (v1) of the graph. */
export interface ValueView {
  v0: number;
  v1: number;
}

/** Pixel box of the plot: time runs over `width`, values over `height` (y grows downwards). */
export interface Plot {
  view: TimeView;
  values: ValueView;
  width: number;
  height: number;
}

export function valueToY(p: Plot, v: number): number {
  return ((p.values.v1 - v) / (p.values.v1 - p.values.v0)) * p.height;
}

export function yToValue(p: Plot, y: number): number {
  return p.values.v1 - (y / Math.max(p.height, 1)) * (p.values.v1 - p.values.v0);
}

/** Zoom the value axis by `factor` (> 1 zooms out) keeping value `v` in place. */
export function zoomValues(vv: ValueView, v: number, factor: number): ValueView {
  const span = vv.v1 - vv.v0;
  const next = Math.min(1e6, Math.max(1e-6, span * factor));
  const k = next / span;
  return { v0: v - (v - vv.v0) * k, v1: v + (vv.v1 - v) * k };
}

/** A value view around [lo, hi] with 8 % margins (a flat or empty range gets +-0.5). */
export function frameValues(lo: number, hi: number): ValueView {
  if (!Number.isFinite(lo) || !Number.isFinite(hi)) return { v0: -1, v1: 1 };
  if (hi - lo < 1e-6) return { v0: lo - 0.5, v1: hi + 0.5 };
  const m = (hi - lo) * 0.08;
  return { v0: lo - m, v1: hi + m };
}

/** Labelled value ticks >= ~28 px apart. */
export function valueTicks(p: Plot): { v: number; label: string }[] {
  const span = p.values.v1 - p.values.v0;
  const step = niceStep(span / Math.max(p.height, 1), 28);
  const d = decimals(step);
  const out: { v: number; label: string }[] = [];
  for (let i = Math.ceil(p.values.v0 / step - 1e-9); i * step <= p.values.v1 + 1e-9 && out.length < 200; i++) {
    const v = i * step;
    out.push({ v, label: (Math.abs(v) < step / 2 ? 0 : v).toFixed(d) });
  }
  return out;
}

const fmt = (n: number): string => (Number.isFinite(n) ? n.toFixed(1) : "0");

/** Times to sample a curve at between t0 and t1: every `stepPx` pixels plus, for each key time inside,
 * the instant just before and at it so steps (constant keys) and corners stay sharp. Sorted. */
export function sampleTimes(p: Plot, a: number, b: number, keyTimes: readonly number[], stepPx = 2): number[] {
  const t0 = Math.max(a, p.view.t0);
  const t1 = Math.min(b, p.view.t1);
  if (!(t1 >= t0)) return [];
  const x0 = timeToX(p.view, p.width, t0);
  const x1 = timeToX(p.view, p.width, t1);
  const ts: number[] = [t0];
  for (let x = Math.ceil((x0 + 1e-9) / stepPx) * stepPx; x < x1; x += stepPx) ts.push(xToTime(p.view, p.width, x));
  const eps = (p.view.t1 - p.view.t0) * 1e-7;
  for (const k of keyTimes) {
    if (k > t0 && k < t1) ts.push(k - eps, k);
  }
  ts.push(t1);
  ts.sort((u, w) => u - w);
  return ts;
}

/** An SVG path through (t, f(t) + offset) at the given times. */
export function pathAt(p: Plot, times: readonly number[], f: (t: number) => number, offset = 0): string {
  let d = "";
  for (let i = 0; i < times.length; i++) {
    const t = times[i];
    d += `${i === 0 ? "M" : "L"}${fmt(timeToX(p.view, p.width, t))} ${fmt(valueToY(p, f(t) + offset))}`;
  }
  return d;
}

/** The whole visible curve as one path. */
export function curvePath(p: Plot, f: (t: number) => number, keyTimes: readonly number[], offset = 0): string {
  return pathAt(p, sampleTimes(p, -Infinity, Infinity, keyTimes), f, offset);
}

export interface Span {
  t_start: number;
  t_end: number;
}

/** One path of sub-paths, one per span, following the curve over [t_start, t_end] (a single-sample span
 * is widened to half a pixel each side so it still shows). Spans outside the view are left out. */
export function spansPath(p: Plot, spans: readonly Span[], f: (t: number) => number, keyTimes: readonly number[], offset = 0): string {
  const half = ((p.view.t1 - p.view.t0) / Math.max(p.width, 1)) * 0.5;
  let d = "";
  for (const s of spans) {
    const a = s.t_end - s.t_start < half ? s.t_start - half : s.t_start;
    const b = s.t_end - s.t_start < half ? s.t_end + half : s.t_end;
    if (b < p.view.t0 || a > p.view.t1) continue;
    d += pathAt(p, sampleTimes(p, a, b, keyTimes), f, offset);
  }
  return d;
}

/** Group spans by key (e.g. "dof|kind") keeping their order. */
export function groupSpans<S extends Span>(spans: readonly S[], key: (s: S) => string): Map<string, S[]> {
  const out = new Map<string, S[]>();
  for (const s of spans) {
    const k = key(s);
    const list = out.get(k);
    if (list) list.push(s);
    else out.set(k, [s]);
  }
  return out;
}

/** A path through samples taken at `rate` Hz from time 0 (the ghost), drawn at most one point per
 * ~`stepPx` pixels (keeping the extreme of each bucket would hide nothing a 2 px step can show). */
export function samplesPath(p: Plot, values: readonly number[], rate: number, stepPx = 2): string {
  if (values.length === 0 || !(rate > 0)) return "";
  const first = Math.max(0, Math.floor(p.view.t0 * rate));
  const last = Math.min(values.length - 1, Math.ceil(p.view.t1 * rate));
  if (last < first) return "";
  const perPx = rate * ((p.view.t1 - p.view.t0) / Math.max(p.width, 1));
  const stride = Math.max(1, Math.floor(perPx * stepPx));
  let d = "";
  for (let i = first; i <= last; i += stride) {
    d += `${d ? "L" : "M"}${fmt(timeToX(p.view, p.width, i / rate))} ${fmt(valueToY(p, values[i]))}`;
  }
  if ((last - first) % stride !== 0) d += `L${fmt(timeToX(p.view, p.width, last / rate))} ${fmt(valueToY(p, values[last]))}`;
  return d;
}

/** Min and max of samples (ignoring non-finite ones), or null when none. */
export function extent(values: Iterable<number>): [number, number] | null {
  let lo = Infinity;
  let hi = -Infinity;
  for (const v of values) {
    if (!Number.isFinite(v)) continue;
    if (v < lo) lo = v;
    if (v > hi) hi = v;
  }
  return lo <= hi ? [lo, hi] : null;
}

/** Distinct curve colours (readable on the dark and the light theme). */
export const CURVE_COLOURS = ["#e5734a", "#4aa3e5", "#6cc66c", "#c77de0", "#e5c04a", "#4ad0c8", "#e55a8f", "#9aa7ff"];

export const curveColour = (i: number): string => CURVE_COLOURS[i % CURVE_COLOURS.length];
