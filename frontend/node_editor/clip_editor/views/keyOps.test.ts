import { describe, expect, it } from "vitest";
import { clipboard } from "../model/clipboard";
import type { Clip, Edited, KeyRef } from "../model/types";
import type { Commit, KeyContext } from "./keyOps";
import { keyCommand, letterOf } from "./keyOps";

const doc: Clip = {
  fps: 10,
  tracks: {
    a: [{ t: 0, v: 0 }, { t: 1, v: 1 }, { t: 2, v: 0 }],
    b: [{ t: 0.5, v: 2 }],
  },
};

function ctx(over: Partial<KeyContext> = {}) {
  const calls: { next: Edited; commit: Commit }[] = [];
  const selections: KeyRef[][] = [];
  let framed = 0;
  const c: KeyContext = {
    doc,
    selection: [],
    setSelection: (s) => selections.push(s),
    onChange: (next, commit) => calls.push({ next, commit }),
    playhead: 1.5,
    insertDofs: [],
    pasteTargets: [],
    allKeys: () => [{ dof: "a", index: 0 }, { dof: "b", index: 0 }],
    frame: () => framed++,
    ...over,
  };
  return { c, calls, selections, framed: () => framed };
}

const key = (k: string, mods: Partial<{ ctrlKey: boolean; altKey: boolean; metaKey: boolean; code: string }> = {}) =>
  ({ key: k, code: mods.code ?? `Key${k.toUpperCase()}`, ctrlKey: false, altKey: false, metaKey: false, shiftKey: false, ...mods }) as unknown as KeyboardEvent;

describe("view key commands", () => {
  it("reads Alt+letter by its physical key", () => {
    expect(letterOf({ key: "å", code: "KeyA", altKey: true })).toBe("a");
    expect(letterOf({ key: "X", code: "KeyX", altKey: false })).toBe("x");
    expect(letterOf({ key: "Delete", code: "Delete", altKey: false })).toBe("Delete");
  });

  it("X deletes the selection as one committed step", () => {
    const t = ctx({ selection: [{ dof: "a", index: 1 }] });
    expect(keyCommand(key("x"), t.c)).toBe(true);
    expect(t.calls).toHaveLength(1);
    expect(t.calls[0].commit).toEqual({ label: "Delete keys" });
    expect(t.calls[0].next.doc.tracks.a.map((k) => k.t)).toEqual([0, 2]);
    expect(keyCommand(key("Delete", { code: "Delete" }), ctx().c)).toBe(true);
  });

  it("I inserts keys at the playhead for the given DoFs, selected", () => {
    const t = ctx({ insertDofs: ["a", "c"] });
    keyCommand(key("i"), t.c);
    const next = t.calls[0].next;
    expect(next.doc.tracks.a.map((k) => k.t)).toEqual([0, 1, 1.5, 2]);
    expect(next.doc.tracks.c.map((k) => k.t)).toEqual([1.5]);
    expect(next.selection).toHaveLength(2);
    expect(t.calls[0].commit?.label).toBe("Insert keys");
  });

  it("Ctrl+C / Ctrl+V copy and paste at the playhead, into the target DoFs for one track", () => {
    const t = ctx({ selection: [{ dof: "b", index: 0 }] });
    keyCommand(key("c", { ctrlKey: true }), t.c);
    expect(clipboard.get()?.tracks.b).toHaveLength(1);
    const p = ctx({ pasteTargets: ["a"] });
    keyCommand(key("v", { ctrlKey: true }), p.c);
    expect(p.calls[0].next.doc.tracks.a.find((k) => k.t === 1.5)?.v).toBe(2);
    expect(p.calls[0].commit?.label).toBe("Paste keys");
  });

  it("A selects all, Alt+A none, Home frames; other keys are not consumed", () => {
    const t = ctx();
    keyCommand(key("a"), t.c);
    keyCommand(key("å", { altKey: true, code: "KeyA" }), t.c);
    expect(t.selections).toEqual([[{ dof: "a", index: 0 }, { dof: "b", index: 0 }], []]);
    keyCommand(key("Home", { code: "Home" }), t.c);
    expect(t.framed()).toBe(1);
    expect(keyCommand(key("z", { ctrlKey: true }), t.c)).toBe(false);
    expect(keyCommand(key("s", { ctrlKey: true }), t.c)).toBe(false);
    expect(t.calls).toHaveLength(0);
  });
});
