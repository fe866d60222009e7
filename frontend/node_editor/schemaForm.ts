// Parameter-panel fields derived from a block's JSON Schema (pydantic's output), one widget each.
import { niceStep, type NumberSpec } from "./fields/numberField";
import type { JsonSchema } from "./jsonSchema";

export type FieldKind = "slider" | "number" | "integer" | "enum" | "bool" | "text" | "dofs" | "colour" | "json" | "posture" | "clip";

export interface Field {
  name: string;
  label: string;
  kind: FieldKind;
  description: string;
  /** The slider's (soft) range: `x-soft` when the block declares one, else the hard range. */
  min?: number;
  max?: number;
  step?: number;
  /** Numbers: the soft range, the hard range and the step (../fields/numberField). */
  number?: NumberSpec;
  options?: (string | number)[];
  nullable: boolean;
  default?: unknown;
}

/** `s` with a `$ref` into the root schema's `$defs` replaced by the definition. */
export function resolve(s: JsonSchema, root: JsonSchema): JsonSchema {
  if (s.$ref) {
    const name = s.$ref.split("/").pop()!;
    return { ...(root.$defs?.[name] ?? {}), ...s, $ref: undefined };
  }
  return s;
}

/** The non-null branch of `X | None` and whether null is allowed. */
function unwrapNullable(s: JsonSchema, root: JsonSchema): { schema: JsonSchema; nullable: boolean } {
  if (s.anyOf) {
    const branches = s.anyOf.map((b) => resolve(b, root));
    const nonNull = branches.filter((b) => b.type !== "null");
    if (nonNull.length === 1) return { schema: { ...nonNull[0], description: s.description, default: s.default, title: s.title }, nullable: nonNull.length < branches.length };
  }
  return { schema: resolve(s, root), nullable: false };
}

const label = (name: string) => name.replace(/_/g, " ");

export function fieldsFromSchema(schema: JsonSchema): Field[] {
  const out: Field[] = [];
  for (const [name, raw] of Object.entries(schema.properties ?? {})) {
    const { schema: s, nullable } = unwrapNullable(raw, schema);
    const widget = (raw["x-widget"] ?? s["x-widget"]) as string | undefined;
    const base = { name, label: label(name), description: String(raw.description ?? s.description ?? ""), nullable, default: raw.default ?? s.default };
    if (widget === "dofs") {
      out.push({ ...base, kind: "dofs" });
      continue;
    }
    if (widget === "posture") {
      out.push({ ...base, kind: "posture" });
      continue;
    }
    if (name === "clip") {
      out.push({ ...base, kind: "clip" });
      continue;
    }
    const enumValues = s.enum ?? (s.const !== undefined ? [s.const] : undefined);
    if (enumValues) {
      out.push({ ...base, kind: "enum", options: enumValues as (string | number)[] });
      continue;
    }
    const t = Array.isArray(s.type) ? s.type.find((x) => x !== "null") : s.type;
    if (t === "number" || t === "integer") {
      const number = numberSpec(s, raw, t === "integer");
      const slider = number.softMin !== undefined && number.softMax !== undefined;
      out.push({ ...base, kind: slider ? "slider" : t, min: number.softMin, max: number.softMax, step: number.step, number });
      continue;
    }
    if (t === "boolean") {
      out.push({ ...base, kind: "bool" });
      continue;
    }
    if (t === "string") {
      out.push({ ...base, kind: "text" });
      continue;
    }
    if (t === "array" && s.items && (s.items as JsonSchema).type === "number" && s.maxItems === 3 && /colou?r/.test(name)) {
      out.push({ ...base, kind: "colour" });
      continue;
    }
    out.push({ ...base, kind: "json" });
  }
  return out;
}

/** A hard range wider than this (a seed's 0..2^31) makes no usable slider: a typed field only. The
 * server's tests hold every wide number parameter to an `x-soft` range (tests/test_soft_ranges.py). */
const WIDEST_HARD_SLIDER = 1000;

const num = (x: unknown) => (typeof x === "number" && Number.isFinite(x) ? x : undefined);

/** A number's ranges (contract C1): the slider spans `x-soft` when declared, else a bounded hard range;
 * typing may go up to the hard range (`minimum`/`maximum`, or exclusive bounds). */
function numberSpec(s: JsonSchema, raw: JsonSchema, integer: boolean): NumberSpec {
  const ext = (key: string) => raw[key] ?? s[key];
  const minEx = num(s.exclusiveMinimum), maxEx = num(s.exclusiveMaximum);
  const hardMin = num(s.minimum) ?? minEx, hardMax = num(s.maximum) ?? maxEx;
  const soft = ext("x-soft");
  const hardSlider = hardMin !== undefined && hardMax !== undefined && hardMax - hardMin <= WIDEST_HARD_SLIDER;
  const [softMin, softMax] = Array.isArray(soft) && soft.length === 2 && soft.every((x) => num(x) !== undefined)
    ? (soft as number[]) : hardSlider ? [hardMin, hardMax] : [undefined, undefined];
  const bounded = softMin !== undefined && softMax !== undefined;
  const step = num(ext("x-step")) ?? (integer ? 1 : bounded ? niceStep(softMax - softMin) : 0.01);
  return {
    ...(bounded ? { softMin, softMax } : {}), hardMin, hardMax, step, integer,
    ...(num(s.minimum) === undefined && minEx !== undefined ? { minExclusive: true } : {}),
    ...(num(s.maximum) === undefined && maxEx !== undefined ? { maxExclusive: true } : {}),
  };
}

/** Hex colour of an [r, g, b] in 0..1 and back (for colour pickers). */
export function rgbToHex(rgb: number[]): string {
  return "#" + rgb.map((c) => Math.round(Math.min(1, Math.max(0, c)) * 255).toString(16).padStart(2, "0")).join("");
}

export function hexToRgb(hex: string): number[] {
  const m = /^#?([0-9a-f]{2})([0-9a-f]{2})([0-9a-f]{2})$/i.exec(hex);
  if (!m) return [0, 0, 0];
  return [1, 2, 3].map((i) => Math.round((parseInt(m[i], 16) / 255) * 1000) / 1000);
}
