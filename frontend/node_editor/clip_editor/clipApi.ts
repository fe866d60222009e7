// The server calls the clip editor makes (docs/api-contract.md): the clip library, the trajectory
// helper and ghost, the Pre-Viz preview pose, recording, postures and the clip commands. Some of these
// endpoints are newer than the generated types, so their answers are typed here by hand.
import { call, type FilteredTracks, type Saved, type ServerStatus, type TrackAnalysis } from "../api";
import type { Clip, Keyframe } from "./model/types";

/** A pose as the engine takes it: rad/m, an option name, or [r, g, b]. */
export type PoseValues = Record<string, Keyframe["v"]>;

export type GhostPreset = "W" | "A" | "B" | "C" | "D" | "E";

export interface PreviewState {
  active: boolean;
  values: PoseValues | null;
  /** DoFs the Pre-Viz user grabbed and where they left them (applied when `revision` changes). */
  grabbed: PoseValues;
  revision: number;
}

export interface RecordStarted {
  recording: boolean;
  dofs: string[];
  rate: number;
}

export interface RecordResult {
  saved: string;
  clip: Clip;
  samples: number;
  keys: Record<string, number>;
  duration: number;
  max_error: number;
  report: TrackAnalysis;
}

const enc = encodeURIComponent;

export const clipApi = {
  list: () => call<string[]>("GET", "/api/clips"),
  get: (name: string) => call<Clip>("GET", `/api/clips/${enc(name)}`),
  save: (name: string, doc: Clip) => call<Saved>("PUT", `/api/clips/${enc(name)}`, doc),
  status: () => call<ServerStatus>("GET", "/api/status"),
  /** `fit: false` leaves out the slow-down search (the bulk of the time): the colours of every edit. */
  analyze: (rate: number, clip: Clip, fit = true) => call<TrackAnalysis>("POST", "/api/analyze", { rate, clip, fit }),
  filter: (rate: number, clip: Clip, preset?: GhostPreset) =>
    call<FilteredTracks>("POST", "/api/filter", preset ? { rate, clip, preset } : { rate, clip }),
  preview: (values: PoseValues | null, label?: string) =>
    call<{ preview: boolean }>("PUT", "/api/previz/preview", values === null ? { values: null } : { values, label }),
  previewState: () => call<PreviewState>("GET", "/api/previz/preview"),
  recordStart: (dofs: string[]) => call<RecordStarted>("POST", "/api/record/start", { dofs, source: "output" }),
  recordStop: (name: string, tolerance = 0.005) => call<RecordResult>("POST", "/api/record/stop", { name, tolerance }),
  recordCancel: () => call<unknown>("DELETE", "/api/record"),
  savePosture: (name: string, description: string, values: PoseValues) =>
    call<Saved>("PUT", `/api/postures/${enc(name)}`, { format: "nutty-posture/1", name, description, values }),
  /** A command through POST /api/commands: play_clip's `document` and `start` are newer than the
   * generated command types, so the body is built here rather than typed as `Command`. */
  command: (body: Record<string, unknown>) => call<unknown>("POST", "/api/commands", body),
};

/** The play_clip command that plays the working copy from `start` (s), once or looping. */
export function playClipCommand(name: string, doc: Clip, start: number, loop: boolean): Record<string, unknown> {
  return { type: "play_clip", clip: name, document: doc, start, mode: loop ? "loop" : "once" };
}
