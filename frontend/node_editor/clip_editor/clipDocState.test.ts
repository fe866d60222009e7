import { describe, expect, it } from "vitest";
import { clipDocReducer, docKey, documentToSave, initClipDoc, isDirty, type ClipDocAction, type ClipDocState } from "./clipDocState";
import type { Clip } from "./model/types";

const clip = (v: number): Clip => ({ format: "nutty-clip/1", name: "c", tracks: { head: [{ t: 0, v }, { t: 1, v: v + 1 }] } });
const run = (actions: ClipDocAction[], from: ClipDocState = initClipDoc("c", clip(0))) => actions.reduce(clipDocReducer, from);
const change = (doc: Clip, label: string | null): ClipDocAction =>
  ({ type: "changed", next: { doc, selection: [{ dof: "head", index: 0 }] }, commit: label === null ? null : { label } });

describe("clip document history", () => {
  it("makes one undo step of a drag's transient steps and its commit, from the pre-drag document", () => {
    const start = initClipDoc("c", clip(0));
    const a = clip(1), b = clip(2), c = clip(3);
    const s = run([change(a, null), change(b, null), change(c, "move keys")], start);
    expect(s.history.present.doc).toBe(c);
    expect(s.history.past.map((p) => p.doc)).toEqual([start.history.present.doc]);
    expect(s.dragBase).toBeNull();
    const undone = clipDocReducer(s, { type: "undo" });
    expect(undone.history.present.doc).toBe(start.history.present.doc);
    expect(clipDocReducer(undone, { type: "redo" }).history.present.doc).toBe(c);
  });

  it("shows a transient step without recording it", () => {
    const s = run([change(clip(5), null)]);
    expect(s.history.present.doc.tracks.head[0].v).toBe(5);
    expect(s.history.past).toHaveLength(0);
    expect(s.dragBase).not.toBeNull();
  });

  it("records a click edit (commit at once) as one step with its label", () => {
    const s = run([change(clip(1), "insert key"), change(clip(2), "delete keys")]);
    expect(s.history.past).toHaveLength(2);
    expect(s.history.present.label).toBe("delete keys");
  });

  it("records nothing for a drag that ends where it started", () => {
    const start = initClipDoc("c", clip(0));
    const s = run([change(clip(4), null), change(start.history.present.doc, "move keys")], start);
    expect(s.history.past).toHaveLength(0);
    expect(s.history.present.doc).toBe(start.history.present.doc);
  });

  it("undo during a drag drops the drag and undoes the step before it", () => {
    const s = run([change(clip(1), "a"), change(clip(9), null), { type: "undo" }]);
    expect(s.history.present.doc.tracks.head[0].v).toBe(0);
    expect(s.dragBase).toBeNull();
  });

  it("keeps selection changes out of the history but restores a step's selection on undo", () => {
    const s = run([{ type: "selected", selection: [{ dof: "head", index: 1 }] }, change(clip(1), "a")]);
    expect(s.history.past).toHaveLength(1);
    expect(s.history.present.selection).toEqual([{ dof: "head", index: 0 }]);
    expect(clipDocReducer(s, { type: "undo" }).history.present.selection).toEqual([{ dof: "head", index: 1 }]);
  });

  it("drops the redo branch on a new edit", () => {
    const s = run([change(clip(1), "a"), { type: "undo" }, change(clip(2), "b")]);
    expect(s.history.future).toHaveLength(0);
  });
});

describe("dirty", () => {
  it("is clean when loaded, dirty after an edit, clean again after undo and after a save", () => {
    const start = initClipDoc("c", clip(0));
    expect(isDirty(start)).toBe(false);
    const edited = run([change(clip(1), "a")], start);
    expect(isDirty(edited)).toBe(true);
    expect(isDirty(clipDocReducer(edited, { type: "undo" }))).toBe(false);
    const sent = edited.history.present.doc;
    const body = documentToSave(sent, "c", "nutty", 30);
    const saved = clipDocReducer(edited, { type: "saved", sent, doc: body });
    expect(isDirty(saved)).toBe(false);
    expect(saved.history.present.doc).toBe(body);
    expect(saved.onServer).toBe(true);
  });

  it("stays dirty when edited while the save was on its way", () => {
    const edited = run([change(clip(1), "a")]);
    const sent = edited.history.present.doc;
    const later = clipDocReducer(edited, change(clip(2), "b"));
    const saved = clipDocReducer(later, { type: "saved", sent, doc: documentToSave(sent, "c", null, 30) });
    expect(isDirty(saved)).toBe(true);
  });

  it("compares content, not key order", () => {
    expect(docKey({ tracks: {}, name: "a" })).toBe(docKey({ name: "a", tracks: {} }));
    expect(docKey({ tracks: { x: [{ t: 0, v: 1 }] } })).not.toBe(docKey({ tracks: { x: [{ t: 0, v: 2 }] } }));
  });

  it("a new clip is not dirty until edited, and is not on the server", () => {
    const s = initClipDoc("new", { tracks: {} }, true);
    expect(isDirty(s)).toBe(false);
    expect(s.onServer).toBe(false);
  });
});

describe("documentToSave", () => {
  it("sets format, name, robot and fps, keeping the clip's own robot and fps", () => {
    expect(documentToSave({ tracks: {} }, "wave", "nutty", 30)).toEqual({ tracks: {}, format: "nutty-clip/1", name: "wave", robot: "nutty", fps: 30 });
    expect(documentToSave({ tracks: {}, robot: "other", fps: 24, name: "old" }, "wave", "nutty", 30))
      .toMatchObject({ name: "wave", robot: "other", fps: 24 });
  });
});

describe("documentToSave", () => {
  it("keeps a clip long enough for an anchor or event after its last key", () => {
    const doc = { tracks: { head_pitch: [{ t: 0, v: 0 }, { t: 1, v: 0.2 }] }, anchors: { beat: 1.5 },
      events: [{ t: 1.8, dof: "sound", kind: "sound", payload: {} }] };
    expect(documentToSave(doc, "c", "nutty", 30).duration).toBe(1.8);
    expect(documentToSave({ ...doc, anchors: {}, events: [] }, "c", "nutty", 30).duration).toBeUndefined();
    expect(documentToSave({ ...doc, duration: 3 }, "c", "nutty", 30).duration).toBe(3);
  });
});
