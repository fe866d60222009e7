// The behaviour's declared parameters (name, type, default, description: what callers and AIs give)
// and, beside each, the value the editor's plan, preview and play use (empty: its default).
import type { Param } from "../generated/behaviour";
import { CommitInput } from "./fieldInputs";
import { uniqueName } from "./model/edits";
import type { BehaviourDoc } from "./model/types";
import { formatParam, parseParam, removeParam, renameParam, setParam, type ParamType } from "./paramValues";

const TYPES: ParamType[] = ["string", "number", "vec3", "bool"];

export function ParamsPanel({ doc, edit, values, setValue, errors }: {
  doc: BehaviourDoc; edit: (doc: BehaviourDoc, label: string) => void;
  values: Record<string, string>; setValue: (name: string, text: string) => void; errors: Record<string, string>;
}) {
  const params = doc.params ?? {};
  const update = (name: string, patch: Partial<Param>, label: string) => {
    const next: Param = { ...params[name], ...patch };
    for (const k of Object.keys(patch) as (keyof Param)[]) if (patch[k] === undefined) delete next[k];
    edit(setParam(doc, name, next), label);
  };
  const add = () => edit(setParam(doc, uniqueName("param", Object.keys(params)), { type: "string", description: "" }), "add parameter");
  return (
    <div className="bh-params" data-testid="behaviour-params">
      <div className="bh-section-head">Parameters <button type="button" data-testid="behaviour-param-add" onClick={add}>+ Add</button></div>
      {!Object.keys(params).length && <div className="muted">No parameters. Items take one as a field's whole value: “{"{name}"}”.</div>}
      {Object.entries(params).map(([name, decl]) => (
        <div className="bh-param" key={name} data-testid={`behaviour-param-row-${name}`}>
          <div className="bh-param-line">
            <CommitInput testId={`behaviour-param-name-${name}`} value={name} ariaLabel="name"
                         onCommit={(t) => edit(renameParam(doc, name, t.trim()), "rename parameter")} />
            <select data-testid={`behaviour-param-type-${name}`} value={decl.type} aria-label="type"
                    onChange={(e) => update(name, { type: e.target.value as ParamType, default: undefined }, "parameter type")}>
              {TYPES.map((t) => <option key={t} value={t}>{t}</option>)}
            </select>
            <button type="button" className="bh-icon" title={`remove ${name}`} data-testid={`behaviour-param-remove-${name}`}
                    onClick={() => edit(removeParam(doc, name), "remove parameter")}>×</button>
          </div>
          <label>Default
            <CommitInput testId={`behaviour-param-default-${name}`} value={formatParam(decl.default)} placeholder="(required)"
                         onCommit={(t) => {
                           if (!t.trim()) { update(name, { default: undefined }, "parameter default"); return; }
                           const p = parseParam(decl.type, t);
                           update(name, { default: p.ok ? p.value : t }, "parameter default");
                         }} />
          </label>
          <label>Description
            <CommitInput testId={`behaviour-param-description-${name}`} value={decl.description ?? ""}
                         onCommit={(t) => update(name, { description: t }, "parameter description")} />
          </label>
          <label>Preview value
            <input data-testid={`behaviour-param-${name}`} value={values[name] ?? ""} placeholder={formatParam(decl.default) || "required"}
                   className={errors[name] ? "invalid" : ""} title={errors[name] ?? ""}
                   onChange={(e) => setValue(name, e.target.value)} />
          </label>
        </div>
      ))}
    </div>
  );
}
