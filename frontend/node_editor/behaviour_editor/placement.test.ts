import { describe, expect, it } from "vitest";
import { trackForKind } from "./placement";

const doc = { tracks: [{ name: "body", items: [] }, { name: "Voice", items: [] }, { name: "misc", items: [] }] };

describe("new item placement", () => {
  it("puts an item on the lane named for its kind", () => {
    expect(trackForKind(doc, "say", 2)).toBe(1);
    expect(trackForKind(doc, "play_clip", 2)).toBe(0);
  });
  it("else on the selected item's lane, else the first", () => {
    expect(trackForKind(doc, "set_emotion", 2)).toBe(2);
    expect(trackForKind(doc, "set_emotion", null)).toBe(0);
    expect(trackForKind(doc, "set_emotion", 7)).toBe(0);
  });
});
