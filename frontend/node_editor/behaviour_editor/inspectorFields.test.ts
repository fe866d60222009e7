import { describe, expect, it } from "vitest";
import { KIND_FIELDS, fieldText, parseField } from "./inspectorFields";
import { KIND_ORDER } from "./model/types";

describe("inspector fields", () => {
  it("every kind has its required field first", () => {
    for (const kind of KIND_ORDER) expect(KIND_FIELDS[kind]).toBeDefined();
    expect(KIND_FIELDS.play_clip[0].field).toBe("clip");
    expect(KIND_FIELDS.say[0].field).toBe("text");
  });

  it("parses numbers, triples and keeps {param} references as text", () => {
    expect(parseField({ type: "number" }, " 1.5")).toBe(1.5);
    expect(parseField({ type: "number" }, "{speed}")).toBe("{speed}");
    expect(parseField({ type: "number", optional: true }, "")).toBeUndefined();
    expect(parseField({ type: "triple" }, "[1, 0.8, 0.2]")).toEqual([1, 0.8, 0.2]);
    expect(parseField({ type: "triple" }, "{target}")).toBe("{target}");
    expect(parseField({ type: "numberOrTriple" }, "0.5")).toBe(0.5);
    expect(parseField({ type: "numberOrTriple" }, "0 1 2")).toEqual([0, 1, 2]);
    expect(parseField({ type: "text" }, "Hello {name}!")).toBe("Hello {name}!");
  });

  it("shows values as text", () => {
    expect(fieldText([1, 0.8, 0.2])).toBe("1, 0.8, 0.2");
    expect(fieldText(null)).toBe("");
    expect(fieldText(2)).toBe("2");
  });
});
