// A number field's rules, apart from React: what typed text means, how far an arrow key or a drag on
// the label moves the value, and what the hard range allows. The slider spans the soft range (where a
// value usually lives); typing may go beyond it up to the hard range (what the block accepts).
//
// Policy for typed text on commit: text that is not a number is refused (the field says why and shows
// the value it had); a number beyond the hard range is clamped to it (and the field says so), except
// beyond an exclusive bound (`> 0`), which has no nearest value and is refused.

export interface NumberSpec {
  /** The slider's range; absent: no slider. */
  softMin?: number;
  softMax?: number;
  /** What the block accepts; absent: unbounded on that side. */
  hardMin?: number;
  hardMax?: number;
  /** The hard bound itself is not allowed (JSON Schema `exclusiveMinimum`/`exclusiveMaximum`). */
  minExclusive?: boolean;
  maxExclusive?: boolean;
  /** The slider's and the arrow keys' step. */
  step: number;
  integer?: boolean;
}

export type Commit = { ok: true; value: number; note?: string } | { ok: false; reason: string };

/** How much of a step a modifier makes: Shift fine, Ctrl (or Cmd) coarse. */
export interface Modifiers { shiftKey?: boolean; ctrlKey?: boolean; metaKey?: boolean }

export const stepFactor = (m: Modifiers): number => (m.shiftKey ? 0.1 : m.ctrlKey || m.metaKey ? 10 : 1);

/** Pixels of horizontal drag on the label per step. */
export const SCRUB_PX_PER_STEP = 2;
/** A press on the label that moves less than this (px) is a click: it focuses the text. */
export const SCRUB_THRESHOLD_PX = 3;

/** A step that makes round values reachable across `span`: 0.01 for 0..1, 0.1 for 0..50, 1 for 0..100. */
export function niceStep(span: number): number {
  if (!(span > 0) || !Number.isFinite(span)) return 0.01;
  return Math.pow(10, Math.floor(Math.log10(span) + 1e-9) - 2);
}

/** The number typed, or null: accepts "-3", ".5", "-0.2", "1e-3", "1,5" (a decimal comma), "1."; not "", "-", "abc". */
export function parseNumber(text: string): number | null {
  const t = text.trim().replace(/^([+-]?\d*),(\d+)$/, "$1.$2").replace("\u2212", "-");
  if (!/^[+-]?(\d+\.?\d*|\.\d+)([eE][+-]?\d+)?$/.test(t)) return null;
  const v = Number(t);
  return Number.isFinite(v) ? v : null;
}

/** `v` inside the hard range (an exclusive bound is not clamped to: see commitValue). */
export function clampHard(v: number, spec: NumberSpec): number {
  let out = v;
  if (spec.hardMin !== undefined && !spec.minExclusive) out = Math.max(spec.hardMin, out);
  if (spec.hardMax !== undefined && !spec.maxExclusive) out = Math.min(spec.hardMax, out);
  return out;
}

/** A value checked against the hard range: clamped to an inclusive bound, refused past an exclusive one. */
export function commitValue(v: number, spec: NumberSpec): Commit {
  const value = spec.integer ? Math.round(v) : v;
  if (spec.minExclusive && spec.hardMin !== undefined && value <= spec.hardMin) return { ok: false, reason: `must be > ${spec.hardMin}` };
  if (spec.maxExclusive && spec.hardMax !== undefined && value >= spec.hardMax) return { ok: false, reason: `must be < ${spec.hardMax}` };
  const clamped = clampHard(value, spec);
  if (clamped !== value) return { ok: true, value: clamped, note: `limited to ${clamped < value ? "max" : "min"} ${formatNumber(clamped)}` };
  return { ok: true, value, ...(value !== v ? { note: "a whole number" } : {}) };
}

/** Typed text on Enter or blur: the value to send, or why not. */
export function commitText(text: string, spec: NumberSpec): Commit {
  const v = parseNumber(text);
  if (v === null) return { ok: false, reason: text.trim() ? `'${text.trim()}' is not a number` : "type a number" };
  return commitValue(v, spec);
}

/** `v` without float noise (0.1 + 0.2 is 0.3), its own digits kept (0.2045 + 0.05 is 0.2545). */
export const clean = (v: number): number => Number(v.toPrecision(12));

/** One arrow-key step up (+1) or down (-1) from `v`, scaled by the modifiers, inside the hard range. */
export function stepValue(v: number, spec: NumberSpec, direction: 1 | -1, m: Modifiers = {}): number {
  const step = Math.max(spec.integer ? 1 : 0, spec.step * stepFactor(m));
  return clampHard(clean(v + direction * step), spec);
}

/** The value after dragging the label `dx` pixels from where it was `start`. */
export function scrubValue(start: number, dx: number, spec: NumberSpec, m: Modifiers = {}): number {
  const step = Math.max(spec.integer ? 1 : 0, spec.step * stepFactor(m));
  const steps = Math.trunc(dx / SCRUB_PX_PER_STEP);
  const v = clean(start + steps * step);
  const c = commitValue(v, spec);
  return c.ok ? c.value : start;
}

/** The value as the text box shows it: up to 6 significant digits, no trailing zeros. */
export function formatNumber(v: number): string {
  if (!Number.isFinite(v)) return "";
  return String(Number(v.toPrecision(6)));
}

/** Where the slider's thumb sits for `v`: the soft range's end when the value lies beyond it. */
export function sliderPosition(v: number, spec: NumberSpec): number {
  const lo = spec.softMin ?? -Infinity, hi = spec.softMax ?? Infinity;
  return Math.min(hi, Math.max(lo, v));
}
