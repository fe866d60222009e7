// An exact port of backend/engine/curves.py for one curve: easing presets, handle resolution and the
// reference evaluation (`CurveSet.evaluate_reference`), with the same arithmetic order so the editor
// draws what the engine plays (checked against Python-generated values in curveCases.json).
// Plus `numericKeys`, compile_clip's per-channel conversion of enum and colour tracks.
import type { DofInfo, Easing, Handle, Interp, Keyframe } from "./types";

/** A key whose value is a number (one channel of a track, as the engine evaluates it). */
export type NumericKey = Keyframe & { v: number };

export interface ResolvedHandles {
  left: Handle;
  right: Handle;
}

// Python's 2-argument min/max (first argument wins ties and NaN comparisons), not Math.min/max.
const pyMin = (a: number, b: number): number => (b < a ? b : a);
const pyMax = (a: number, b: number): number => (b > a ? b : a);
const copysign = (x: number, y: number): number =>
  y < 0 || Object.is(y, -0) ? -Math.abs(x) : Math.abs(x);

const num = (v: Keyframe["v"]): number => (typeof v === "number" ? v : Number.NaN);

const POWERS: Record<string, number> = { quad: 2, cubic: 3, quart: 4, quint: 5 };

function bounceOut(u: number): number {
  const n = 7.5625;
  const d = 2.75;
  if (u < 1 / d) return n * u * u;
  if (u < 2 / d) return n * (u - 1.5 / d) ** 2 + 0.75;
  if (u < 2.5 / d) return n * (u - 2.25 / d) ** 2 + 0.9375;
  return n * (u - 2.625 / d) ** 2 + 0.984375;
}

function easeIn(name: string, u: number): number {
  switch (name) {
    case "sine":
      return 1.0 - Math.cos((u * Math.PI) / 2);
    case "quad":
    case "cubic":
    case "quart":
    case "quint":
      return u ** POWERS[name];
    case "expo":
      return u <= 0.0 ? 0.0 : 2.0 ** (10.0 * pyMin(u, 1.0) - 10.0) - (1 - u) * 2.0 ** -10;
    case "circ":
      return 1.0 - Math.sqrt(pyMax(0.0, 1.0 - u * u));
    case "back": {
      const c1 = 1.70158;
      return (c1 + 1) * u ** 3 - c1 * u ** 2;
    }
    case "elastic":
      if (u <= 0.0) return 0.0;
      if (u >= 1.0) return 1.0;
      return -(2.0 ** (10 * u - 10)) * Math.sin((u * 10 - 10.75) * ((2 * Math.PI) / 3));
    case "bounce":
      return 1.0 - bounceOut(1.0 - u);
    default:
      throw new Error(`unknown easing '${name}'`);
  }
}

/** Eased fraction for u in [0, 1] (clipped): `in` starts slowly, `out` ends slowly, `in_out` both. */
export function ease(name: string, mode: Easing | string, u: number): number {
  const x = pyMin(pyMax(u, 0.0), 1.0);
  if (mode === "in") return easeIn(name, x);
  if (mode === "out") return 1.0 - easeIn(name, 1.0 - x);
  if (mode === "in_out") return x < 0.5 ? 0.5 * easeIn(name, 2 * x) : 1.0 - 0.5 * easeIn(name, 2 - 2 * x);
  throw new Error(`unknown easing mode '${mode}'`);
}

// ---------------------------------------------------------------------------------------------------
// Handles (resolve_handles and its helpers, line by line)
// ---------------------------------------------------------------------------------------------------

function autoSlope(keys: readonly Keyframe[], i: number, clamped: boolean): number {
  const k = keys[i];
  if (keys.length === 1) return 0.0;
  if (i === 0 || i === keys.length - 1) {
    if (clamped) return 0.0;
    const other = i === 0 ? keys[1] : keys[keys.length - 2];
    return (num(other.v) - num(k.v)) / (other.t - k.t);
  }
  const prev = keys[i - 1];
  const nxt = keys[i + 1];
  let slope = (num(nxt.v) - num(prev.v)) / (nxt.t - prev.t);
  if (clamped) {
    if ((num(k.v) - num(prev.v)) * (num(nxt.v) - num(k.v)) <= 0.0) return 0.0;
    const s0 = (num(k.v) - num(prev.v)) / (k.t - prev.t);
    const s1 = (num(nxt.v) - num(k.v)) / (nxt.t - k.t);
    const limit = 3.0 * pyMin(Math.abs(s0), Math.abs(s1));
    slope = copysign(pyMin(Math.abs(slope), limit), slope);
  }
  return slope;
}

const given = (h: Keyframe["left"]): Handle | null => (h == null ? null : [Number(h[0]), Number(h[1])]);

