import { describe, expect, it } from "vitest";
import { activeAfter } from "./useRobotPlay";

describe("items under way on the robot", () => {
  it("an item is active from its started event to its ending one", () => {
    let a: ReadonlySet<string> = new Set();
    a = activeAfter(a, "wave", "started");
    a = activeAfter(a, "hello", "started");
    expect([...a]).toEqual(["wave", "hello"]);
    a = activeAfter(a, "wave", "completed");
    a = activeAfter(a, "hello", "cancelled");
    expect([...a]).toEqual([]);
  });
  it("an unknown state changes nothing", () => {
    const a = new Set(["wave"]);
    expect([...activeAfter(a, "wave", "progress")]).toEqual(["wave"]);
  });
});
