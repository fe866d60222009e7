// The server's HTTP API (docs/api-contract.md). Every type here is generated from the backend's
// pydantic models (./generated, `npm run gen:types`); this module only makes the calls.
import type {
  BlockEntry, CommandAccepted, ErrorDetail, ExposedInputs, GhostSet, InputSet, ParamsApplied, PrevizInfo, ProgramLoaded,
  RobotDescription, RunningProgram, Saved, ValidationReport,
} from "./generated/api";
import type { Command } from "./generated/commands";
import type { Program, Subgraph as SubgraphDef } from "./generated/program";

export type * from "./generated/api";
export type { Command } from "./generated/commands";
export type { ExposedInput, Program } from "./generated/program";
export type { JsonSchema } from "./jsonSchema";

export type Catalog = Record<string, BlockEntry>;

/** A refused request: `detail` is the contract's error detail (`code`, `message`, maybe a `report`); a
 * response from outside the contract (a proxy's, a body that is not JSON) may lack any of them. */
export class ApiError extends Error {
  constructor(public status: number, public detail: Partial<ErrorDetail> | null) {
    super(detail?.message ?? `HTTP ${status}`);
  }
}

const TOKEN_KEY = "nutty.token";

/** The server's access token (`nutty serve --token T`), if this page was given one: from the page's
 * `?token=` (then dropped from the address bar, so it is not shared with a copied link) or typed in
 * when the server asked. Kept for this tab's session only. */
export function accessToken(): string | null {
  const fromUrl = new URLSearchParams(location.search).get("token");
  if (fromUrl) {
    sessionStorage.setItem(TOKEN_KEY, fromUrl);
    const url = new URL(location.href);
    url.searchParams.delete("token");
    history.replaceState(history.state, "", url.toString());
  }
  return sessionStorage.getItem(TOKEN_KEY);
}

export function setAccessToken(token: string): void {
  sessionStorage.setItem(TOKEN_KEY, token);
}

/** `url` with the token as `?token=` (WebSockets and pages cannot carry an Authorization header). */
export function withToken(url: string): string {
  const token = accessToken();
  if (!token) return url;
  return `${url}${url.includes("?") ? "&" : "?"}token=${encodeURIComponent(token)}`;
}

/** One request to the server's API (token and JSON handled); refused requests throw ApiError. */
export async function call<T>(method: string, path: string, body?: unknown): Promise<T> {
  const headers: Record<string, string> = {};
  if (body !== undefined) headers["Content-Type"] = "application/json";
  const token = accessToken();
  if (token) headers.Authorization = `Bearer ${token}`;
  const res = await fetch(path, { method, headers, body: body === undefined ? undefined : JSON.stringify(body) });
  const text = await res.text();
  const data = text ? JSON.parse(text) : null;
  if (!res.ok) throw new ApiError(res.status, data?.detail ?? data);
  return data as T;
}

export const api = {
  blocks: () => call<BlockEntry[]>("GET", "/api/blocks"),
  robot: () => call<RobotDescription>("GET", "/api/robot"),
  program: () => call<RunningProgram>("GET", "/api/program"),
  validate: (p: Program) => call<ValidationReport>("POST", "/api/program/validate", p),
  putProgram: (p: Program) => call<ProgramLoaded>("PUT", "/api/program", p),
  patchParams: (node: string, params: Record<string, unknown>) =>
    call<ParamsApplied>("PATCH", `/api/program/nodes/${encodeURIComponent(node)}/params`, params),
  list: (kind: "programs" | "clips" | "postures") => call<string[]>("GET", `/api/${kind}`),
  getProgram: (name: string) => call<Program>("GET", `/api/programs/${encodeURIComponent(name)}`),
  saveProgram: (name: string, p: Program) => call<Saved>("PUT", `/api/programs/${encodeURIComponent(name)}`, p),
  subgraphs: () => call<string[]>("GET", "/api/subgraphs"),
  getSubgraph: (name: string) => call<SubgraphDef>("GET", `/api/subgraphs/${encodeURIComponent(name)}`),
  saveSubgraph: (name: string, d: SubgraphDef) => call<Saved>("PUT", `/api/subgraphs/${encodeURIComponent(name)}`, d),
  command: (c: Command) => call<CommandAccepted>("POST", "/api/commands", c),
  setInput: (name: string, value: unknown) => call<InputSet>("PUT", `/api/inputs/${encodeURIComponent(name)}`, { value }),
  inputs: () => call<ExposedInputs>("GET", "/api/inputs"),
  previz: () => call<PrevizInfo>("GET", "/api/previz"),
  ghost: (visible: boolean) => call<GhostSet>("PUT", "/api/previz/ghost", { visible }),
  /** The Pre-Viz scene's background follows the editor's theme (refused when there is no Pre-Viz). */
  previzTheme: (theme: "light" | "dark") => call<{ theme: string }>("PUT", "/api/previz/theme", { theme }),
};

export function wsUrl(path: string): string {
  const proto = location.protocol === "https:" ? "wss:" : "ws:";
  return withToken(`${proto}//${location.host}${path}`);
}
