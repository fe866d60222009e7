// The behaviour's parameters as the editor types them: text in an input turned into the value the
// server takes (by the parameter's declared type), and the preview values sent with plan, preview and
// play (an empty field leaves the parameter to its default). Pure; tested with vitest.
import type { Param } from "../generated/behaviour";

export type ParamType = Param["type"];
export type Parsed = { ok: true; value: unknown } | { ok: false; error: string };

const NUMBER = /^[-+]?(\d+\.?\d*|\.\d+)([eE][-+]?\d+)?$/;

/** `text` as a value of `type`: numbers, "true"/"false", a point "x, y, z" (brackets optional) or an
 * exposed input's name for a vec3, any text for a string. */
export function parseParam(type: ParamType, text: string): Parsed {
  const t = text.trim();
  switch (type) {
    case "string":
      return { ok: true, value: text };
    case "number":
      return NUMBER.test(t) ? { ok: true, value: Number(t) } : { ok: false, error: "a number" };
    case "bool":
      if (/^(true|yes|1|on)$/i.test(t)) return { ok: true, value: true };
      if (/^(false|no|0|off)$/i.test(t)) return { ok: true, value: false };
      return { ok: false, error: "true or false" };
    case "vec3": {
      if (/^[A-Za-z_][A-Za-z0-9_.]*$/.test(t)) return { ok: true, value: t };  // an exposed input's name
      const parts = t.replace(/^\[|\]$/g, "").split(/[\s,]+/).filter(Boolean);
      if (parts.length === 3 && parts.every((p) => NUMBER.test(p))) return { ok: true, value: parts.map(Number) };
      return { ok: false, error: "x, y, z (m) or an input's name" };
    }
  }
}

/** A value as the editor shows it in a field. */
export function formatParam(value: unknown): string {
  if (value === undefined || value === null) return "";
  if (Array.isArray(value)) return value.map(String).join(", ");
  return String(value);
}

/** The params to send (typed fields parsed; empty ones left to their defaults) and the fields that do
 * not parse (name -> what they should be). */
export function previewParams(decls: Record<string, Param>, texts: Record<string, string>):
  { params: Record<string, unknown>; errors: Record<string, string> } {
  const params: Record<string, unknown> = {};
  const errors: Record<string, string> = {};
  for (const [name, decl] of Object.entries(decls)) {
    const text = texts[name];
    if (text === undefined || text.trim() === "") continue;
    const parsed = parseParam(decl.type, text);
    if (parsed.ok) params[name] = parsed.value;
    else errors[name] = parsed.error;
  }
  return { params, errors };
}

/** A parameter's name as the format allows it. */
export const validParamName = (name: string): boolean => /^[A-Za-z_][A-Za-z0-9_]{0,39}$/.test(name);

type Doc = { params?: Record<string, Param> | null };

/** The document with parameter `name` declared as `decl` (added at the end when new). */
export function setParam<D extends Doc>(doc: D, name: string, decl: Param): D {
  return { ...doc, params: { ...(doc.params ?? {}), [name]: decl } };
}

/** The document without parameter `name`. */
export function removeParam<D extends Doc>(doc: D, name: string): D {
  const params = { ...(doc.params ?? {}) };
  delete params[name];
  return { ...doc, params };
}

/** Parameter `from` renamed `to`, in place (unchanged when `to` is taken or no valid name). */
export function renameParam<D extends Doc>(doc: D, from: string, to: string): D {
  const params = doc.params ?? {};
  if (from === to || !validParamName(to) || to in params || !(from in params)) return doc;
  return { ...doc, params: Object.fromEntries(Object.entries(params).map(([k, v]) => [k === from ? to : k, v])) };
}
