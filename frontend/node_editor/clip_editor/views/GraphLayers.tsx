// The graph editor's drawn layers, each memoised on plain values so a drag redraws only what changed:
// the value axis and grid, one DoF's curve (with its limits, the trajectory helper's over-limit spans and
// the ghost), and one DoF's keys and the handles of its selected bezier keys.
import { memo } from "react";
import type { PointerEvent as ReactPointerEvent } from "react";
import type { LimitRange } from "../../generated/api";
import { prepareCurve } from "../model/curve";
import type { ClipErrors, Keyframe, KeyRef, Side } from "../model/types";
import type { Plot } from "./graphDraw";
import { curvePath, groupSpans, samplesPath, spansPath, valueTicks, valueToY } from "./graphDraw";
import { timeToX } from "./timeView";

/** A plot's geometry as plain props (memo compares them by value). */
export interface PlotProps {
  t0: number;
  t1: number;
  v0: number;
  v1: number;
  width: number;
  height: number;
}

export const toPlot = (p: PlotProps): Plot => ({ view: { t0: p.t0, t1: p.t1 }, values: { v0: p.v0, v1: p.v1 }, width: p.width, height: p.height });

export const Axis = memo(function Axis({ plot, gutter }: { plot: PlotProps; gutter: number }) {
  const p = toPlot(plot);
  return (
    <g className="graph-axis">
      {valueTicks(p).map((k) => {
        const y = valueToY(p, k.v);
        return (
          <g key={k.v}>
            <line className={k.v === 0 ? "grid zero" : "grid"} x1={gutter} x2={gutter + p.width} y1={y} y2={y} />
            <text x={gutter - 6} y={y + 4} textAnchor="end">{k.label}</text>
          </g>
        );
      })}
      <text className="axis-unit" x={6} y={12}>rad</text>
    </g>
  );
});

const limitTitle = (r: LimitRange[], kind: string): string => {
  const worst = Math.max(...r.map((x) => x.worst_ratio));
  const other = [...new Set(r.flatMap((x) => Object.keys(x.limits)))].filter((k) => k !== kind);
  return `${kind} limit broken (worst ${worst.toFixed(2)}× the limit)${other.length ? `; also ${other.join(", ")}` : ""}`;
};

export interface CurveLayerProps {
  dof: string;
  keys: readonly Keyframe[] | undefined;
  colour: string;
  offset: number;
  min: number;
  max: number;
  plot: PlotProps;
  ranges: LimitRange[] | undefined;
  rangeColours: Record<string, string> | undefined;
  ghost: number[] | undefined;
  ghostRate: number;
}

export const CurveLayer = memo(function CurveLayer(c: CurveLayerProps) {
  const p = toPlot(c.plot);
  const curve = c.keys && c.keys.length ? prepareCurve(c.keys) : null;
  const keyTimes = c.keys ? c.keys.map((k) => k.t) : [];
  const yMin = valueToY(p, c.min);
  const yMax = valueToY(p, c.max);
  const byKind = groupSpans(c.ranges ?? [], (r) => r.kind);
  return (
    <g className="graph-curve">
      {Number.isFinite(c.min) && <line className="limit-line" stroke={c.colour} x1={0} x2={p.width} y1={yMin} y2={yMin}><title>{`${c.dof} min ${c.min}`}</title></line>}
      {Number.isFinite(c.max) && <line className="limit-line" stroke={c.colour} x1={0} x2={p.width} y1={yMax} y2={yMax}><title>{`${c.dof} max ${c.max}`}</title></line>}
      {c.ghost && c.ghost.length > 0 && (
        <path className="ghost-path" data-testid={`ghost-${c.dof}`} stroke={c.colour} d={samplesPath(p, c.ghost, c.ghostRate)}>
          <title>{`${c.dof}: what the engine's filter plays (ghost)`}</title>
        </path>
      )}
      {curve && <path className="curve-path" stroke={c.colour} d={curvePath(p, curve.at, keyTimes, c.offset)} />}
      {curve && [...byKind].map(([kind, spans]) => (
        <path key={kind} className="limit-span" data-testid={`limit-${c.dof}-${kind}`} stroke={c.rangeColours?.[kind] ?? "#e5484d"}
              d={spansPath(p, spans, curve.at, keyTimes, c.offset)}>
          <title>{`${c.dof}: ${limitTitle(spans, kind)}`}</title>
        </path>
      ))}
    </g>
  );
});

export interface KeyLayerProps {
  dof: string;
  keys: readonly Keyframe[] | undefined;
  colour: string;
  offset: number;
  plot: PlotProps;
  /** selected key indices, comma-separated */
  selected: string;
  errors: ClipErrors;
  onKey: (e: ReactPointerEvent, ref: KeyRef) => void;
  onHandle: (e: ReactPointerEvent, ref: KeyRef, side: Side) => void;
}

const isBezier = (k: Keyframe | undefined): boolean => !!k && (k.interp ?? "bezier") === "bezier";

export const KeyLayer = memo(function KeyLayer(c: KeyLayerProps) {
  if (!c.keys || !c.keys.length) return null;
  const p = toPlot(c.plot);
  const keys = c.keys;
  const sels = new Set(c.selected ? c.selected.split(",").map(Number) : []);
  const handles = sels.size ? prepareCurve(keys).handles : [];
  const X = (t: number) => timeToX(p.view, p.width, t);
  const Y = (v: number) => valueToY(p, v + c.offset);
  return (
    <g className="graph-keys">
      {[...sels].map((i) => {
        const k = keys[i];
        const h = handles[i];
        if (!k || !h || typeof k.v !== "number") return null;
        const sides: Side[] = [];
        if (i > 0 && (isBezier(k) || isBezier(keys[i - 1]))) sides.push("left");
        if (i < keys.length - 1 && isBezier(k)) sides.push("right");
        const kx = X(k.t);
        const ky = Y(k.v);
        return sides.map((side) => {
          const [ht, hv] = h[side];
          const hx = X(ht);
          const hy = Y(hv);
          return (
            <g key={`${i}-${side}`} className="graph-handle">
              <line x1={kx} y1={ky} x2={hx} y2={hy} />
              <circle cx={hx} cy={hy} r={4} data-testid={`handle-${c.dof}-${i}-${side}`} data-t={ht} data-v={hv}
                      onPointerDown={(e) => c.onHandle(e, { dof: c.dof, index: i }, side)}>
                <title>{`${side} handle (${k[side === "left" ? "left_type" : "right_type"] ?? "auto_clamped"})`}</title>
              </circle>
            </g>
          );
        });
      })}
      {keys.map((k, i) => {
        if (typeof k.v !== "number") return null;
        const x = X(k.t);
        if (x < -8 || x > p.width + 8) return null;
        const sel = sels.has(i);
        const err = c.errors[`${c.dof}#${i}`];
        return (
          <circle key={i} cx={x} cy={Y(k.v)} r={sel ? 5 : 4} fill={sel ? undefined : c.colour}
                  className={`gkey${sel ? " selected" : ""}${err ? " key-error" : ""}`}
                  data-testid={`gkey-${c.dof}-${i}`} data-t={k.t} data-v={k.v} data-selected={sel ? "true" : "false"}
                  onPointerDown={(e) => c.onKey(e, { dof: c.dof, index: i })}>
            <title>{err ?? `${c.dof} @ ${k.t.toFixed(3)} s = ${k.v.toFixed(4)} (${k.interp ?? "bezier"})`}</title>
          </circle>
        );
      })}
    </g>
  );
});