function handleOf(keys: readonly Keyframe[], i: number, side: "left" | "right", span: number): Handle {
  const k = keys[i];
  const kind = (side === "left" ? k.left_type : k.right_type) ?? "auto_clamped";
  const g = given(side === "left" ? k.left : k.right);
  const sign = side === "left" ? -1.0 : 1.0;
  if ((kind === "free" || kind === "aligned") && g !== null) return g;
  if (kind === "vector") {
    const j = side === "left" ? i - 1 : i + 1;
    if (j >= 0 && j < keys.length) return [(keys[j].t - k.t) / 3.0, (num(keys[j].v) - num(k.v)) / 3.0];
    return [0.0, 0.0];
  }
  const slope = autoSlope(keys, i, kind !== "auto");
  const dt = (sign * span) / 3.0;
  return [dt, slope * dt];
}

function align(other: Handle, span: number, g: Handle | null): Handle {
  const [odt, odv] = other;
  const norm = Math.hypot(odt, odv);
  if (norm === 0.0) return [0.0, 0.0];
  let length = g !== null ? Math.hypot(g[0], g[1]) : span / 3.0;
  if (g !== null && length === 0.0) length = span / 3.0;
  return [(-odt / norm) * length, (-odv / norm) * length];
}

const isGivenType = (t: Keyframe["left_type"]) => t === "free" || t === "aligned";

/** Absolute handle points [t, v] of every key after applying the handle types (Python's
 * `resolve_handles`): what the engine evaluates, so what the graph editor draws. */
export function resolveHandles(keys: readonly Keyframe[]): ResolvedHandles[] {
  const out: ResolvedHandles[] = [];
  const n = keys.length;
  for (let i = 0; i < n; i++) {
    const k = keys[i];
    const spanL = i > 0 ? k.t - keys[i - 1].t : 0.0;
    const spanR = i < n - 1 ? keys[i + 1].t - k.t : 0.0;
    let left = handleOf(keys, i, "left", spanL);
    let right = handleOf(keys, i, "right", spanR);
    const leftType = k.left_type ?? "auto_clamped";
    const rightType = k.right_type ?? "auto_clamped";
    if (leftType === "aligned" && k.right != null && isGivenType(rightType)) {
      left = align(right, spanL, given(k.left));
    } else if (rightType === "aligned" && k.left != null && isGivenType(leftType)) {
      right = align(left, spanR, given(k.right));
    }
    const dtL = pyMin(pyMax(left[0], -spanL), 0.0);
    const dtR = pyMax(pyMin(right[0], spanR), 0.0);
    // keep the slope of a clamped handle (shorten it in time and value together)
    const vl = left[0] !== 0.0 ? left[1] * (dtL / left[0]) : 0.0;
    const vr = right[0] !== 0.0 ? right[1] * (dtR / right[0]) : 0.0;
    const v = num(k.v);
    out.push({ left: [k.t + dtL, v + vl], right: [k.t + dtR, v + vr] });
  }
  return out;
}

// ---------------------------------------------------------------------------------------------------
// Evaluation
// ---------------------------------------------------------------------------------------------------

function bezier(x0: number, y0: number, x1: number, y1: number, x2: number, y2: number, x3: number, y3: number, t: number): number {
  // Solve x(u) = t on [0, 1] by the same bracketed Newton as Python (12 steps, same expressions).
  let lo = 0;
  let hi = 1;
  let u = (t - x0) / (x3 - x0);
  for (let n = 0; n < 12; n++) {
    const a = 1.0 - u;
    const x = a * a * a * x0 + 3 * a * a * u * x1 + 3 * a * u * u * x2 + u * u * u * x3;
    const f = x - t;
    if (f < 0) lo = u;
    if (f > 0) hi = u;
    const dx = 3 * a * a * (x1 - x0) + 6 * a * u * (x2 - x1) + 3 * u * u * (x3 - x2);
    const step = u - f / dx;
    u = Number.isFinite(step) && step >= lo && step <= hi ? step : 0.5 * (lo + hi);
  }
  const a = 1.0 - u;
  return a * a * a * y0 + 3 * a * a * u * y1 + 3 * a * u * u * y2 + u * u * u * y3;
}

/** A curve made ready for many evaluations: handles resolved once. */
export interface PreparedCurve {
  readonly keys: readonly Keyframe[];
  readonly handles: readonly ResolvedHandles[];
  /** The curve's value at t (s): NaN for a curve without keys. */
  at(t: number): number;
  sample(times: readonly number[]): number[];
}

