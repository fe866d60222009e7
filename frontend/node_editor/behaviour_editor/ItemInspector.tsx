// The selected item's fields by kind (./inspectorFields), its id and label, its start (./StartEditor)
// and the errors the plan or the last save reported on it. Each committed change is one undo step.
import { renameItem, updateItem } from "./model/edits";
import { findItem } from "./model/refs";
import { isItemKind, kindInfo, type BehaviourDoc, type Issue, type Plan } from "./model/types";
import { CommitInput, NameSelect } from "./fieldInputs";
import { KIND_FIELDS, fieldText, parseField, type FieldSpec } from "./inspectorFields";
import { StartEditor } from "./StartEditor";

export interface RobotNames { clips: string[]; postures: string[]; sounds: string[]; inputs: string[]; expressions: string[] }

export function ItemInspector({ doc, plan, id, edit, names, errors, onRenamed }: {
  doc: BehaviourDoc; plan: Plan; id: string; edit: (doc: BehaviourDoc, label: string) => void; names: RobotNames;
  errors: Issue[]; onRenamed: (id: string) => void;
}) {
  const found = findItem(doc, id);
  if (!found) return <div className="bh-inspector muted">Select an item on the timeline.</div>;
  const { item } = found;
  const kind = item.kind ?? "play_clip";
  const fields = isItemKind(kind) ? KIND_FIELDS[kind] : [];
  const values = item as unknown as Record<string, unknown>;
  const set = (field: string, value: unknown) => edit(updateItem(doc, id, { [field]: value }), `edit ${field}`);

  const input = (spec: FieldSpec) => {
    const testId = `item-field-${spec.field}`;
    const e = spec.editor;
    const v = values[spec.field];
    if (e.type === "select") {
      return <NameSelect testId={testId} value={typeof v === "string" ? v : ""} options={names[e.source]} optional={e.optional}
                         onChange={(x) => set(spec.field, x === "" && e.optional ? undefined : x)} />;
    }
    if (e.type === "choice") {
      return <NameSelect testId={testId} value={typeof v === "string" ? v : ""} options={e.choices} optional={e.optional}
                         onChange={(x) => set(spec.field, x === "" ? undefined : x)} />;
    }
    return <CommitInput key={`${id}.${spec.field}`} testId={testId} value={fieldText(v)} long={e.type === "text" && e.long}
                        onCommit={(t) => set(spec.field, parseField(e, t))} />;
  };

  return (
    <div className="bh-inspector" data-testid="item-inspector">
      <div className="bh-inspector-head">
        <span className="bh-kind-chip" style={{ background: `var(${kindInfo(kind).colour})` }} />
        {kindInfo(kind).label}
      </div>
      <label>Id
        <CommitInput key={`${id}.id`} testId="item-field-id" value={id} onCommit={(t) => {
          const next = renameItem(doc, id, t.trim());
          if (next !== doc) { edit(next, "rename item"); onRenamed(t.trim()); }
        }} />
      </label>
      <label>Label
        <CommitInput key={`${id}.label`} testId="item-field-label" value={item.label ?? ""}
                     onCommit={(t) => set("label", t.trim() ? t : undefined)} />
      </label>
      {fields.map((spec) => <label key={spec.field}>{spec.label}{input(spec)}</label>)}
      <StartEditor doc={doc} plan={plan} item={item} setStart={(start, label) => edit(updateItem(doc, id, { start }), label)} />
      {errors.length > 0 && (
        <ul className="bh-item-errors" data-testid="item-errors">
          {errors.map((e, i) => <li key={i}>{e.field ? <b>{e.field}: </b> : null}{e.message}</li>)}
        </ul>
      )}
    </div>
  );
}
