// The clip editor's shared vocabulary. The clip document's own types are generated from the backend's
// pydantic Clip model (../../generated/clip.ts, `npm run gen:types`); this module only names them and
// adds what the editor needs around them (key references, DoF facts, the clipboard).
import type { Clip, ClipEvent, Easing, Interp, Keyframe, LeftType } from "../../generated/clip";

export type { Clip, ClipEvent, Easing, Interp, Keyframe };
export type HandleType = LeftType;
/** A handle as an offset [dt (s), dv (DoF unit)] from its key, or as an absolute point [t, v]. */
export type Handle = [number, number];
export type Side = "left" | "right";

/** Frames per second keys snap to when the clip names none (the format's default). */
export const DEFAULT_FPS = 30;

/** One key of one track: `index` is its position in the track (keys are kept sorted by time). */
export interface KeyRef {
  dof: string;
  index: number;
}

/** What the editor knows of a DoF of the robot (from GET /api/robot). Units: rad or m for continuous
 * DoFs; `options` for enum DoFs (values are option names); colours are [r, g, b] in 0..1. */
export interface DofInfo {
  name: string;
  type: "continuous" | "colour" | "enum";
  min: number;
  max: number;
  rest: number;
  /** The rest value as a key value (number, option name or [r, g, b]); `rest` is its number (a colour's
   * first channel, an enum's option index). Added by the model (dofs.ts). */
  restValue?: Keyframe["v"];
  velocity: number;
  options?: string[];
  /** The row group in the dopesheet: "Joints", "Symbolic", "Spatial", "Display". */
  group: string;
  description?: string;
}

/** Keys copied from one or more tracks; times are relative to the earliest copied key (s). */
export interface ClipboardKeys {
  tracks: Record<string, Keyframe[]>;
}

/** A marker on the marker row: an anchor (by name) or an event (by its index in `events`). */
export type MarkerRef = { kind: "anchor"; name: string } | { kind: "event"; index: number };

/** An edit's result: the new document and the selection after it (indices follow re-sorted keys). */
export interface Edited {
  doc: Clip;
  selection: KeyRef[];
}

/** Errors the server reported, keyed by "dof" (a track), "dof#index" (a key), or "" (the clip). */
export type ClipErrors = Record<string, string>;

export const keyId = (ref: KeyRef): string => `${ref.dof}#${ref.index}`;
