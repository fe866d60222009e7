import { describe, expect, it } from "vitest";
import { libraryName, nameProblem, suggestedName } from "./libraryName";

describe("library names", () => {
  it("accepts what the server accepts", () => {
    for (const n of ["idle", "calm_idle-2", "v1.2", "_x", "a".repeat(80)]) expect(nameProblem(n)).toBeNull();
  });
  it("says why a name is refused", () => {
    expect(nameProblem("")).toBe("type a name");
    expect(nameProblem("my idle")).toMatch(/no spaces/);
    expect(nameProblem("../etc")).toMatch(/start with/);
    expect(nameProblem("a".repeat(81))).toMatch(/80/);
  });
  it("stores without .json and suggests a name from a title", () => {
    expect(libraryName(" idle.json ")).toBe("idle");
    expect(suggestedName("My calm idle!")).toBe("My_calm_idle_");
    expect(suggestedName("")).toBe("program");
    expect(suggestedName(null)).toBe("program");
  });
});
