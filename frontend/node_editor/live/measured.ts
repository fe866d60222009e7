// What the motors read, as the curve panel shows it beside what the engine sent (pure functions, tested
// with vitest): which joint series have a measured line in view, how far each lagged behind its goal,
// and whether its motor hit its limit.
import type { Samples } from "../telemetry";
import type { SeriesInfo } from "./net";

export interface Tracking {
  key: string;
  name: string;
  angular: boolean;
  /** the largest |commanded - read| in view (null: the reads in view carried no error) */
  peak: number | null;
  /** the samples in view with the motor at its torque (or speed) limit */
  saturated: number;
}

function anyIn<T>(list: (T | null)[] | undefined, from: number, to: number): boolean {
  if (!list) return false;
  for (let i = Math.max(0, from); i < Math.min(to, list.length); i++) if (list[i] != null) return true;
  return false;
}

/** The joint series among `series` read at their motors in the samples [from, to), with their tracking. */
export function trackingInView(s: Samples, series: SeriesInfo[], from: number, to: number): Tracking[] {
  const out: Tracking[] = [];
  for (const info of series) {
    if (!info.key.startsWith("joint:") || !anyIn(s.measured[info.key], from, to)) continue;
    const error = s.error[info.key] ?? [];
    const saturated = s.saturated[info.key] ?? [];
    let peak: number | null = null;
    let count = 0;
    for (let i = Math.max(0, from); i < Math.min(to, s.t.length); i++) {
      const e = error[i];
      if (e != null && Number.isFinite(e)) peak = Math.max(peak ?? 0, Math.abs(e));
      if (saturated[i]) count++;
    }
    out.push({ key: info.key, name: info.name, angular: info.angular, peak, saturated: count });
  }
  return out;
}

/** One joint's part of the legend, in the plot's own unit (rad; mm for a prismatic joint, whose metres
 * would round to nothing). */
export function trackingText(t: Tracking): string {
  const peak = t.peak == null ? "—" : t.angular ? `${t.peak.toFixed(3)} rad` : `${(t.peak * 1000).toFixed(1)} mm`;
  const sat = t.saturated ? `, ⚠ saturated ${t.saturated} frame${t.saturated === 1 ? "" : "s"}` : "";
  return `${t.name}: tracking ${peak} peak${sat}`;
}

/** The joint keys read at their motors anywhere in the samples kept (the series picker marks them). */
export function measuredKeys(s: Samples): Set<string> {
  const keys = new Set<string>();
  for (const [key, list] of Object.entries(s.measured)) if (anyIn(list, 0, list.length)) keys.add(key);
  return keys;
}
