import { describe, expect, it } from "vitest";
import { formatParam, parseParam, previewParams, removeParam, renameParam, setParam, validParamName } from "./paramValues";

describe("parameter values", () => {
  it("parses by type", () => {
    expect(parseParam("number", " 0.5 ")).toEqual({ ok: true, value: 0.5 });
    expect(parseParam("number", "abc").ok).toBe(false);
    expect(parseParam("bool", "True")).toEqual({ ok: true, value: true });
    expect(parseParam("bool", "off")).toEqual({ ok: true, value: false });
    expect(parseParam("bool", "maybe").ok).toBe(false);
    expect(parseParam("string", "Hello Ada")).toEqual({ ok: true, value: "Hello Ada" });
  });

  it("a vec3 is a point with or without brackets, or an input's name", () => {
    expect(parseParam("vec3", "[1, 0, 0.35]")).toEqual({ ok: true, value: [1, 0, 0.35] });
    expect(parseParam("vec3", "1 0 -2e-1")).toEqual({ ok: true, value: [1, 0, -0.2] });
    expect(parseParam("vec3", "person")).toEqual({ ok: true, value: "person" });
    expect(parseParam("vec3", "1, 2").ok).toBe(false);
  });

  it("preview params leave empty fields to their defaults and report bad ones", () => {
    const decls = { name: { type: "string" as const }, n: { type: "number" as const }, at: { type: "vec3" as const } };
    const r = previewParams(decls, { name: "Ada", n: "x", at: "" });
    expect(r.params).toEqual({ name: "Ada" });
    expect(r.errors).toEqual({ n: "a number" });
  });

  it("formats values back for fields and checks names", () => {
    expect(formatParam([1, 0, 0.35])).toBe("1, 0, 0.35");
    expect(formatParam(undefined)).toBe("");
    expect(validParamName("name_2")).toBe(true);
    expect(validParamName("2name")).toBe(false);
  });
});

describe("parameter declarations", () => {
  const doc = { params: { a: { type: "number" as const }, b: { type: "string" as const } } };
  it("renames in place, refusing a taken or bad name", () => {
    expect(Object.keys(renameParam(doc, "a", "c").params ?? {})).toEqual(["c", "b"]);
    expect(renameParam(doc, "a", "b")).toBe(doc);
    expect(renameParam(doc, "a", "1x")).toBe(doc);
  });
  it("adds, replaces and removes without touching the input", () => {
    const added = setParam(doc, "name", { type: "string", default: "friend" });
    expect(Object.keys(added.params ?? {})).toEqual(["a", "b", "name"]);
    expect(Object.keys(removeParam(added, "a").params ?? {})).toEqual(["b", "name"]);
    expect(Object.keys(doc.params)).toEqual(["a", "b"]);
  });
});
