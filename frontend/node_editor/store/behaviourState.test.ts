import { describe, expect, it } from "vitest";
import { initialState, reducer, type Action, type EditorState } from "./state";

const run = (actions: Action[], from: EditorState = initialState) => actions.reduce(reducer, from);

describe("open behaviour state", () => {
  it("opens at once when none is open, showing its tab", () => {
    const s = run([{ type: "behaviourRequested", name: "greet" }]);
    expect(s.behaviour).toEqual({ name: "greet", fresh: false, seq: 1 });
    expect(s.clipTab).toBe("behaviour");
  });

  it("asks before replacing an open behaviour, and opens on grant", () => {
    const s = run([{ type: "behaviourRequested", name: "greet" }, { type: "behaviourRequested", name: "think" }]);
    expect(s.behaviour?.name).toBe("greet");
    expect(s.behaviourRequest).toEqual({ kind: "open", name: "think", fresh: false });
    const g = reducer(s, { type: "behaviourRequestGranted" });
    expect(g.behaviour).toEqual({ name: "think", fresh: false, seq: 2 });
    expect(g.behaviourRequest).toBeNull();
  });

  it("closes on grant back to the library; a dropped request keeps it open", () => {
    const s = run([{ type: "behaviourRequested", name: "greet" }, { type: "behaviourCloseRequested" }]);
    expect(reducer(s, { type: "behaviourRequestDropped" }).behaviour?.name).toBe("greet");
    const closed = reducer(s, { type: "behaviourRequestGranted" });
    expect(closed.behaviour).toBeNull();
    expect(closed.clipTab).toBe("behaviours");
  });

  it("a saved new behaviour takes its name without reloading", () => {
    const s = run([{ type: "behaviourRequested", name: "untitled", fresh: true }, { type: "behaviourSaved", name: "hop" }]);
    expect(s.behaviour).toEqual({ name: "hop", fresh: false, seq: 1 });
  });

  it("the behaviour tab without an open behaviour shows the library; the clip's state is untouched", () => {
    const s = run([{ type: "clipTabShown", tab: "behaviour" }]);
    expect(s.clipTab).toBe("behaviours");
    expect(s.clip).toBeNull();
  });
});
