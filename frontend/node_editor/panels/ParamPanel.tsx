// The parameter panel, generated from the selected block's JSON Schema; the server's errors for the
// block are shown on it and on the fields they name.
import { useMemo, useState, type ReactNode } from "react";
import type { RobotDescription } from "../api";
import { fieldsFromSchema, hexToRgb, rgbToHex, type Field } from "../schemaForm";
import { useActions, useEditor } from "../store/EditorStore";
import { errorsByNode } from "../store/state";
import { drivenBy } from "../live/logic";
import { DrivenBy, LayerStack, type Layer } from "../live/ParamExtras";
import { NumberField } from "../fields/NumberField";
import { PoseField } from "../clip_editor/PoseField";

function DofPicker({ value, robot, onChange }: { value: string[]; robot: RobotDescription | null; onChange: (v: string[]) => void }) {
  const [text, setText] = useState("");
  const names = robot?.dofs.map((d) => d.name) ?? [];
  const add = (s: string) => s && !value.includes(s) && onChange([...value, s]);
  return (
    <div className="dofs">
      <div className="chips">
        {value.map((s) => (
          <span key={s} className="chip">{s}<button aria-label={`remove ${s}`} onClick={() => onChange(value.filter((x) => x !== s))}>×</button></span>
        ))}
      </div>
      <div className="row">
        <input list="dof-names" value={text} placeholder="DoF, glob or stationary:*" onChange={(e) => setText(e.target.value)}
               onKeyDown={(e) => { if (e.key === "Enter") { add(text.trim()); setText(""); } }} />
        <button onClick={() => { add(text.trim()); setText(""); }}>add</button>
      </div>
      <datalist id="dof-names">
        {["*", "stationary:*", "spatial:*", "display:*", ...names].map((n) => <option key={n} value={n} />)}
      </datalist>
    </div>
  );
}

function FieldEditor({ f, value, robot, clips, onChange }: { f: Field; value: unknown; robot: RobotDescription | null; clips: string[]; onChange: (v: unknown, live: boolean) => void }) {
  const v = value === undefined ? f.default : value;
  switch (f.kind) {
    case "enum":
      return (
        <select aria-label={f.name} value={String(v ?? "")} onChange={(e) => {
          const opt = f.options!.find((o) => String(o) === e.target.value);
          onChange(opt, false);
        }}>
          {f.options!.map((o) => <option key={String(o)} value={String(o)}>{String(o)}</option>)}
        </select>
      );
    case "bool":
      return <input type="checkbox" aria-label={f.name} checked={Boolean(v)} onChange={(e) => onChange(e.target.checked, false)} />;
    case "dofs":
      return <DofPicker value={(v as string[]) ?? []} robot={robot} onChange={(x) => onChange(x, false)} />;
    case "posture":
      return (
        <select aria-label={f.name} value={String(v ?? "")} onChange={(e) => onChange(e.target.value || null, false)}>
          <option value="">(none)</option>
          {(robot?.postures ?? []).map((p) => <option key={p} value={p}>{p}</option>)}
        </select>
      );
    case "clip":
      return (
        <select aria-label={f.name} value={String(v ?? "")} onChange={(e) => onChange(e.target.value, false)}>
          {[...(v && !clips.includes(String(v)) ? [String(v)] : []), ...clips].map((c) => <option key={c} value={c}>{c}</option>)}
        </select>
      );
    case "colour":
      return <input type="color" aria-label={f.name} value={rgbToHex((v as number[]) ?? [1, 1, 1])} onChange={(e) => onChange(hexToRgb(e.target.value), false)} />;
    case "text":
      return <input type="text" aria-label={f.name} value={String(v ?? "")} onChange={(e) => onChange(e.target.value, false)} />;
    default:
      return <JsonField value={v} onChange={(x) => onChange(x, false)} />;
  }
}

/** A numeric parameter: slider over its soft range (when it has one) and free typing (../fields). */
function NumberParam({ f, value, disabled, aside, onChange }: {
  f: Field; value: unknown; disabled: boolean; aside: ReactNode; onChange: (v: unknown, live: boolean) => void;
}) {
  const v = value === undefined ? f.default : value;
  const num = typeof v === "number" ? v : null;  // null: a nullable override left to its default (e.g. the preset's σ)
  return (
    <NumberField testId={`param-${f.name}`} label={f.label} ariaLabel={f.name} value={num} spec={f.number!}
                 disabled={disabled} aside={aside} onChange={(x, phase) => onChange(x, phase === "live")}>
      {f.nullable && v !== null && v !== undefined && !disabled &&
        <button type="button" title="use the default" onClick={() => onChange(null, false)}>↺</button>}
    </NumberField>
  );
}

