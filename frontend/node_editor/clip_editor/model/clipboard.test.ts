// Copy/paste of keys (relative times, by name across clips, one track into other DoFs, replacement)
// and the clipboard store's localStorage mirror.
import { afterEach, describe, expect, it, vi } from "vitest";
import { CLIPBOARD_STORAGE_KEY, clipboard, copyKeys, parseClipboard, pasteKeys } from "./clipboard";
import type { Clip, DofInfo } from "./types";

const doc = (): Clip => ({
  tracks: {
    a: [{ t: 1, v: 0 }, { t: 2, v: 1, right_type: "free", right: [0.2, 0.3] }, { t: 3, v: 0 }],
    b: [{ t: 1.5, v: 5 }],
    led: [{ t: 0, v: [1, 0, 0] }],
  },
});

describe("copyKeys", () => {
  it("copies selected keys with times relative to the earliest one", () => {
    const cb = copyKeys(doc(), [{ dof: "a", index: 1 }, { dof: "b", index: 0 }, { dof: "a", index: 2 }]);
    expect(cb.tracks).toEqual({
      a: [{ t: 0.5, v: 1, right_type: "free", right: [0.2, 0.3] }, { t: 1.5, v: 0 }],
      b: [{ t: 0, v: 5 }],
    });
  });
});

describe("pasteKeys", () => {
  const cb = { tracks: { a: [{ t: 0, v: 9 }, { t: 0.5, v: 8 }] } };

  it("pastes by DoF name at t, replacing keys at the same time, selecting the pasted keys", () => {
    const r = pasteKeys(doc(), cb, 2);
    expect(r.doc.tracks.a).toEqual([{ t: 1, v: 0 }, { t: 2, v: 9 }, { t: 2.5, v: 8 }, { t: 3, v: 0 }]);
    expect(r.selection).toEqual([{ dof: "a", index: 1 }, { dof: "a", index: 2 }]);
  });

  it("pastes one track into each target DoF (across DoFs), creating tracks", () => {
    const d = doc();
    const r = pasteKeys(d, cb, 0, ["b", "c"]);
    expect(r.doc.tracks.b).toEqual([{ t: 0, v: 9 }, { t: 0.5, v: 8 }, { t: 1.5, v: 5 }]);
    expect(r.doc.tracks.c).toEqual([{ t: 0, v: 9 }, { t: 0.5, v: 8 }]);
    expect(r.doc.tracks.a).toBe(d.tracks.a);
    expect(r.selection).toEqual([
      { dof: "b", index: 0 }, { dof: "b", index: 1 }, { dof: "c", index: 0 }, { dof: "c", index: 1 },
    ]);
  });

  it("skips DoFs that cannot take the values", () => {
    const r = pasteKeys(doc(), cb, 0, ["led"]);
    expect(r.doc.tracks.led).toEqual([{ t: 0, v: [1, 0, 0] }]);
    const robot: DofInfo[] = [{ name: "b", type: "continuous", min: 0, max: 1, rest: 0, velocity: 1, group: "Joints" }];
    const r2 = pasteKeys(doc(), cb, 0, ["b", "zzz"], { dofs: robot });
    expect("zzz" in r2.doc.tracks).toBe(false);
    expect(r2.doc.tracks.b).toHaveLength(3);
  });

  it("does not share arrays with the clipboard", () => {
    const src = { tracks: { led: [{ t: 0, v: [0, 1, 0] }] } };
    const r = pasteKeys(doc(), src, 1);
    (r.doc.tracks.led[1].v as number[])[0] = 7;
    expect(src.tracks.led[0].v).toEqual([0, 1, 0]);
  });
});

describe("clipboard store", () => {
  afterEach(() => {
    clipboard.set(null);
    vi.unstubAllGlobals();
  });

  it("keeps the keys, mirrors them in localStorage and notifies", () => {
    const store = new Map<string, string>();
    vi.stubGlobal("localStorage", {
      getItem: (k: string) => store.get(k) ?? null,
      setItem: (k: string, v: string) => store.set(k, v),
      removeItem: (k: string) => store.delete(k),
    });
    const seen: number[] = [];
    const off = clipboard.subscribe(() => seen.push(1));
    const cb = { tracks: { a: [{ t: 0, v: 1 }] } };
    clipboard.set(cb);
    expect(clipboard.get()).toEqual(cb);
    expect(JSON.parse(store.get(CLIPBOARD_STORAGE_KEY) ?? "null")).toEqual(cb);
    off();
    expect(seen).toHaveLength(1);
  });

  it("reads a clipboard stored by an earlier page (and ignores a corrupt one)", () => {
    clipboard.set(null);
    vi.stubGlobal("localStorage", {
      getItem: () => JSON.stringify({ tracks: { b: [{ t: 0.5, v: "smile" }] } }),
      setItem: () => undefined,
      removeItem: () => undefined,
    });
    expect(clipboard.get()).toEqual({ tracks: { b: [{ t: 0.5, v: "smile" }] } });
    expect(parseClipboard({ tracks: { b: [{ v: 1 }] } })).toBeNull();
    expect(parseClipboard("nope")).toBeNull();
  });
});
