// Copy and paste of keys: copied keys keep their times relative to the earliest one, and paste into
// the same DoFs (across clips) or, from one track, into other DoFs. The clipboard itself lives in this
// module and in localStorage ("nutty.clipboard/1"), so it survives switching clips and reloading.
import { clampTime } from "./snap";
import { rebuild, selectionMap } from "./tracks";
import type { Entry } from "./tracks";
import type { Clip, ClipboardKeys, DofInfo, Edited, KeyRef, Keyframe } from "./types";

const copyKey = (k: Keyframe, t: number): Keyframe => {
  const out: Keyframe = { ...k, t };
  if (Array.isArray(k.v)) out.v = [...k.v];
  if (k.left) out.left = [k.left[0], k.left[1]];
  if (k.right) out.right = [k.right[0], k.right[1]];
  return out;
};

/** The selected keys, per track, with times relative to the earliest selected key. */
export function copyKeys(doc: Clip, sel: readonly KeyRef[]): ClipboardKeys {
  const map = selectionMap(doc, sel);
  let t0 = Infinity;
  for (const [dof, idx] of map) for (const i of idx) t0 = Math.min(t0, doc.tracks[dof][i].t);
  const tracks: Record<string, Keyframe[]> = {};
  for (const [dof, idx] of map) {
    tracks[dof] = [...idx].sort((a, b) => a - b).map((i) => copyKey(doc.tracks[dof][i], doc.tracks[dof][i].t - t0));
  }
  return { tracks };
}

type ValueKind = "number" | "string" | "colour" | "other";
const kindOf = (v: Keyframe["v"]): ValueKind =>
  typeof v === "number" ? "number" : typeof v === "string" ? "string" : Array.isArray(v) ? "colour" : "other";

/** Whether keys of this value kind fit the DoF (enum DoFs take option names or indices). */
function fits(kind: ValueKind, doc: Clip, dof: string, info: DofInfo | undefined): boolean {
  if (info) {
    if (info.type === "continuous") return kind === "number";
    if (info.type === "colour") return kind === "colour";
    return kind === "string" || kind === "number";
  }
  const existing = doc.tracks[dof]?.[0];
  return !existing || kindOf(existing.v) === kind;
}

export interface PasteOptions {
  /** the robot's DoFs: paste skips DoFs it lacks and values of the wrong kind */
  dofs?: readonly DofInfo[];
}

/** Paste at time t (s). One copied track and `targetDofs` given: into each target DoF; otherwise into
 * the DoFs the keys were copied from. A pasted key replaces a key already at its time; tracks that
 * cannot take the values (another kind of value, or a DoF the robot lacks) are skipped. The pasted
 * keys come back selected. */
export function pasteKeys(
  doc: Clip,
  cb: ClipboardKeys,
  t: number,
  targetDofs?: readonly string[],
  opts: PasteOptions = {},
): Edited {
  const sources = Object.entries(cb.tracks).filter(([, keys]) => keys.length);
  const plan: [string, Keyframe[]][] =
    sources.length === 1 && targetDofs?.length ? targetDofs.map((d) => [d, sources[0][1]]) : sources;
  const infos = opts.dofs ? new Map(opts.dofs.map((d) => [d.name, d])) : null;
  const changes = new Map<string, Entry[]>();
  for (const [dof, keys] of plan) {
    if (changes.has(dof)) continue;
    const info = infos?.get(dof);
    if (infos && !info) continue;
    if (!keys.every((k) => fits(kindOf(k.v), doc, dof, info))) continue;
    const existing = doc.tracks[dof] ?? [];
    const entries: Entry[] = existing.map((key, order) => ({ key, moved: false, sel: false, order }));
    keys.forEach((k, i) =>
      entries.push({ key: copyKey(k, clampTime(t + k.t)), moved: true, sel: true, order: existing.length + i }),
    );
    changes.set(dof, entries);
  }
  return rebuild(doc, changes);
}

// ---------------------------------------------------------------------------------------------------
// The clipboard store
// ---------------------------------------------------------------------------------------------------

export const CLIPBOARD_STORAGE_KEY = "nutty.clipboard/1";

const isKey = (k: unknown): k is Keyframe => {
  if (typeof k !== "object" || k === null) return false;
  const r = k as Record<string, unknown>;
  return typeof r.t === "number" && (typeof r.v === "number" || typeof r.v === "string" || Array.isArray(r.v));
};

/** A clipboard read back from storage, or null when it is not one. */
export function parseClipboard(value: unknown): ClipboardKeys | null {
  if (typeof value !== "object" || value === null) return null;
  const tracks = (value as { tracks?: unknown }).tracks;
  if (typeof tracks !== "object" || tracks === null) return null;
  const out: Record<string, Keyframe[]> = {};
  for (const [dof, keys] of Object.entries(tracks)) {
    if (!Array.isArray(keys) || !keys.every(isKey)) return null;
    out[dof] = keys;
  }
  return { tracks: out };
}

function storage(): Storage | null {
  try {
    return typeof globalThis.localStorage === "undefined" ? null : globalThis.localStorage;
  } catch {
    return null; // storage access can throw (privacy settings, sandboxed frames)
  }
}

let memory: ClipboardKeys | null = null;
const listeners = new Set<() => void>();

/** The copied keys: get/set, mirrored in localStorage; `subscribe` tells when they change. */
export const clipboard = {
  get(): ClipboardKeys | null {
    if (memory) return memory;
    const text = storage()?.getItem(CLIPBOARD_STORAGE_KEY);
    if (!text) return null;
    try {
      memory = parseClipboard(JSON.parse(text));
    } catch {
      memory = null; // a corrupt entry is no clipboard
    }
    return memory;
  },
  set(cb: ClipboardKeys | null): void {
    memory = cb;
    const s = storage();
    try {
      if (cb) s?.setItem(CLIPBOARD_STORAGE_KEY, JSON.stringify(cb));
      else s?.removeItem(CLIPBOARD_STORAGE_KEY);
    } catch {
      // over quota or blocked: the in-memory clipboard still works for this page
    }
    listeners.forEach((fn) => fn());
  },
  subscribe(fn: () => void): () => void {
    listeners.add(fn);
    return () => listeners.delete(fn);
  },
};
