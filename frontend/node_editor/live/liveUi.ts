// View settings of the live overlays, outside the editor's store (they are not part of the program and
// have no undo): the wires pinned as probes, whether nodes show their cook-time heat, each mixer's
// soloed layer, and the series the curve panel plots. `pinProbe(edgeId)` is what a wire's context menu
// calls; `showCurves(keys)` what the top bar's safety indicator calls.
import { useSyncExternalStore } from "react";

export interface LiveUi {
  probes: string[];
  heat: boolean;
  /** mixer id -> the soloed layer and the layers that were active before the solo */
  solo: Record<string, { layer: string; saved: string[] }>;
  /** The curve panel's series (`dof:<name>`, `joint:<name>`; null: the robot's first DoF). */
  curves: string[] | null;
  /** Counts the requests to show series: the curve panel goes live and comes into view on each. */
  curvesShown: number;
}

let ui: LiveUi = { probes: [], heat: true, solo: {}, curves: null, curvesShown: 0 };
const listeners = new Set<() => void>();

function set(next: LiveUi) {
  ui = next;
  for (const l of listeners) l();
}

export function getLiveUi(): LiveUi {
  return ui;
}

/** Pin a wire (by its edge id) as a probe: a small live plot at its midpoint. */
export function pinProbe(edgeId: string): void {
  if (!ui.probes.includes(edgeId)) set({ ...ui, probes: [...ui.probes, edgeId] });
}

export function unpinProbe(edgeId: string): void {
  if (ui.probes.includes(edgeId)) set({ ...ui, probes: ui.probes.filter((p) => p !== edgeId) });
}

export function setHeat(on: boolean): void {
  if (ui.heat !== on) set({ ...ui, heat: on });
}

export function setSolo(mixer: string, solo: { layer: string; saved: string[] } | null): void {
  const next = { ...ui.solo };
  if (solo) next[mixer] = solo;
  else delete next[mixer];
  set({ ...ui, solo: next });
}

/** Plot these series in the curve panel (none: keep the panel's). */
export function setCurves(keys: string[]): void {
  if (keys.length) set({ ...ui, curves: keys });
}

/** Plot these series, live, and bring the curve panel into view. */
export function showCurves(keys: string[]): void {
  if (keys.length) set({ ...ui, curves: keys, curvesShown: ui.curvesShown + 1 });
}

export function useLiveUi(): LiveUi {
  return useSyncExternalStore((l) => { listeners.add(l); return () => listeners.delete(l); }, getLiveUi);
}
