// The behaviour timeline's geometry and text, as pure functions: lane heights and the lane under a
// pointer, where a planned item's bar (or an instant item's flag) sits, the short summary a bar shows,
// and the link from a relative item to the moment it is timed from. Time <-> x is the clip editor's
// (timeView.ts), so the timeline lines up with the shared Ruler.
import type { TimeView } from "../../clip_editor/views/timeView";
import { timeToX } from "../../clip_editor/views/timeView";
import type { ItemDoc, PlannedItem, StartRef } from "../model/types";
import { isStartRef, kindInfo } from "../model/types";

/** A lane's height (px) and its bar's: 24 px bars with 5 px either side. */
export const LANE_HEIGHT = 34;
export const BAR_HEIGHT = 24;
/** Width (px) of an instant item's flag (LED, face, mood take no time). */
export const FLAG_WIDTH = 12;
/** Narrowest a timed bar is drawn (px), so a very short item stays clickable. */
export const MIN_BAR_WIDTH = 4;

export function laneTop(index: number): number {
  return index * LANE_HEIGHT;
}

/** The y (px) of lane `index`'s middle. */
export function laneMid(index: number): number {
  return laneTop(index) + LANE_HEIGHT / 2;
}

/** The lane under `y` px from the top of the first lane, clamped to the `count` lanes. */
export function laneAt(y: number, count: number): number {
  return Math.max(0, Math.min(count - 1, Math.floor(y / LANE_HEIGHT)));
}

export interface BarBox {
  /** left edge (px in the time area); for a flag, its middle is at the item's time */
  x: number;
  width: number;
  instant: boolean;
}

/** Where the bar of an item spanning [start, end] s sits in a time area `width` px wide. */
export function barBox(view: TimeView, width: number, kind: string, start: number, end: number): BarBox {
  const x0 = timeToX(view, width, start);
  if (kindInfo(kind).instant || end - start <= 1e-9) {
    return { x: x0 - FLAG_WIDTH / 2, width: FLAG_WIDTH, instant: true };
  }
  const x1 = timeToX(view, width, end);
  return { x: x0, width: Math.max(MIN_BAR_WIDTH, x1 - x0), instant: false };
}

function words(text: string, max = 4): string {
  const all = text.trim().split(/\s+/).filter(Boolean);
  return all.length > max ? `${all.slice(0, max).join(" ")}…` : all.join(" ");
}

function show(v: unknown): string {
  if (Array.isArray(v)) return `[${v.map((x) => (typeof x === "number" ? +x.toFixed(2) : String(x))).join(", ")}]`;
  return String(v);
}

/** The text on an item's bar: its label, else a short summary of what it does. */
export function itemSummary(item: ItemDoc): string {
  if (item.label) return item.label;
  switch (item.kind) {
    case "play_clip": return item.clip;
    case "go_posture": return item.posture;
    case "look_at": return `look ${show(item.target)}`;
    case "say": return `“${words(item.text)}”`;
    case "play_sound": return `♪ ${item.sound}`;
    case "set_led": return `LED ${show(item.colour)}`;
    case "set_face": return item.expression;
    case "set_emotion": return `mood ${show(item.valence)}/${show(item.arousal)}`;
    case "ramp": return `${item.input} → ${show(item.to)}`;
    case "wait": return `wait ${show(item.duration ?? 1)} s`;
    default: return item.id;
  }
}

/** "wave.beat + 0.2 s": what a relative start is timed from, for tooltips. */
export function describeStart(start: ItemDoc["start"]): string {
  if (!isStartRef(start)) return `${start ?? 0} s`;
  const ref: StartRef = start;
  const at = ref.at === "anchor" ? ref.anchor ?? "?" : ref.at ?? "start";
  const off = ref.offset ?? 0;
  return `${ref.item}.${at}${off ? ` ${off > 0 ? "+" : "−"} ${Math.abs(off)} s` : ""}`;
}

export interface Link {
  from: string;
  to: string;
  x1: number;
  y1: number;
  x2: number;
  y2: number;
}

/** The thin line from the moment an item is timed from (in its lane) to the item's start (in its). */
export function linkFor(
  item: ItemDoc,
  self: PlannedItem,
  base: PlannedItem | undefined,
  view: TimeView,
  width: number,
  laneOf: (p: PlannedItem) => number,
): Link | null {
  if (!isStartRef(item.start) || !base) return null;
  const at = item.start.at ?? "start";
  const moment = at === "start" ? base.start : at === "end" ? base.end : base.anchors?.[item.start.anchor ?? ""];
  if (moment == null) return null;
  return {
    from: base.id,
    to: self.id,
    x1: timeToX(view, width, moment),
    y1: laneMid(laneOf(base)),
    x2: timeToX(view, width, self.start),
    y2: laneMid(laneOf(self)),
  };
}
