// The server's refusal of a clip turned into what the views show: its `field` path (e.g.
// `tracks.head_pitch.2.t`) as a ClipErrors key ("head_pitch#2", "head_pitch", or "" for the clip as a
// whole) and its message for the toolbar. Pure (tested with vitest).
import { ApiError } from "../api";
import type { ClipErrors } from "./model/types";

/** The ClipErrors key of a server field path; `dofs` (the tracks' names) resolves DoF names with dots. */
export function errorKeyOf(field: string | null | undefined, dofs: string[] = []): string {
  if (!field) return "";
  const parts = field.split(".");
  // FastAPI's own validation errors start their location with "body"
  if (parts[0] === "body") parts.shift();
  if (parts[0] !== "tracks" || parts.length < 2) return "";
  const rest = parts.slice(1);
  // the longest known DoF name the path starts with (a name may itself hold dots), else one segment
  let dofParts = 1;
  for (let n = rest.length; n >= 1; n--) {
    if (dofs.includes(rest.slice(0, n).join("."))) { dofParts = n; break; }
  }
  const dof = rest.slice(0, dofParts).join(".");
  const index = rest[dofParts];
  return index !== undefined && /^\d+$/.test(index) ? `${dof}#${index}` : dof;
}

export interface ClipRefusal {
  message: string;
  errors: ClipErrors;
}

interface FastApiIssue { loc?: unknown[]; msg?: unknown }

/** What a failed request says, for the toolbar and the views. */
export function refusalOf(err: unknown, dofs: string[] = []): ClipRefusal {
  if (err instanceof ApiError) {
    const detail: unknown = err.detail;
    if (Array.isArray(detail) && detail.length) {
      // a request FastAPI refused before the route ran: [{loc, msg}, ...]
      const first = detail[0] as FastApiIssue;
      const field = Array.isArray(first.loc) ? first.loc.map(String).join(".") : null;
      const message = `${field ? field + ": " : ""}${String(first.msg ?? err.message)}`;
      return { message, errors: { [errorKeyOf(field, dofs)]: message } };
    }
    const field = err.detail?.field ?? null;
    const message = err.detail?.message ?? err.message;
    return { message, errors: { [errorKeyOf(field, dofs)]: message } };
  }
  const message = err instanceof Error ? err.message : String(err);
  return { message, errors: { "": message } };
}