function build(keys: readonly Keyframe[]): PreparedCurve {
  const handles = resolveHandles(keys);
  const n = keys.length;
  const ts = keys.map((k) => k.t);
  const vs = keys.map((k) => num(k.v));
  // Python's idx = (number of keys with t_k <= t) - 1; keys are sorted, so a binary search counts them.
  const countAtOrBefore = (t: number): number => {
    let lo = 0;
    let hi = n;
    while (lo < hi) {
      const mid = (lo + hi) >> 1;
      if (ts[mid] <= t) lo = mid + 1;
      else hi = mid;
    }
    return lo;
  };
  const at = (t: number): number => {
    if (n === 0) return Number.NaN;
    const last = n - 1;
    const idx = pyMin(countAtOrBefore(t) - 1, last);
    if (idx < 0) return vs[0];
    if (idx >= last) return vs[last];
    const t0 = ts[idx];
    const t1 = ts[idx + 1];
    const v0 = vs[idx];
    const v1 = vs[idx + 1];
    const u = pyMin(pyMax((t - t0) / (t1 - t0), 0.0), 1.0);
    const k = keys[idx];
    const interp: Interp = k.interp ?? "bezier";
    switch (interp) {
      case "constant":
        return v0;
      case "linear":
        return v0 + u * (v1 - v0);
      case "bezier": {
        const r = handles[idx].right;
        const l = handles[idx + 1].left;
        return bezier(t0, v0, r[0], r[1], l[0], l[1], t1, v1, t);
      }
      default:
        return v0 + ease(interp, k.easing ?? "in_out", u) * (v1 - v0);
    }
  };
  return { keys, handles, at, sample: (times) => times.map(at) };
}

const cache = new WeakMap<readonly Keyframe[], PreparedCurve>();

/** The prepared curve of a key list, cached per array identity: edits never mutate key arrays (they
 * return new ones), so a redraw of an unchanged track costs nothing. Do not mutate `keys` afterwards. */
export function prepareCurve(keys: readonly Keyframe[]): PreparedCurve {
  let c = cache.get(keys);
  if (!c) {
    c = build(keys);
    cache.set(keys, c);
  }
  return c;
}

/** One curve's value at t, as `CurveSet.evaluate_reference` gives it (first value before the first
 * key, last value after the last). Numeric keys only (see `numericKeys`); NaN for no keys. */
export function evaluateKeys(keys: readonly Keyframe[], t: number): number {
  return prepareCurve(keys).at(t);
}

export function sampleKeys(keys: readonly Keyframe[], times: readonly number[]): number[] {
  return prepareCurve(keys).sample(times);
}

// ---------------------------------------------------------------------------------------------------
// Tracks of any DoF type -> numeric channels (compile_clip)
// ---------------------------------------------------------------------------------------------------

const clamp01 = (x: number): number => pyMin(pyMax(x, 0.0), 1.0);

/** The numbers a key's value gives per channel, as backend/engine/clips.py `_key_values` reads them;
 * a value the engine would refuse gives NaN. */
export function channelValues(v: Keyframe["v"], dof: DofInfo): number[] {
  if (dof.type === "continuous") return [typeof v === "number" ? v : Number.NaN];
  if (dof.type === "colour") {
    if (!Array.isArray(v) || v.length !== 3) return [Number.NaN, Number.NaN, Number.NaN];
    return v.map((x) => clamp01(Number(x)));
  }
  const options = dof.options ?? [];
  if (typeof v === "string") {
    const i = options.indexOf(v);
    return [i >= 0 ? i : Number.NaN];
  }
  if (typeof v === "number" && Math.trunc(v) >= 0 && Math.trunc(v) < options.length) return [Math.trunc(v)];
  return [Number.NaN];
}

const channelCache = new WeakMap<readonly Keyframe[], { sig: string; out: NumericKey[][] }>();

/** A track as the engine compiles it: one numeric key list per channel (1 for continuous and enum —
 * the option index, stepping — and 3 for colour, whose bezier keys blend linearly). Cached per key
 * array (and DoF type/options), so `prepareCurve(numericKeys(keys, dof)[c])` stays cached across
 * redraws of an unchanged track; do not mutate the result. */
export function numericKeys(keys: readonly Keyframe[], dof: DofInfo): NumericKey[][] {
  const sig = `${dof.type}:${dof.type === "enum" ? JSON.stringify(dof.options ?? []) : ""}`;
  const hit = channelCache.get(keys);
  if (hit && hit.sig === sig) return hit.out;
  const out = compileChannels(keys, dof);
  channelCache.set(keys, { sig, out });
  return out;
}

function compileChannels(keys: readonly Keyframe[], dof: DofInfo): NumericKey[][] {
  const width = dof.type === "colour" ? 3 : 1;
  const out: NumericKey[][] = Array.from({ length: width }, () => []);
  for (const k of keys) {
    const vals = channelValues(k.v, dof);
    let interp: Interp = dof.type === "enum" ? "constant" : (k.interp ?? "bezier");
    if (dof.type === "colour" && interp === "bezier") interp = "linear";
    for (let c = 0; c < width; c++) {
      out[c].push({
        t: k.t,
        v: vals[c],
        interp,
        easing: k.easing ?? "in_out",
        left_type: k.left_type ?? "auto_clamped",
        right_type: k.right_type ?? "auto_clamped",
        left: k.left ?? null,
        right: k.right ?? null,
      });
    }
  }
  return out;
}
