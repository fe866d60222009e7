// The clip editor's pose panel: one control per DoF of the robot (sliders and typed values for
// continuous DoFs, colour pickers, option selects), showing the pose at the playhead until moved; a
// moved DoF is marked changed (what "Key pose" keys and the preview shows). "Live" streams the changed
// DoFs to the program's puppet layer; a gamepad's stick can drive two chosen DoFs.
import { memo, useCallback, useMemo, useState, type KeyboardEvent } from "react";
import { commitText, formatNumber, niceStep, type NumberSpec } from "../fields/numberField";
import { hexToRgb, rgbToHex } from "../schemaForm";
import { clipApi, type PoseValues } from "./clipApi";
import type { DofInfo } from "./model/types";
import { useGamepad } from "./usePoseInputs";
import { sliderRange } from "./poseValues";
import { usePoseStream } from "./useServerSync";

export interface PosePanelProps {
  rows: { group: string; dofs: DofInfo[] }[];
  /** The pose the clip plays at the playhead (DoFs without a track are absent: their rest shows). */
  played: PoseValues;
  /** The DoFs moved in the panel (or grabbed, or by the gamepad) and their values. */
  edited: PoseValues;
  onEdit: (values: PoseValues) => void;
  onClear: () => void;
}

/** Puppet messages are re-sent this often (ms) while nothing moves: the puppet layer fades out after
 * its timeout (0.5 s in the bundled programs) without them. */
const PUPPET_KEEPALIVE_MS = 200;

function specOf(d: DofInfo): NumberSpec {
  const [softMin, softMax] = sliderRange(d);
  return {
    softMin, softMax, step: niceStep(softMax - softMin),
    ...(Number.isFinite(d.min) ? { hardMin: d.min } : {}), ...(Number.isFinite(d.max) ? { hardMax: d.max } : {}),
  };
}

function numberOf(v: PoseValues[string] | undefined, fallback: number): number {
  return typeof v === "number" ? v : fallback;
}

function ContinuousRow({ dof, value, changed, onEdit }: { dof: DofInfo; value: number; changed: boolean; onEdit: (v: number) => void }) {
  const [draft, setDraft] = useState<string | null>(null);
  const [bad, setBad] = useState<string | null>(null);
  const spec = useMemo(() => specOf(dof), [dof]);
  const commit = () => {
    if (draft === null) return;
    setDraft(null);
    const c = commitText(draft, spec);
    if (!c.ok) { setBad(c.reason); return; }
    setBad(c.note ?? null);
    onEdit(c.value);
  };
  const onKey = (e: KeyboardEvent<HTMLInputElement>) => {
    if (e.key === "Enter") commit();
    if (e.key === "Escape") { setDraft(null); setBad(null); }
  };
  return (
    <div className={`pose-row ${changed ? "changed" : ""}`} title={dof.description}>
      <span className="pose-name">{dof.name}</span>
      <input type="range" data-testid={`pose-slider-${dof.name}`} aria-label={dof.name} min={spec.softMin} max={spec.softMax}
             step={spec.step} value={value} onChange={(e) => onEdit(Number(e.target.value))} />
      <input type="text" inputMode="decimal" className={`pose-number ${bad ? "bad" : ""}`} data-testid={`pose-${dof.name}`}
             aria-label={`${dof.name} value`} title={bad ?? `${dof.min} … ${dof.max}`} spellCheck={false}
             value={draft ?? formatNumber(value)} onChange={(e) => setDraft(e.target.value)} onBlur={commit} onKeyDown={onKey}
             onFocus={(e) => e.currentTarget.select()} />
    </div>
  );
}

