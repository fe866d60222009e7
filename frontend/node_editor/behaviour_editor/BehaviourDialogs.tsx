// The behaviour editor's inline dialog for naming a new behaviour on its first save (never
// window.prompt). Unsaved-changes questions reuse the clip editor's dialog (../clip_editor/ClipDialogs).
import { useState } from "react";
import { validClipName } from "../clip_editor/ClipBrowser";

export function NameDialog({ taken, onSave, onCancel }: { taken: readonly string[]; onSave: (name: string) => void; onCancel: () => void }) {
  const [name, setName] = useState("");
  const [error, setError] = useState<string | null>(null);
  const ok = () => {
    const n = name.trim();
    // the same rule as clips' names: letters, digits, _ . -
    if (!validClipName(n)) { setError("letters, digits, _ . - (no spaces)"); return; }
    if (taken.includes(n)) { setError(`“${n}” exists: choose another name`); return; }
    onSave(n);
  };
  return (
    <div className="clip-dialog" role="dialog" aria-label="name the behaviour" data-testid="behaviour-name-dialog">
      <p>Save the new behaviour as</p>
      <input data-testid="behaviour-name" value={name} autoFocus placeholder="name" onChange={(e) => setName(e.target.value)}
             onKeyDown={(e) => { if (e.key === "Enter") ok(); if (e.key === "Escape") onCancel(); }} />
      {error && <div className="bh-error-text" data-testid="behaviour-name-error">{error}</div>}
      <div className="clip-dialog-buttons">
        <button type="button" data-testid="behaviour-name-save" onClick={ok}>Save</button>
        <button type="button" onClick={onCancel}>Cancel</button>
      </div>
    </div>
  );
}
