import { describe, expect, it } from "vitest";
import { initialState, reducer, type Action, type EditorState } from "./state";

const run = (actions: Action[], from: EditorState = initialState) => actions.reduce(reducer, from);

describe("open clip state", () => {
  it("opens at once when no clip is open, showing the clip tab", () => {
    const s = run([{ type: "clipRequested", name: "wave" }]);
    expect(s.clip).toEqual({ name: "wave", fresh: false, seq: 1 });
    expect(s.clipTab).toBe("clip");
    expect(s.clipRequest).toBeNull();
  });

  it("asks the clip editor before replacing an open clip, and opens on grant", () => {
    const s = run([{ type: "clipRequested", name: "wave" }, { type: "clipRequested", name: "nod", fresh: true }]);
    expect(s.clip?.name).toBe("wave");
    expect(s.clipRequest).toEqual({ kind: "open", name: "nod", fresh: true });
    const granted = reducer(s, { type: "clipRequestGranted" });
    expect(granted.clip).toEqual({ name: "nod", fresh: true, seq: 2 });
    expect(granted.clipRequest).toBeNull();
    const dropped = reducer(s, { type: "clipRequestDropped" });
    expect(dropped.clip?.name).toBe("wave");
    expect(dropped.clipRequest).toBeNull();
  });

  it("closes on grant and goes back to the program", () => {
    const s = run([{ type: "clipRequested", name: "wave" }, { type: "clipCloseRequested" }, { type: "clipRequestGranted" }]);
    expect(s.clip).toBeNull();
    expect(s.clipTab).toBe("program");
  });

  it("cannot show the clip tab with no clip open", () => {
    expect(run([{ type: "clipTabShown", tab: "clip" }]).clipTab).toBe("library");
    expect(run([{ type: "clipTabShown", tab: "library" }]).clipTab).toBe("library");
  });
});

describe("a new clip saved", () => {
  it("is no longer fresh, and keeps its open (no reload)", () => {
    const s = run([{ type: "clipRequested", name: "new_one", fresh: true }, { type: "clipSaved" }]);
    expect(s.clip).toEqual({ name: "new_one", fresh: false, seq: 1 });
  });
});
