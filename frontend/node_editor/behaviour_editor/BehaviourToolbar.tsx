// The behaviour editor's toolbar: the name and dirty mark, undo/redo, save, adding tracks and items (a
// kind menu), deleting the selected item, the browser preview and playing on the robot, and the status.
import type { DocumentBarProps } from "../clip_editor/documentBar";
import { useState } from "react";
import { ITEM_KINDS, KIND_ORDER, type ItemKind } from "./model/types";

export interface BehaviourToolbarProps extends DocumentBarProps {
  addTrack: () => void;
  addItem: (kind: ItemKind) => void;
  canDelete: boolean;
  deleteItem: () => void;
  previewing: boolean;
  togglePreview: () => void;
  onRobot: boolean;
  toggleRobot: () => void;
  close: () => void;
  status: string;
  statusError: boolean;
}

export function BehaviourToolbar(p: BehaviourToolbarProps) {
  const [menu, setMenu] = useState(false);
  return (
    <div className="bh-toolbar">
      <span className="bh-title" title={p.dirty ? "unsaved changes" : "saved"}>
        <span data-testid="behaviour-title-name">{p.name}</span>
        {p.dirty && <span className="bh-dirty" data-testid="behaviour-dirty" aria-label="unsaved changes">●</span>}
      </span>
      <button type="button" data-testid="behaviour-undo" disabled={!p.canUndo} onClick={p.undo} title={`Undo ${p.undoLabel} (Ctrl+Z)`}>↶</button>
      <button type="button" data-testid="behaviour-redo" disabled={!p.canRedo} onClick={p.redo} title={`Redo ${p.redoLabel} (Ctrl+Shift+Z)`}>↷</button>
      <button type="button" data-testid="behaviour-save" disabled={p.saving} onClick={p.save} title="Save to the robot's library (Ctrl+S)">
        {p.saving ? "Saving…" : "Save"}
      </button>
      <span className="bh-sep" />
      <button type="button" data-testid="behaviour-add-track" onClick={p.addTrack}>+ Track</button>
      <span className="bh-menu-anchor">
        <button type="button" data-testid="behaviour-add-item" aria-expanded={menu} onClick={() => setMenu((m) => !m)}>+ Item ▾</button>
        {menu && (
          <div className="bh-menu" role="menu" onMouseLeave={() => setMenu(false)}>
            {KIND_ORDER.map((k) => (
              <button type="button" role="menuitem" key={k} data-testid={`behaviour-add-${k}`} onClick={() => { setMenu(false); p.addItem(k); }}>
                <span className="bh-kind-chip" style={{ background: `var(${ITEM_KINDS[k].colour})` }} />{ITEM_KINDS[k].label}
              </button>
            ))}
          </div>
        )}
      </span>
      <button type="button" data-testid="behaviour-delete-item" disabled={!p.canDelete} onClick={p.deleteItem} title="Delete the selected item (Delete)">Delete</button>
      <span className="bh-sep" />
      <button type="button" data-testid="behaviour-preview" aria-pressed={p.previewing} onClick={p.togglePreview}
              title="Preview in the Pre-Viz with sound (Space)">{p.previewing ? "■ Stop preview" : "▶ Preview"}</button>
      <button type="button" data-testid="behaviour-play-robot" aria-pressed={p.onRobot} onClick={p.toggleRobot}
              className={p.onRobot ? "bh-live" : ""}>{p.onRobot ? "■ Stop robot" : "▶ Play on robot"}</button>
      <span className={`bh-status ${p.statusError ? "error" : ""}`} data-testid="behaviour-status" role="status">{p.status}</span>
      <button type="button" className="bh-close" data-testid="behaviour-close" onClick={p.close} title="Close the behaviour">✕</button>
    </div>
  );
}
