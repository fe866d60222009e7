// The dopesheet's row layout (group headers, one row per DoF, collapsed groups hidden) and the key
// geometry it implies: where each key's diamond sits and which keys a selection box covers. Pure.
import type { Clip, DofInfo, KeyRef } from "../model/types";
import type { TimeView } from "./timeView";
import { timeToX } from "./timeView";

export const ROW_H = 20;

export type LayoutRow =
  | { kind: "group"; group: string; y: number; count: number; collapsed: boolean; dofs: string[] }
  | { kind: "dof"; dof: string; info: DofInfo | null; y: number; hasTrack: boolean };

export interface RowGroup {
  group: string;
  dofs: DofInfo[];
}

/** Rows top to bottom: each group's header, then (unless collapsed) one row per DoF; tracks of DoFs the
 * robot does not list go in a last "Other" group so their keys (and errors) still show. */
export function layoutRows(doc: Clip, rows: readonly RowGroup[], collapsed: ReadonlySet<string>): LayoutRow[] {
  const out: LayoutRow[] = [];
  const known = new Set<string>();
  const groups: { group: string; dofs: { name: string; info: DofInfo | null }[] }[] = rows.map((g) => ({
    group: g.group,
    dofs: g.dofs.map((d) => {
      known.add(d.name);
      return { name: d.name, info: d };
    }),
  }));
  const other = Object.keys(doc.tracks).filter((d) => !known.has(d)).sort();
  if (other.length) groups.push({ group: "Other", dofs: other.map((name) => ({ name, info: null })) });
  let y = 0;
  for (const g of groups) {
    const isCollapsed = collapsed.has(g.group);
    out.push({ kind: "group", group: g.group, y, count: g.dofs.length, collapsed: isCollapsed, dofs: g.dofs.map((d) => d.name) });
    y += ROW_H;
    if (isCollapsed) continue;
    for (const d of g.dofs) {
      out.push({ kind: "dof", dof: d.name, info: d.info, y, hasTrack: (doc.tracks[d.name]?.length ?? 0) > 0 });
      y += ROW_H;
    }
  }
  return out;
}

export function layoutHeight(rows: readonly LayoutRow[]): number {
  return rows.length ? rows[rows.length - 1].y + ROW_H : 0;
}

/** Every key of the visible rows. */
export function visibleKeys(doc: Clip, rows: readonly LayoutRow[]): KeyRef[] {
  const out: KeyRef[] = [];
  for (const r of rows) {
    if (r.kind !== "dof") continue;
    const keys = doc.tracks[r.dof] ?? [];
    for (let i = 0; i < keys.length; i++) out.push({ dof: r.dof, index: i });
  }
  return out;
}

export interface Box {
  x0: number;
  y0: number;
  x1: number;
  y1: number;
}

/** Keys whose diamond centre lies inside the box (any corner order), in time-area pixels. */
export function keysInBox(doc: Clip, rows: readonly LayoutRow[], view: TimeView, width: number, b: Box): KeyRef[] {
  const [xa, xb] = b.x0 < b.x1 ? [b.x0, b.x1] : [b.x1, b.x0];
  const [ya, yb] = b.y0 < b.y1 ? [b.y0, b.y1] : [b.y1, b.y0];
  const out: KeyRef[] = [];
  for (const r of rows) {
    if (r.kind !== "dof") continue;
    const cy = r.y + ROW_H / 2;
    if (cy < ya || cy > yb) continue;
    const keys = doc.tracks[r.dof] ?? [];
    keys.forEach((k, i) => {
      const x = timeToX(view, width, k.t);
      if (x >= xa && x <= xb) out.push({ dof: r.dof, index: i });
    });
  }
  return out;
}

/** `a` plus the refs of `b` it lacks. */
export function unionRefs(a: readonly KeyRef[], b: readonly KeyRef[]): KeyRef[] {
  const seen = new Set(a.map((r) => `${r.dof}#${r.index}`));
  return [...a, ...b.filter((r) => !seen.has(`${r.dof}#${r.index}`))];
}

/** The distinct key times of a group's tracks (a collapsed group's summary row), sorted. */
export function summaryTimes(doc: Clip, dofs: readonly string[]): number[] {
  const ts = new Set<number>();
  for (const d of dofs) for (const k of doc.tracks[d] ?? []) ts.add(k.t);
  return [...ts].sort((a, b) => a - b);
}
