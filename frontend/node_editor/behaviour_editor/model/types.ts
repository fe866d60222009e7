// The behaviour editor's model types: the document (the generated `Behaviour`), its items and start
// references, the server's plan (every item's exact start/end) and issues, and the item kinds with the
// label and colour variable each is drawn with. Types only, plus the constant kind table.
import type { Behaviour, Items, StartRef as GeneratedStartRef, Track } from "../../generated/behaviour";

export type BehaviourDoc = Behaviour;
export type TrackDoc = Track;
/** One item: the generated union of the item kinds (the format's `Item`). */
export type ItemDoc = Items[number];
export type StartRef = GeneratedStartRef;
export type ItemKind = NonNullable<ItemDoc["kind"]>;
export type At = "start" | "end" | "anchor";

/** An error or warning the server reports, located on a track, item and field when it can. */
export interface Issue {
  message: string;
  path?: string;
  track?: number;
  /** the item's id, or "#i" for an item without a usable id */
  item?: string;
  /** e.g. "clip", "start.anchor" */
  field?: string;
}

/** One item as POST /api/behaviours/plan times it (seconds from the behaviour's start). */
export interface PlannedItem {
  id: string;
  track: number;
  kind: string;
  start: number;
  end: number;
  /** clip anchor -> seconds from the behaviour's start */
  anchors?: Record<string, number>;
  /** look_at: the exposed input followed while the item lasts */
  follow?: string;
}

export interface Plan {
  valid: boolean;
  duration: number;
  params: Record<string, unknown>;
  /** in start order; items that cannot be timed are missing */
  items: PlannedItem[];
  errors: Issue[];
}

/** A moment of another item a dragged item's start can snap to; `t` is that moment's planned time. */
export interface SnapTarget {
  item: string;
  at: At;
  anchor?: string;
  t: number;
}

export interface KindInfo {
  label: string;
  /** the CSS variable (timeline.css defines it for both themes) the kind's bars are filled with */
  colour: string;
  /** true when the item takes no time (drawn as a flag) */
  instant: boolean;
}

export const ITEM_KINDS: Record<ItemKind, KindInfo> = {
  play_clip: { label: "Clip", colour: "--bk-clip", instant: false },
  go_posture: { label: "Posture", colour: "--bk-posture", instant: false },
  look_at: { label: "Look at", colour: "--bk-gaze", instant: false },
  say: { label: "Say", colour: "--bk-say", instant: false },
  play_sound: { label: "Sound", colour: "--bk-sound", instant: false },
  set_led: { label: "LED", colour: "--bk-led", instant: true },
  set_face: { label: "Face", colour: "--bk-face", instant: true },
  set_emotion: { label: "Mood", colour: "--bk-mood", instant: true },
  ramp: { label: "Ramp", colour: "--bk-ramp", instant: false },
  wait: { label: "Wait", colour: "--bk-wait", instant: false },
};

export const KIND_ORDER = Object.keys(ITEM_KINDS) as ItemKind[];

export function isItemKind(kind: string): kind is ItemKind {
  return Object.prototype.hasOwnProperty.call(ITEM_KINDS, kind);
}

/** The kind's info; an unknown kind (a newer server) gets a neutral look. */
export function kindInfo(kind: string): KindInfo {
  return isItemKind(kind) ? ITEM_KINDS[kind] : { label: kind, colour: "--bk-other", instant: false };
}

export function isStartRef(start: ItemDoc["start"]): start is StartRef {
  return typeof start === "object" && start !== null;
}
