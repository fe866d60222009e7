// The engine's safety net as the editor shows it (pure functions, tested with vitest): which series the
// curve panel can plot and their limits, the legend's counts over a window of delivered frames, and
// what the net corrected lately (the top bar's indicator).
import type { DofInfo, RobotDescription } from "../api";
import { dofKey, jointKey, type Samples } from "../telemetry";
import { CLASS_COLOURS } from "../trajectory";

/** How long the top bar keeps showing a correction after the net stopped making it (s). */
export const RECENT_SECONDS = 10;
/** Limit names by code (`LIMIT_CODE`), and the trajectory-helper's colours (position: purple). */
export const LIMIT_NAMES = ["ok", "velocity", "acceleration", "jerk", "position"];
export const LIMIT_COLOURS = [...CLASS_COLOURS, "#a970ff"];

export interface SeriesInfo {
  key: string;
  /** The DoF's or joint's name; joints are labelled `<name> (joint)`. */
  label: string;
  name: string;
  lo: number | null;
  hi: number | null;
  /** rad (shown in degrees) or m (shown in mm) */
  angular: boolean;
}

function dofAngular(d: DofInfo): boolean {
  if (d.joint_frame) return d.joint_frame.type !== "prismatic";
  return d.dimension !== "spatial" || !/_(x|y|z)$/.test(d.name);
}

/** The series the curve panel offers: the continuous DoFs, then the actuated joints. */
export function seriesOf(robot: RobotDescription | null): SeriesInfo[] {
  if (!robot) return [];
  const dofs = robot.dofs.filter((d) => d.type === "continuous").map((d) => ({
    key: dofKey(d.name), label: d.name, name: d.name, lo: d.min, hi: d.max, angular: dofAngular(d),
  }));
  const joints = robot.joints.map((j) => {
    const frame = robot.joint_frames[j];
    return {
      key: jointKey(j), label: `${j} (joint)`, name: j, lo: frame?.limits[0] ?? null, hi: frame?.limits[1] ?? null,
      angular: frame?.type !== "prismatic",
    };
  });
  return [...dofs, ...joints];
}

/** An amount the net moved a DoF, in the unit an animator reads: degrees or millimetres. */
export function amountText(amount: number, angular: boolean): string {
  return angular ? `${((amount * 180) / Math.PI).toFixed(1)}°` : `${(amount * 1000).toFixed(1)} mm`;
}

export interface NetCounts {
  frames: number;
  /** frames on which the net corrected one of the series */
  corrected: number;
  /** those frames by the limit enforced (LIMIT_NAMES order; a frame counts once, its most severe) */
  byLimit: number[];
  /** delivered frames by the trajectory-helper's class (ok, velocity, acceleration, jerk) */
  delivered: number[];
}

/** The limit a frame's corrections of `keys` enforced, most severe first (position, jerk, acceleration,
 * velocity); 0: none. */
function worst(net: Record<string, [number, number]>, keys: string[]): number {
  let code = 0;
  for (const k of keys) {
    const c = net[k]?.[0] ?? 0;
    if (c === 4 || (code !== 4 && c > code)) code = c;
  }
  return code;
}

/** The legend's counts over the delivered frames [from, to) for the series `keys`. */
export function netCounts(s: Samples, keys: string[], from = 0, to = s.t.length): NetCounts {
  const out: NetCounts = { frames: 0, corrected: 0, byLimit: [0, 0, 0, 0, 0], delivered: [0, 0, 0, 0] };
  const channels = keys.filter((k) => k.startsWith("dof:")).map((k) => k.slice(4));
  for (let i = Math.max(0, from); i < Math.min(to, s.t.length); i++) {
    out.frames++;
    const code = worst(s.net[i] ?? {}, keys);
    if (code) { out.corrected++; out.byLimit[code]++; }
    const cls = s.classes[i] ?? {};
    out.delivered[Math.max(0, ...channels.map((c) => cls[c] ?? 0))]++;
  }
  return out;
}

export function legendText(c: NetCounts): string {
  const by = LIMIT_NAMES.slice(1).map((n, i) => `${n} ${c.byLimit[i + 1]}`).join(", ");
  return `net corrected ${c.corrected} (${by})`;
}

export interface Recent {
  key: string;
  name: string;
  /** the largest |requested - delivered| in the window */
  amount: number;
  /** the limit of that largest correction */
  limit: number;
}

/** What the top bar names: the DoFs the net corrected lately, and the joints it corrected whose own DoF
 * it did not (a joint only symbolic DoFs drive, say), largest first. */
export function recentForBar(s: Samples, robot: RobotDescription | null, seconds = RECENT_SECONDS): Recent[] {
  const dofs = recentCorrections(s, seconds, "dof:");
  const named = new Set(dofs.map((r) => r.name));
  const ownDof = new Map((robot?.dofs ?? []).filter((d) => d.joint && !d.drives).map((d) => [d.joint as string, d.name]));
  const joints = recentCorrections(s, seconds, "joint:").filter((r) => !named.has(ownDof.get(r.name) ?? ""));
  return [...dofs, ...joints].sort((a, b) => b.amount - a.amount);
}

/** The series (`kind`: "dof:" or "joint:") the net corrected in the last `seconds` of samples (engine
 * time), largest first. */
export function recentCorrections(s: Samples, seconds = RECENT_SECONDS, kind = "dof:"): Recent[] {
  const now = s.t.at(-1);
  if (now === undefined) return [];
  const found = new Map<string, Recent>();
  for (let i = s.t.length - 1; i >= 0 && s.t[i] >= now - seconds; i--) {
    for (const [key, [limit, amount]] of Object.entries(s.net[i] ?? {})) {
      if (!key.startsWith(kind)) continue;
      const had = found.get(key);
      if (!had || amount > had.amount) found.set(key, { key, name: key.slice(kind.length), amount, limit });
    }
  }
  return [...found.values()].sort((a, b) => b.amount - a.amount);
}

/** The window [from, to) of samples the panel shows: the last `span` seconds, or (scrubbed) the `span`
 * seconds ending `back` seconds before the newest sample. */
export function viewWindow(t: number[], span: number, back = 0): [number, number] {
  const last = t.at(-1);
  if (last === undefined) return [0, 0];
  const end = last - back;
  let to = t.length;
  while (to > 0 && t[to - 1] > end + 1e-9) to--;
  let from = to;
  while (from > 0 && t[from - 1] > end - span) from--;
  return [from, to];
}

/** The y range that shows the series' values and their position limits, a little padded. */
export function yRange(values: (number | null)[][], limits: (number | null)[]): [number, number] {
  let lo = Infinity, hi = -Infinity;
  for (const list of values) for (const v of list) if (v != null && Number.isFinite(v)) { lo = Math.min(lo, v); hi = Math.max(hi, v); }
  for (const v of limits) if (v != null && Number.isFinite(v)) { lo = Math.min(lo, v); hi = Math.max(hi, v); }
  if (!Number.isFinite(lo)) return [-1, 1];
  const pad = Math.max((hi - lo) * 0.06, 1e-3);
  return [lo - pad, hi + pad];
}