function OtherRow({ dof, value, changed, onEdit }: { dof: DofInfo; value: PoseValues[string] | undefined; changed: boolean; onEdit: (v: PoseValues[string]) => void }) {
  return (
    <div className={`pose-row ${changed ? "changed" : ""}`} title={dof.description}>
      <span className="pose-name">{dof.name}</span>
      {dof.type === "colour"
        ? <input type="color" data-testid={`pose-${dof.name}`} aria-label={dof.name}
                 value={rgbToHex(Array.isArray(value) ? value : [0, 0, 0])} onChange={(e) => onEdit(hexToRgb(e.target.value))} />
        : <select data-testid={`pose-${dof.name}`} aria-label={dof.name} value={typeof value === "string" ? value : ""}
                  onChange={(e) => onEdit(e.target.value)}>
            {typeof value !== "string" && <option value="">—</option>}
            {(dof.options ?? []).map((o) => <option key={o} value={o}>{o}</option>)}
          </select>}
    </div>
  );
}

function PosePanelImpl({ rows, played, edited, onEdit, onClear }: PosePanelProps) {
  const [live, setLive] = useState(false);
  const [pad, setPad] = useState<[string, string]>(["", ""]);
  const continuous = useMemo(() => rows.flatMap((r) => r.dofs).filter((d) => d.type === "continuous"), [rows]);
  const shown = useCallback((d: DofInfo) => edited[d.name] ?? played[d.name], [edited, played]);

  // Live: the changed DoFs go to the program's puppet layer, so the robot follows the sliders
  const puppetPose = useCallback(() => (Object.keys(edited).length ? { values: edited } : null), [edited]);
  usePoseStream(live, puppetPose,
    (values) => clipApi.command(values === null ? { type: "puppet", release: true } : { type: "puppet", values }),
    PUPPET_KEEPALIVE_MS);

  const byName = useMemo(() => new Map(continuous.map((d) => [d.name, d])), [continuous]);
  const base = useCallback((name: string) => numberOf(played[name], byName.get(name)?.rest ?? 0), [played, byName]);
  const connected = useGamepad(true, [byName.get(pad[0]) ?? null, byName.get(pad[1]) ?? null], base, onEdit);

  return (
    <div className="pose-panel" data-testid="pose-panel">
      <div className="pose-head">
        <strong>Pose</strong>
        <label className="pose-live" title="send moved DoFs to the robot's puppet layer as they move">
          <input type="checkbox" data-testid="pose-live" checked={live} onChange={(e) => setLive(e.target.checked)} /> Live
        </label>
        <button type="button" data-testid="pose-clear" disabled={!Object.keys(edited).length} onClick={onClear}
                title="forget the moved DoFs: show the clip's pose again">Reset</button>
      </div>
      <div className="pose-pad" title={connected ? "the gamepad's stick drives these DoFs" : "connect a gamepad to drive two DoFs with its stick"}>
        <span className="muted">{connected ? "Stick" : "No gamepad"}</span>
        {(["x", "y"] as const).map((axis, i) => (
          <select key={axis} data-testid={`pose-pad-${axis}`} aria-label={`gamepad ${axis}`} value={pad[i]}
                  onChange={(e) => setPad((p) => (i === 0 ? [e.target.value, p[1]] : [p[0], e.target.value]))}>
            <option value="">{axis}: —</option>
            {continuous.map((d) => <option key={d.name} value={d.name}>{axis}: {d.name}</option>)}
          </select>
        ))}
      </div>
      <div className="pose-rows">
        {rows.map((r) => (
          <div key={r.group} className="pose-group">
            <div className="pose-group-name">{r.group}</div>
            {r.dofs.map((d) => d.type === "continuous"
              ? <ContinuousRow key={d.name} dof={d} value={numberOf(shown(d), d.rest)} changed={d.name in edited}
                               onEdit={(v) => onEdit({ [d.name]: v })} />
              : <OtherRow key={d.name} dof={d} value={shown(d)} changed={d.name in edited} onEdit={(v) => onEdit({ [d.name]: v })} />)}
          </div>
        ))}
      </div>
    </div>
  );
}

export const PosePanel = memo(PosePanelImpl);
