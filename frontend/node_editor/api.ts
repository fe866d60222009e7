// The server's HTTP API (docs/api-contract.md). Program and command types are generated from the
// backend's pydantic models (./generated); the block catalog is described here.
import type { Program } from "./generated/program";

export type { Program };

export type PortType = "frame" | "float" | "int" | "bool" | "string" | "vec3" | "colour" | "event";

export interface PortSpec {
  type: PortType;
  doc: string;
  required: boolean;
}

export interface BlockEntry {
  type: string;
  title: string;
  category: string;
  role: string;
  summary: string;
  doc: string;
  params_schema: JsonSchema;
  inputs: Record<string, PortSpec>;
  outputs: Record<string, PortSpec>;
  dynamic_ports: boolean;
}

export interface JsonSchema {
  type?: string | string[];
  properties?: Record<string, JsonSchema>;
  required?: string[];
  default?: unknown;
  minimum?: number;
  maximum?: number;
  exclusiveMinimum?: number;
  exclusiveMaximum?: number;
  enum?: unknown[];
  const?: unknown;
  description?: string;
  title?: string;
  items?: JsonSchema;
  anyOf?: JsonSchema[];
  $ref?: string;
  $defs?: Record<string, JsonSchema>;
  "x-widget"?: string;
  [key: string]: unknown;
}

export interface Issue {
  code: string;
  node?: string | null;
  port?: string | null;
  message: string;
  path?: string | null;
}

export interface Report {
  valid: boolean;
  level: number | null;
  errors: Issue[];
  warnings: Issue[];
}

export interface DofInfo {
  name: string;
  dimension: string;
  type: string;
  min: number | null;
  max: number | null;
  velocity: number | null;
  acceleration: number | null;
  jerk: number | null;
  options?: string[];
  sounds?: string[];
}

export interface Robot {
  name: string;
  dimensions: Record<string, number>;
  dofs: DofInfo[];
  channels: string[];
  postures: string[];
}

export class ApiError extends Error {
  constructor(public status: number, public detail: any) {
    super(detail?.message ?? `HTTP ${status}`);
  }
}

async function call<T>(method: string, path: string, body?: unknown): Promise<T> {
  const res = await fetch(path, {
    method,
    headers: body === undefined ? undefined : { "Content-Type": "application/json" },
    body: body === undefined ? undefined : JSON.stringify(body),
  });
  const text = await res.text();
  const data = text ? JSON.parse(text) : null;
  if (!res.ok) throw new ApiError(res.status, data?.detail ?? data);
  return data as T;
}

export const api = {
  blocks: () => call<BlockEntry[]>("GET", "/api/blocks"),
  robot: () => call<Robot>("GET", "/api/robot"),
  program: () => call<{ program: Program | null; report: Report | null; level: number | null }>("GET", "/api/program"),
  validate: (p: Program) => call<Report>("POST", "/api/program/validate", p),
  putProgram: (p: Program) => call<{ report: Report; kept: string[] }>("PUT", "/api/program", p),
  patchParams: (node: string, params: Record<string, unknown>) =>
    call<{ params: Record<string, unknown> }>("PATCH", `/api/program/nodes/${encodeURIComponent(node)}/params`, params),
  ports: (type: string, params: Record<string, unknown>) =>
    call<{ inputs: Record<string, PortSpec>; outputs: Record<string, PortSpec> }>("POST", `/api/blocks/${type}/ports`, { params }),
  list: (kind: "programs" | "clips" | "postures") => call<string[]>("GET", `/api/${kind}`),
  getProgram: (name: string) => call<Program>("GET", `/api/programs/${encodeURIComponent(name)}`),
  saveProgram: (name: string, p: Program) => call<{ saved: string }>("PUT", `/api/programs/${encodeURIComponent(name)}`, p),
  command: (c: Record<string, unknown>) => call<{ id: string; status: string }>("POST", "/api/commands", c),
  setInput: (name: string, value: unknown) => call("PUT", `/api/inputs/${encodeURIComponent(name)}`, { value }),
  inputs: () => call<{ values: Record<string, unknown>; declarations: any[] }>("GET", "/api/inputs"),
  previz: () => call<{ url: string | null; ghost: boolean | null }>("GET", "/api/previz"),
  ghost: (visible: boolean) => call("PUT", "/api/previz/ghost", { visible }),
};

export function wsUrl(path: string): string {
  const proto = location.protocol === "https:" ? "wss:" : "ws:";
  return `${proto}//${location.host}${path}`;
}