/** A JSON field grows with its text up to this many rows, then scrolls. */
const JSON_MAX_ROWS = 10;

function JsonField({ value, onChange }: { value: unknown; onChange: (v: unknown) => void }) {
  const [text, setText] = useState(JSON.stringify(value ?? null, null, 1));
  const [bad, setBad] = useState(false);
  return (
    <textarea className={bad ? "bad" : ""} rows={Math.min(JSON_MAX_ROWS, text.split("\n").length + 1)} value={text}
              onChange={(e) => setText(e.target.value)}
              onBlur={() => { try { onChange(JSON.parse(text)); setBad(false); } catch { setBad(true); } }} />
  );
}

export function ParamPanel() {
  const { state: { catalog, history, robot, clips, report }, dispatch } = useEditor();
  const { editParams: onChange } = useActions();
  const node = history.present.nodes.find((n) => n.selected) ?? null;
  const entry = node ? catalog[node.data.type] : undefined;
  const errors = useMemo(() => (node ? errorsByNode(report)[node.id] ?? [] : []), [node, report]);
  const fields = useMemo(() => (entry ? fieldsFromSchema(entry.params_schema) : []), [entry]);
  if (!node || !entry) return <div className="panel empty">Select a block to edit its parameters.</div>;
  const params = node.data.params;
  return (
    <div className="panel params" data-testid="param-panel">
      <h3>{entry.title} <span className="muted">{node.id}</span></h3>
      <p className="doc">{entry.doc}</p>
      {errors.map((e, i) => <div key={i} className="error-line">{e}</div>)}
      {fields.map((f) => {
        const bad = errors.some((e) => e.includes(`'${f.name}'`)) ? "bad" : "";
        if (node.data.type === "layer_mixer" && f.name === "layers" && Array.isArray(params.layers))
          return (
            <div key={f.name} className={`field ${bad}`}>
              <span className="field-name">{f.label}</span>
              <LayerStack node={node.id} layers={params.layers as Layer[]}
                          onChange={(layers, live) => onChange(node.id, { ...params, layers }, live)} />
            </div>
          );
        const driver = drivenBy(history.present.edges, node.id, f.name);
        // a pose parameter (the constant pose's `values`): one row per DoF rather than raw JSON
        if (entry.params_schema.properties?.[f.name]?.["x-widget"] === "pose" && !driver)
          return (
            <div key={`${node.id}/${f.name}`} className={`field ${bad}`} title={f.description}>
              <span className="field-name">{f.label}</span>
              <PoseField name={f.name} value={params[f.name]} robot={robot}
                         onChange={(val, live) => onChange(node.id, { ...params, [f.name]: val }, live)} />
              {f.description && <span className="hint">{f.description}</span>}
            </div>
          );
        if (f.number)
          return (
            // keyed by node too: a half-typed value or a hint does not carry over to the next block
            <div key={`${node.id}/${f.name}`} className={`field ${bad} ${driver ? "driven" : ""}`} title={f.description}>
              <NumberParam f={f} value={params[f.name]} disabled={!!driver}
                           aside={driver && <DrivenBy param={f.name} driver={driver} />}
                           onChange={(val, live) => onChange(node.id, { ...params, [f.name]: val }, live)} />
              {f.description && <span className="hint">{f.description}</span>}
            </div>
          );
        const editor = <FieldEditor f={f} value={params[f.name]} robot={robot} clips={clips}
                                    onChange={(val, live) => onChange(node.id, { ...params, [f.name]: val }, live)} />;
        return (
          <label key={f.name} className={`field ${bad} ${driver ? "driven" : ""}`} title={f.description}>
            <span className="field-name">{f.label}</span>
            {driver && <DrivenBy param={f.name} driver={driver} />}
            {driver ? <fieldset disabled className="driven-editor" title="overridden by the wire">{editor}</fieldset> : editor}
            {f.kind === "clip" && typeof (params[f.name] ?? f.default) === "string" && (params[f.name] ?? f.default) !== "" && (
              <button type="button" data-testid="param-edit-clip" title="open this clip in the clip editor"
                      onClick={(e) => { e.preventDefault(); dispatch({ type: "clipRequested", name: String(params[f.name] ?? f.default) }); }}>Edit clip</button>
            )}
            {f.description && <span className="hint">{f.description}</span>}
          </label>
        );
      })}
    </div>
  );
}
