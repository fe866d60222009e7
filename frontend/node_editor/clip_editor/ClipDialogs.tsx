// The clip editor's small inline dialogs (never window.confirm/prompt): unsaved changes before a clip
// is closed or replaced, and a pose saved as a named posture.
import { useState } from "react";
import { clipApi, type PoseValues } from "./clipApi";
import { refusalOf } from "./clipErrors";

export function UnsavedDialog({ name, what, onSave, onDiscard, onCancel }: {
  name: string; what: string; onSave: () => void; onDiscard: () => void; onCancel: () => void;
}) {
  return (
    <div className="clip-dialog" role="dialog" aria-label="unsaved changes" data-testid="clip-confirm">
      <p>“{name}” has unsaved changes. {what}?</p>
      <div className="clip-dialog-buttons">
        <button type="button" data-testid="clip-confirm-save" onClick={onSave}>Save</button>
        <button type="button" data-testid="clip-confirm-discard" onClick={onDiscard}>Discard changes</button>
        <button type="button" data-testid="clip-confirm-cancel" onClick={onCancel} autoFocus>Cancel</button>
      </div>
    </div>
  );
}

export function PostureDialog({ values, onDone }: { values: PoseValues; onDone: (saved: string | null) => void }) {
  const [name, setName] = useState("");
  const [description, setDescription] = useState("");
  const [error, setError] = useState<string | null>(null);
  const [busy, setBusy] = useState(false);
  const save = () => {
    if (!name.trim()) { setError("name the posture"); return; }
    setBusy(true);
    clipApi.savePosture(name.trim(), description, values)
      .then((r) => onDone(r.saved))
      .catch((e: unknown) => setError(refusalOf(e).message))
      .finally(() => setBusy(false));
  };
  return (
    <div className="clip-dialog" role="dialog" aria-label="save as posture" data-testid="posture-dialog">
      <p>Save the pose ({Object.keys(values).length} DoFs) as a posture</p>
      <label>Name <input data-testid="posture-name" value={name} autoFocus onChange={(e) => setName(e.target.value)}
                         onKeyDown={(e) => { if (e.key === "Enter") save(); if (e.key === "Escape") onDone(null); }} /></label>
      <label>Description <input data-testid="posture-description" value={description} onChange={(e) => setDescription(e.target.value)} /></label>
      {error && <div className="clip-error-text" data-testid="posture-error">{error}</div>}
      <div className="clip-dialog-buttons">
        <button type="button" data-testid="posture-save" disabled={busy} onClick={save}>Save</button>
        <button type="button" onClick={() => onDone(null)}>Cancel</button>
      </div>
    </div>
  );
}
