// Ports of a block and which outputs an input accepts: the backend's rules, applied here.
// A block's fixed ports and its port rules come with the catalog (GET /api/blocks); the compatibility
// table and the palette's categories are generated from the backend (generated/rules.json). This module
// evaluates a port rule exactly as backend/engine/blocks/ports.py does; it decides nothing itself.
import type { BlockEntry, EditorRules, JsonSchema, PortRule, PortSpec, PortType } from "./api";
import generatedRules from "./generated/rules.json";
import { resolve } from "./schemaForm";

const rules = generatedRules as EditorRules;

export interface Ports {
  inputs: Record<string, PortSpec>;
  outputs: Record<string, PortSpec>;
}

/** Palette groups in palette order, with their titles. */
export const CATEGORIES = rules.categories;

/** Whether an output of type `source` may feed an input of type `target` (the backend's port_accepts). */
export function accepts(target: PortType, source: PortType): boolean {
  return rules.accepts[target]?.includes(source) ?? false;
}

/** Default parameter values from a block's JSON Schema. */
export function defaultParams(entry: BlockEntry): Record<string, unknown> {
  return withDefaults(entry.params_schema, {});
}

/** `values` completed with the defaults its object schema declares (what the backend's validation does). */
function withDefaults(schema: JsonSchema, values: Record<string, unknown>): Record<string, unknown> {
  const out: Record<string, unknown> = {};
  for (const [k, s] of Object.entries(schema.properties ?? {})) {
    if (s.default !== undefined) out[k] = structuredClone(s.default);
  }
  return { ...out, ...values };
}

const FIELD = /\{([A-Za-z_][A-Za-z0-9_]*)\}/g;

/** A rule template filled with `{field}` values; null when a field is missing (the server says why). */
function fill(template: string, values: Record<string, unknown>): string | null {
  let missing = false;
  const text = template.replace(FIELD, (_, name: string) => {
    if (!(name in values)) missing = true;
    return String(values[name]);
  });
  return missing ? null : text;
}

function isRecord(v: unknown): v is Record<string, unknown> {
  return typeof v === "object" && v !== null && !Array.isArray(v);
}

/** What a rule is filled from: each item of its list parameter, or the parameters themselves. */
function ruleItems(rule: PortRule, schema: JsonSchema, params: Record<string, unknown>): Record<string, unknown>[] {
  if (!rule.each) return [params];
  const list = params[rule.each];
  if (!Array.isArray(list)) return [];
  const item = resolve(schema.properties?.[rule.each]?.items ?? {}, schema);
  return list.filter(isRecord).map((v) => withDefaults(item, v));
}

function derivedPorts(rule: PortRule, schema: JsonSchema, params: Record<string, unknown>): Record<string, PortSpec> {
  const out: Record<string, PortSpec> = {};
  for (const item of ruleItems(rule, schema, params)) {
    const name = fill(rule.name, item);
    const type = fill(rule.type, item) as PortType | null;
    if (name === null || type === null || !rules.port_types.includes(type)) continue;
    out[name] = { type, doc: fill(rule.doc, item) ?? "", required: false };
  }
  return out;
}

/** The ports a block declares without parameters: the catalog's, less those a fixed-name rule derives. */
function fixedPorts(entry: BlockEntry, side: PortRule["side"]): Record<string, PortSpec> {
  const derived = new Set(entry.port_rules.filter((r) => r.side === side && !r.each).map((r) => r.name));
  return Object.fromEntries(Object.entries(entry[side]).filter(([name]) => !derived.has(name)));
}

/** Ports of a block for given parameters: its fixed ports, then those its rules derive, in rule order. */
export function portsOf(entry: BlockEntry | undefined, params: Record<string, unknown>): Ports {
  if (!entry) return { inputs: {}, outputs: {} };
  const values = withDefaults(entry.params_schema, params);
  const ports: Ports = { inputs: fixedPorts(entry, "inputs"), outputs: fixedPorts(entry, "outputs") };
  for (const rule of entry.port_rules) Object.assign(ports[rule.side], derivedPorts(rule, entry.params_schema, values));
  return ports;
}
