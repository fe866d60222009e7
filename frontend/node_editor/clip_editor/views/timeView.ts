// The time axis the ruler, dopesheet and graph editor share: which seconds are at the left and right
// edges, the pixel <-> time maps, zooming/panning/framing, frame snapping and the ruler's tick layout.
// Pure functions only, so every view converts the same way and the maths is unit-tested.
import type { Clip } from "../model/types";

/** Seconds at the left (t0) and right (t1) edge of the time area. */
export interface TimeView {
  t0: number;
  t1: number;
}

/** Width (px) of the column left of the time area in every view (track names, value axis), so a Ruler
 * mounted above the dopesheet and graph editor lines up with them. */
export const GUTTER = 170;

const MIN_SPAN = 1e-3;
const MAX_SPAN = 1e5;

export function timeToX(view: TimeView, width: number, t: number): number {
  return ((t - view.t0) / (view.t1 - view.t0)) * width;
}

export function xToTime(view: TimeView, width: number, x: number): number {
  return view.t0 + (x / Math.max(width, 1)) * (view.t1 - view.t0);
}

/** Seconds per pixel of the view at `width`. */
export function secondsPerPx(view: TimeView, width: number): number {
  return (view.t1 - view.t0) / Math.max(width, 1);
}

/** Zoom by `factor` (> 1 zooms out) keeping time `t` at the same place on screen. */
export function zoomAbout(view: TimeView, t: number, factor: number): TimeView {
  const span = view.t1 - view.t0;
  const next = Math.min(MAX_SPAN, Math.max(MIN_SPAN, span * factor));
  const k = next / span;
  return { t0: t - (t - view.t0) * k, t1: t + (view.t1 - t) * k };
}

/** Shift the view by `dt` seconds (positive moves the visible window later). */
export function panBy(view: TimeView, dt: number): TimeView {
  return { t0: view.t0 + dt, t1: view.t1 + dt };
}

/** The clip's last time: its duration, else its last key, anchor or event (0 for an empty clip). */
export function docEnd(doc: Clip): number {
  if (doc.duration != null) return doc.duration;
  let end = 0;
  for (const keys of Object.values(doc.tracks)) for (const k of keys) end = Math.max(end, k.t);
  for (const t of Object.values(doc.anchors ?? {})) end = Math.max(end, t);
  for (const e of doc.events ?? []) end = Math.max(end, e.t);
  return end;
}

/** A view showing the whole clip with a small margin either side (2 s for an empty clip). */
export function frameAll(doc: Clip): TimeView {
  return frameSpan(0, docEnd(doc));
}

export function frameSpan(a: number, b: number): TimeView {
  const span = b - a > 1e-6 ? b - a : 2;
  const margin = span * 0.05;
  return { t0: a - margin, t1: a + span + margin };
}

/** `t` rounded to the nearest frame of `fps`, never negative. */
export function snapFrame(t: number, fps: number): number {
  return Math.max(0, Math.round(t * fps) / fps);
}

export interface Tick {
  t: number;
  label: string;
}

export interface RulerTicks {
  /** labelled ticks (seconds) */
  major: Tick[];
  /** unlabelled ticks between them (frames when zoomed in far enough) */
  minor: number[];
  /** true when `minor` are one per frame */
  frames: boolean;
}

const STEPS = [0.001, 0.002, 0.005, 0.01, 0.02, 0.05, 0.1, 0.2, 0.25, 0.5, 1, 2, 5, 10, 15, 30, 60, 120, 300, 600];

/** The smallest "nice" step (s) at least `minPx` apart on screen. */
export function niceStep(spp: number, minPx: number): number {
  const need = spp * minPx;
  for (const s of STEPS) if (s >= need) return s;
  return STEPS[STEPS.length - 1] * Math.ceil(need / STEPS[STEPS.length - 1]);
}

/** Decimals needed to print multiples of `step` exactly (at most 4). */
export function decimals(step: number): number {
  let d = 0;
  while (d < 4 && Math.abs(Math.round(step * 10 ** d) - step * 10 ** d) > 1e-9) d++;
  return d;
}

/** Ticks for a ruler `width` px wide: labels >= ~70 px apart, frame ticks once a frame is >= 6 px. */
export function rulerTicks(view: TimeView, width: number, fps: number): RulerTicks {
  const spp = secondsPerPx(view, width);
  const step = niceStep(spp, 70);
  const d = decimals(step);
  const major: Tick[] = [];
  const first = Math.ceil(view.t0 / step - 1e-9);
  for (let i = first; i * step <= view.t1 + 1e-9 && major.length < 500; i++) {
    const t = i * step;
    major.push({ t, label: `${t.toFixed(d)} s` });
  }
  const frames = 1 / fps / spp >= 6;
  const minorStep = frames ? 1 / fps : step / 5;
  const minor: number[] = [];
  if (minorStep / spp >= 3) {
    const f = Math.ceil(view.t0 / minorStep - 1e-9);
    for (let i = f; i * minorStep <= view.t1 + 1e-9 && minor.length < 2000; i++) minor.push(i * minorStep);
  }
  return { major, minor, frames };
}
