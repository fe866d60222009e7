// The find box's matches: by name first, then by type, fuzzy last.
import { describe, expect, it } from "vitest";
import type { BlockEntry } from "./api";
import { findBlocks } from "./findBlock";
import type { FlowNode } from "./graph";
import blocks from "./generated/blocks.json";

const catalog: Record<string, BlockEntry> = Object.fromEntries((blocks as unknown as BlockEntry[]).map((b) => [b.type, b]));
const node = (id: string, type: string, kind: FlowNode["type"] = "block"): FlowNode =>
  ({ id, type: kind, position: { x: 0, y: 0 }, data: { type, params: {}, ui: {}, inputs: {}, outputs: {}, errors: [] } });
const nodes = [
  node("wander_filter", "motion_filter"), node("eyelid_filter", "motion_filter"), node("nmf", "nmf_stage2"),
  node("breath", "breathe"), node("note-1", "comment", "comment"), node("output", "output"),
];

describe("find block", () => {
  it("ranks names before types, and skips annotations", () => {
    expect(findBlocks(nodes, catalog, "nmf").map((f) => f.id)[0]).toBe("nmf");  // then the filters, by title
    expect(findBlocks(nodes, catalog, "filter").map((f) => f.id).slice(0, 2)).toEqual(["eyelid_filter", "wander_filter"]);
    expect(findBlocks(nodes, catalog, "motion").map((f) => f.id)).toEqual(["eyelid_filter", "nmf", "wander_filter"]);  // by title
    expect(findBlocks(nodes, catalog, "").map((f) => f.id)).not.toContain("note-1");
  });
  it("finds by letters in order", () => {
    expect(findBlocks(nodes, catalog, "wf").map((f) => f.id)[0]).toBe("wander_filter");
    expect(findBlocks(nodes, catalog, "zzz")).toEqual([]);
  });
  it("names the block's type", () => {
    expect(findBlocks(nodes, catalog, "breath")[0]).toMatchObject({ id: "breath", type: "breathe", title: catalog.breathe.title });
  });
});
