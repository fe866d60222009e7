// What Home frames in the graph editor: the time span of the shown curves' keys (and the ghost's
// samples) and the value range the curves (display values, with offsets), keys and ghost cover.
import type { FilteredTracks } from "../../generated/api";
import { prepareCurve } from "../model/curve";
import type { Clip, DofInfo } from "../model/types";
import type { ValueView } from "./graphDraw";
import { extent, frameValues } from "./graphDraw";
import type { TimeView } from "./timeView";
import { frameAll, frameSpan } from "./timeView";

const SAMPLES = 240;

export function graphFrame(
  doc: Clip,
  shown: readonly DofInfo[],
  offsets: Record<string, number>,
  ghost: FilteredTracks | null,
): { view: TimeView; values: ValueView } {
  let ta = Infinity;
  let tb = -Infinity;
  for (const d of shown) {
    for (const k of doc.tracks[d.name] ?? []) {
      ta = Math.min(ta, k.t);
      tb = Math.max(tb, k.t);
    }
    const g = ghost?.tracks[d.name];
    if (g && g.length && ghost.rate > 0) {
      ta = Math.min(ta, 0);
      tb = Math.max(tb, (g.length - 1) / ghost.rate);
    }
  }
  const view = ta <= tb ? (tb - ta > 1e-6 ? frameSpan(ta, tb) : frameSpan(Math.min(ta, 0), Math.max(tb, 1))) : frameAll(doc);
  const vals: number[] = [];
  for (const d of shown) {
    const keys = doc.tracks[d.name];
    const off = offsets[d.name] ?? 0;
    if (keys?.length) {
      const c = prepareCurve(keys);
      for (let i = 0; i <= SAMPLES; i++) vals.push(c.at(view.t0 + ((view.t1 - view.t0) * i) / SAMPLES) + off);
      for (const k of keys) if (typeof k.v === "number") vals.push(k.v + off);
    }
    const g = ghost?.tracks[d.name];
    if (g && ghost.rate > 0) {
      for (let i = 0; i < g.length; i++) {
        const t = i / ghost.rate;
        if (t >= view.t0 && t <= view.t1) vals.push(g[i]);
      }
    }
  }
  let range = extent(vals);
  if (!range) range = extent(shown.flatMap((d) => [d.min, d.max, (offsets[d.name] ?? 0) + 0]));
  return { view, values: range ? frameValues(range[0], range[1]) : { v0: -1, v1: 1 } };
}
