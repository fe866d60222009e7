import { describe, expect, it } from "vitest";
import {
  commitText, formatNumber, niceStep, parseNumber, scrubValue, sliderPosition, stepValue, type NumberSpec,
} from "./numberField";

const amplitude: NumberSpec = { softMin: 0, softMax: 1, hardMin: 0, hardMax: 100, step: 0.01 };
const offset: NumberSpec = { softMin: -1, softMax: 1, step: 0.01 };  // unbounded hard range

describe("parseNumber", () => {
  it("reads what an animator types", () => {
    expect(parseNumber("-3")).toBe(-3);
    expect(parseNumber("-0.2")).toBe(-0.2);
    expect(parseNumber(".5")).toBe(0.5);
    expect(parseNumber("1,5")).toBe(1.5);
    expect(parseNumber(" 2 ")).toBe(2);
    expect(parseNumber("1e-3")).toBe(0.001);
    expect(parseNumber("\u22122")).toBe(-2);
  });
  it("refuses the in-between states of typing and junk", () => {
    for (const t of ["", "-", ".", "abc", "1.2.3", "--1", "Infinity", "NaN"]) expect(parseNumber(t)).toBeNull();
  });
});

describe("commitText", () => {
  it("passes a value inside the hard range even beyond the soft one", () => {
    expect(commitText("5", amplitude)).toEqual({ ok: true, value: 5 });
    expect(commitText("-30", offset)).toEqual({ ok: true, value: -30 });
  });
  it("clamps to an inclusive hard bound and says so", () => {
    const c = commitText("250", amplitude);
    expect(c.ok && c.value).toBe(100);
    expect(c.ok && c.note).toMatch(/max 100/);
  });
  it("refuses text that is not a number and a value past an exclusive bound", () => {
    expect(commitText("abc", amplitude)).toEqual({ ok: false, reason: "'abc' is not a number" });
    expect(commitText("", amplitude).ok).toBe(false);
    expect(commitText("0", { hardMin: 0, minExclusive: true, step: 0.1 })).toEqual({ ok: false, reason: "must be > 0" });
  });
  it("rounds an integer field", () => {
    const c = commitText("2.6", { hardMin: 0, hardMax: 10, step: 1, integer: true });
    expect(c.ok && c.value).toBe(3);
  });
});

describe("steps", () => {
  it("steps by the step, Shift a tenth, Ctrl ten times, without float noise", () => {
    expect(stepValue(0.2, amplitude, 1)).toBe(0.21);
    expect(stepValue(0.2, amplitude, -1, { shiftKey: true })).toBe(0.199);
    expect(stepValue(0.2, amplitude, 1, { ctrlKey: true })).toBe(0.3);
    expect(stepValue(0, amplitude, -1)).toBe(0);  // the hard minimum
    expect(stepValue(0.2045, { ...amplitude, step: 0.005 }, 1, { ctrlKey: true })).toBe(0.2545);  // digits kept
  });
  it("makes round values reachable across the soft span", () => {
    expect(niceStep(1)).toBe(0.01);
    expect(niceStep(50)).toBe(0.1);
    expect(niceStep(100)).toBe(1);
    expect(niceStep(0.5)).toBe(0.001);
  });
});

describe("scrubbing the label", () => {
  it("moves one step per couple of pixels, finer with Shift, coarser with Ctrl", () => {
    expect(scrubValue(0.5, 20, amplitude)).toBe(0.6);
    expect(scrubValue(0.5, 20, amplitude, { shiftKey: true })).toBe(0.51);
    expect(scrubValue(0.5, -20, amplitude, { ctrlKey: true })).toBe(0);  // clamped at the hard minimum
    expect(scrubValue(0.5, 1, amplitude)).toBe(0.5);
  });
});

describe("display", () => {
  it("shows short numbers and pins the thumb at the soft range's ends", () => {
    expect(formatNumber(0.1 + 0.2)).toBe("0.3");
    expect(formatNumber(-3)).toBe("-3");
    expect(sliderPosition(5, amplitude)).toBe(1);
    expect(sliderPosition(0.4, amplitude)).toBe(0.4);
  });
});
