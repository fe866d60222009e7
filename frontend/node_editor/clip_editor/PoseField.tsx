// The parameter panel's editor for a pose parameter (`"x-widget": "pose"`, the constant-pose block's
// `values`): one row per DoF in the pose (a number field within the DoF's limits, a colour picker or
// an option select), a remove button each, and a picker that adds a DoF at its rest value.
import { useMemo } from "react";
import type { RobotDescription } from "../api";
import { NumberField, type NumberPhase } from "../fields/NumberField";
import { niceStep, type NumberSpec } from "../fields/numberField";
import { hexToRgb, rgbToHex } from "../schemaForm";
import type { PoseValues } from "./clipApi";
import { dofInfos } from "./model/dofs";
import type { DofInfo } from "./model/types";
import { sliderRange } from "./poseValues";
import "./clipEditor.css";

export interface PoseFieldProps {
  /** The parameter's name (test ids: `posefield-<dof>`, `posefield-add`, `posefield-remove-<dof>`). */
  name: string;
  value: unknown;
  robot: RobotDescription | null;
  onChange: (values: PoseValues, live: boolean) => void;
}

/** The pose in a parameter's value (entries that are no pose value are dropped). */
export function asPose(value: unknown): PoseValues {
  if (!value || typeof value !== "object" || Array.isArray(value)) return {};
  const out: PoseValues = {};
  for (const [k, v] of Object.entries(value as Record<string, unknown>)) {
    if (typeof v === "number" || typeof v === "string" || (Array.isArray(v) && v.every((x) => typeof x === "number"))) out[k] = v as PoseValues[string];
  }
  return out;
}

/** The value a DoF added to a pose starts at: its rest value. */
export function restOf(d: DofInfo): PoseValues[string] {
  if (d.restValue !== undefined) return d.restValue;
  if (d.type === "enum") return d.options?.[0] ?? "";
  if (d.type === "colour") return [d.rest, d.rest, d.rest];
  return d.rest;
}

function specOf(d: DofInfo): NumberSpec {
  const [softMin, softMax] = sliderRange(d);
  return {
    softMin, softMax, step: niceStep(softMax - softMin),
    ...(Number.isFinite(d.min) ? { hardMin: d.min } : {}), ...(Number.isFinite(d.max) ? { hardMax: d.max } : {}),
  };
}

function Row({ dof, value, set }: { dof: DofInfo; value: PoseValues[string]; set: (v: PoseValues[string], live: boolean) => void }) {
  const spec = useMemo(() => specOf(dof), [dof]);
  if (dof.type === "continuous")
    return <div className="pf-number"><NumberField testId={`posefield-${dof.name}`} label={dof.name} value={typeof value === "number" ? value : null}
                        spec={spec} onChange={(v: number, phase: NumberPhase) => set(v, phase === "live")} /></div>;
  if (dof.type === "colour")
    return <label className="pf-other"><span className="field-name">{dof.name}</span>
      <input type="color" data-testid={`posefield-${dof.name}`} aria-label={dof.name} value={rgbToHex(Array.isArray(value) ? value : [0, 0, 0])}
             onChange={(e) => set(hexToRgb(e.target.value), false)} /></label>;
  return <label className="pf-other"><span className="field-name">{dof.name}</span>
    <select data-testid={`posefield-${dof.name}`} aria-label={dof.name} value={String(value)} onChange={(e) => set(e.target.value, false)}>
      {(dof.options ?? []).map((o) => <option key={o} value={o}>{o}</option>)}
    </select></label>;
}

export function PoseField({ name, value, robot, onChange }: PoseFieldProps) {
  const pose = asPose(value);
  const infos = useMemo(() => (robot ? dofInfos(robot) : []), [robot]);
  const byName = useMemo(() => new Map(infos.map((d) => [d.name, d])), [infos]);
  const missing = infos.filter((d) => !(d.name in pose));
  const set = (dof: string, v: PoseValues[string], live: boolean) => onChange({ ...pose, [dof]: v }, live);
  const remove = (dof: string) => onChange(Object.fromEntries(Object.entries(pose).filter(([k]) => k !== dof)), false);
  return (
    <div className="pose-field" data-testid={`posefield-${name}`}>
      {Object.entries(pose).map(([dof, v]) => {
        const info = byName.get(dof) ?? { name: dof, type: typeof v === "string" ? "enum" : Array.isArray(v) ? "colour" : "continuous",
          min: -Infinity, max: Infinity, rest: 0, velocity: Infinity, group: "Other" } satisfies DofInfo;
        return (
          <div key={dof} className="pose-field-row">
            <Row dof={info} value={v} set={(x, live) => set(dof, x, live)} />
            <button type="button" data-testid={`posefield-remove-${dof}`} aria-label={`remove ${dof}`} onClick={() => remove(dof)}>×</button>
          </div>
        );
      })}
      <div className="pose-field-add">
        <select data-testid="posefield-add" aria-label="add a DoF" value=""
                onChange={(e) => { const d = byName.get(e.target.value); if (d) onChange({ ...pose, [d.name]: restOf(d) }, false); }}>
          <option value="">add DoF…</option>
          {missing.map((d) => <option key={d.name} value={d.name}>{d.name}</option>)}
        </select>
      </div>
    </div>
  );
}
