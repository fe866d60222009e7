// What the clip editor knows of the robot's DoFs (from GET /api/robot), and the dopesheet's rows: the
// keyable DoFs (not event DoFs: those take clip events) in stable groups.
import type { DofInfo as ApiDof, RobotDescription } from "../../generated/api";
import type { DofInfo, Keyframe } from "./types";

/** The dopesheet's groups in display order; "Other" holds tracks of DoFs the robot does not have. */
export const GROUP_ORDER = ["Joints", "Symbolic", "Spatial", "Display", "Other"] as const;

function groupOf(d: ApiDof): string {
  if (d.dimension === "spatial") return "Spatial";
  if (d.dimension === "display" || d.dimension === "audible") return "Display";
  if (d.drives && Object.keys(d.drives).length) return "Symbolic";
  return "Joints";
}

function restValue(d: ApiDof, type: DofInfo["type"]): Keyframe["v"] {
  const rest = d.rest;
  if (type === "colour") return Array.isArray(rest) ? [...rest] : [rest ?? 0, rest ?? 0, rest ?? 0];
  const r = Array.isArray(rest) ? (rest[0] ?? 0) : (rest ?? 0);
  if (type === "enum") return d.options?.[Math.round(r)] ?? d.options?.[0] ?? r;
  return r;
}

/** One DofInfo per keyable DoF, in the robot's order. Unbounded limits are -Infinity/Infinity, an
 * unlimited velocity Infinity; `rest` is a number (a colour's first channel, an enum's option index)
 * and `restValue` the rest as a key value. */
export function dofInfos(robot: Pick<RobotDescription, "dofs">): DofInfo[] {
  const out: DofInfo[] = [];
  for (const d of robot.dofs) {
    if (d.type === "event") continue;
    const type = d.type;
    const colour = type === "colour";
    const rest = Array.isArray(d.rest) ? (d.rest[0] ?? 0) : (d.rest ?? 0);
    const info: DofInfo = {
      name: d.name,
      type,
      min: d.min ?? (colour ? 0 : -Infinity),
      max: d.max ?? (colour ? 1 : type === "enum" ? Math.max(0, (d.options?.length ?? 1) - 1) : Infinity),
      rest,
      restValue: restValue(d, type),
      velocity: d.velocity ?? Infinity,
      group: groupOf(d),
    };
    if (d.options) info.options = [...d.options];
    if (d.description) info.description = d.description;
    out.push(info);
  }
  return out;
}

/** A stand-in for a track whose DoF the robot lacks (its type guessed from the values). */
function otherDof(name: string, keys: readonly Keyframe[]): DofInfo {
  const v = keys[0]?.v;
  const type: DofInfo["type"] = Array.isArray(v) ? "colour" : typeof v === "string" ? "enum" : "continuous";
  const options = type === "enum" ? [...new Set(keys.map((k) => String(k.v)))] : undefined;
  return { name, type, min: -Infinity, max: Infinity, rest: 0, velocity: Infinity, group: "Other", ...(options ? { options } : {}) };
}

export interface RowGroup {
  group: string;
  dofs: DofInfo[];
}

/** The dopesheet's rows: groups in GROUP_ORDER (empty ones left out), DoFs in the robot's order, then
 * the clip's tracks for DoFs the robot lacks ("Other", so their keys still show). `onlyKeyed` keeps
 * only DoFs that have a track. */
export function groupRows(
  infos: readonly DofInfo[],
  tracks: Readonly<Record<string, readonly Keyframe[]>>,
  opts: { onlyKeyed?: boolean } = {},
): RowGroup[] {
  const byGroup = new Map<string, DofInfo[]>();
  const known = new Set<string>();
  for (const d of infos) {
    known.add(d.name);
    if (opts.onlyKeyed && !tracks[d.name]?.length) continue;
    const list = byGroup.get(d.group) ?? [];
    list.push(d);
    byGroup.set(d.group, list);
  }
  const others = Object.keys(tracks)
    .filter((name) => !known.has(name))
    .map((name) => otherDof(name, tracks[name]));
  if (others.length) byGroup.set("Other", [...(byGroup.get("Other") ?? []), ...others]);
  const order = [...GROUP_ORDER, ...[...byGroup.keys()].filter((g) => !(GROUP_ORDER as readonly string[]).includes(g))];
  return order.filter((g) => byGroup.get(g)?.length).map((g) => ({ group: g, dofs: byGroup.get(g) ?? [] }));
}
