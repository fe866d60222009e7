// The server calls the behaviour editor makes: the behaviour library, the plan (every item's exact
// timing), the render (frames and events for the browser's preview), the robot's clips, postures and
// sounds for the inspector's selects, and playing on the robot. The behaviour endpoints are newer than
// the generated API types, so their answers are typed here by hand.
import { ApiError, call, type Saved } from "../api";
import type { Param } from "../generated/behaviour";
import type { BehaviourDoc, Issue, Plan } from "./model/types";

export interface BehaviourSummary {
  name: string;
  description: string;
  params: Record<string, Param>;
  /** s with the default params; null when the behaviour has errors */
  duration: number | null;
  errors: Issue[];
}

export interface RenderEvent {
  t: number;
  dof: string;
  kind: string;
  payload: { url?: string; sound?: string; duration?: number; text?: string; [k: string]: unknown };
}

export interface Rendered {
  rate: number;
  duration: number;
  dofs: string[];
  /** frame k at k / rate s from the behaviour's start: one value per DoF */
  frames: unknown[][];
  events: RenderEvent[];
}

export interface SoundInfo { name: string; duration: number; url: string }

export interface CommandAck { id: string; status: string }

/** A refusal's issues (a 422 invalid_behaviour) and message. */
export function issuesOf(err: unknown): { message: string; errors: Issue[] } {
  if (err instanceof ApiError) {
    const detail = err.detail as { message?: string; errors?: Issue[] } | null;
    return { message: detail?.message ?? err.message, errors: Array.isArray(detail?.errors) ? detail.errors : [] };
  }
  return { message: err instanceof Error ? err.message : String(err), errors: [] };
}

const enc = encodeURIComponent;

export const behaviourApi = {
  list: () => call<BehaviourSummary[]>("GET", "/api/behaviours"),
  get: (name: string) => call<BehaviourDoc>("GET", `/api/behaviours/${enc(name)}`),
  save: (name: string, doc: BehaviourDoc) => call<Saved & { warnings?: Issue[] }>("PUT", `/api/behaviours/${enc(name)}`, doc),
  plan: (document: BehaviourDoc, params: Record<string, unknown>) =>
    call<Plan>("POST", "/api/behaviours/plan", { document, params }),
  render: (document: BehaviourDoc, params: Record<string, unknown>, rate = 30) =>
    call<Rendered>("POST", "/api/behaviours/render", { document, params, rate }),
  clips: () => call<string[]>("GET", "/api/clips"),
  postures: () => call<string[]>("GET", "/api/postures"),
  sounds: () => call<SoundInfo[]>("GET", "/api/sounds"),
  play: (behaviour: string, document: BehaviourDoc, params: Record<string, unknown>) =>
    call<CommandAck>("POST", "/api/commands", { type: "play_behaviour", behaviour, document, params }),
  cancel: (id: string) => call<unknown>("DELETE", `/api/commands/${enc(id)}`),
};
