// The shortcut table: the keys the handlers look up, and the list the overlay shows, are one table.
import { describe, expect, it } from "vitest";
import canvasKeys from "./hooks/useCanvasKeys.ts?raw";
import anywhereKeys from "./hooks/useShortcuts.ts?raw";
import { keyLabel, matches, shortcutOf, SHORTCUTS } from "./shortcuts";

const key = (k: string, mods: Partial<{ ctrl: boolean; meta: boolean; shift: boolean; alt: boolean }> = {}) => ({
  key: k, ctrlKey: !!mods.ctrl, metaKey: !!mods.meta, shiftKey: !!mods.shift, altKey: !!mods.alt,
});

describe("matching keys", () => {
  it("tells modifiers apart", () => {
    expect(shortcutOf(key("z", { ctrl: true }), "anywhere")).toBe("undo");
    expect(shortcutOf(key("Z", { ctrl: true, shift: true }), "anywhere")).toBe("redo");
    expect(shortcutOf(key("y", { meta: true }), "anywhere")).toBe("redo");
    expect(shortcutOf(key("Enter", { ctrl: true }), "anywhere")).toBe("goLive");
    expect(shortcutOf(key("Enter"), "anywhere")).toBeNull();
    expect(shortcutOf(key("f"), "anywhere")).toBe("fit");
    expect(shortcutOf(key("f", { ctrl: true }), "anywhere")).toBe("find");
    expect(shortcutOf(key("F", { shift: true }), "anywhere")).toBeNull();
  });
  it("finds the canvas's keys", () => {
    expect(shortcutOf(key("m"), "canvas")).toBe("bypass");
    expect(shortcutOf(key("D", { shift: true }), "canvas")).toBe("duplicate");
    expect(shortcutOf(key("d"), "canvas")).toBeNull();
    expect(shortcutOf(key("A", { shift: true }), "canvas")).toBe("quickAdd");
    expect(shortcutOf(key("Tab"), "canvas")).toBe("quickAdd");
    expect(shortcutOf(key("Tab", { shift: true }), "canvas")).toBeNull();
    expect(shortcutOf(key(" "), "canvas")).toBe("quickAdd");
    expect(shortcutOf(key("F2"), "canvas")).toBe("rename");
    expect(shortcutOf(key("a", { ctrl: true }), "anywhere")).toBe("selectAll");
  });
  it("matches punctuation whatever Shift it takes to type", () => {
    expect(matches("?", key("?", { shift: true }))).toBe(true);
    expect(shortcutOf(key("?", { shift: true }), "anywhere")).toBe("help");
    expect(shortcutOf(key("."), "anywhere")).toBe("frameSelected");
  });
  it("leaves React Flow's own keys to it", () => {
    expect(shortcutOf(key("Delete"), "canvas")).toBeNull();
    expect(SHORTCUTS.find((s) => s.id === "delete")?.by).toBe("canvas");
  });
  it("reads Mod as the platform's key", () => {
    expect(keyLabel("Mod+Shift+Z", false)).toBe("Ctrl+Shift+Z");
    expect(keyLabel("Mod+F", true)).toBe("⌘+F");
  });
});

describe("the table", () => {
  it("lists every shortcut the issue names, once", () => {
    const all = SHORTCUTS.flatMap((s) => s.keys);
    for (const k of ["Tab", "Shift+A", "Space", "Mod+A", "Mod+Z", "Mod+Y", "Mod+C", "Mod+V", "Mod+S", "Mod+Enter", "F",
      "Delete", "M", "F2", "Shift+D", "Mod+F", ".", "?"]) expect(all).toContain(k);
    expect(new Set(all).size).toBe(all.length);
    expect(new Set(SHORTCUTS.map((s) => s.id)).size).toBe(SHORTCUTS.length);
  });
  it("is what the handlers read: no key is compared by hand there", () => {
    for (const src of [anywhereKeys, canvasKeys]) {
      expect(src).toContain("shortcutOf(");
      expect(src).not.toMatch(/e\.key(\.toLowerCase\(\))? === "[a-zA-Z.?]"/);
    }
  });
});
