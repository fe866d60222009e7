import { describe, expect, it } from "vitest";
import { behaviourDocReducer, documentToSave, initBehaviourDoc, isDirty, newBehaviour } from "./behaviourDocState";
import type { BehaviourDoc } from "./model/types";

const base: BehaviourDoc = { format: "nutty-behaviour/1", tracks: [{ name: "body", items: [] }] };
const withTrack = (doc: BehaviourDoc, name: string): BehaviourDoc => ({ ...doc, tracks: [...(doc.tracks ?? []), { name, items: [] }] });

describe("behaviour working copy", () => {
  it("each edit is one undo step; undo and redo walk them; dirty follows the saved copy", () => {
    let s = initBehaviourDoc("greet", base);
    expect(isDirty(s)).toBe(false);
    const a = withTrack(base, "voice");
    s = behaviourDocReducer(s, { type: "edited", doc: a, label: "add track" });
    const b = withTrack(a, "face");
    s = behaviourDocReducer(s, { type: "edited", doc: b, label: "add track" });
    expect(isDirty(s)).toBe(true);
    s = behaviourDocReducer(s, { type: "undo" });
    expect(s.history.present.doc).toBe(a);
    s = behaviourDocReducer(s, { type: "undo" });
    expect(s.history.present.doc).toBe(base);
    expect(isDirty(s)).toBe(false);
    s = behaviourDocReducer(s, { type: "redo" });
    expect(s.history.present.doc).toBe(a);
  });

  it("a merged edit joins the previous step (one undo for a drag that retimes and changes lane)", () => {
    let s = initBehaviourDoc("greet", base);
    const a = withTrack(base, "voice");
    s = behaviourDocReducer(s, { type: "edited", doc: a, label: "retime" });
    s = behaviourDocReducer(s, { type: "edited", doc: withTrack(a, "face"), label: "retime", merge: true });
    expect(s.history.past.length).toBe(1);
    expect(behaviourDocReducer(s, { type: "undo" }).history.present.doc).toBe(base);
  });

  it("an edit that returns the same document adds no step", () => {
    const s = initBehaviourDoc("greet", base);
    expect(behaviourDocReducer(s, { type: "edited", doc: base, label: "retime" })).toBe(s);
  });

  it("a save makes it clean under its (new) name, unless edited meanwhile", () => {
    let s = initBehaviourDoc("untitled", base, true);
    expect(s.onServer).toBe(false);
    const a = withTrack(base, "voice");
    s = behaviourDocReducer(s, { type: "edited", doc: a, label: "add track" });
    const put = documentToSave(a, "hop", "nutty_desk");
    const saved = behaviourDocReducer(s, { type: "saved", name: "hop", sent: a, doc: put });
    expect(saved.name).toBe("hop");
    expect(saved.onServer).toBe(true);
    expect(isDirty(saved)).toBe(false);
    const b = withTrack(a, "face");
    const edited = behaviourDocReducer(s, { type: "edited", doc: b, label: "add track" });
    expect(isDirty(behaviourDocReducer(edited, { type: "saved", name: "hop", sent: a, doc: put }))).toBe(true);
  });

  it("a new behaviour has a body and a voice track and the robot's name", () => {
    const doc = newBehaviour("nutty_desk");
    expect(doc.tracks?.map((t) => t.name)).toEqual(["body", "voice"]);
    expect(documentToSave(doc, "x", null)).toMatchObject({ name: "x", robot: "nutty_desk", format: "nutty-behaviour/1" });
  });
});
