// The clip editor's top toolbar: the clip's name and dirty mark, history, save, transport, "On robot",
// the ghost's source, keying the pose, saving it as a posture, recording, closing, and the errors.
import type { DocumentBarProps } from "./documentBar";
import type { ReactNode } from "react";
import type { GhostSource } from "./useServerSync";

export interface ClipToolbarProps extends DocumentBarProps {
  playing: boolean;
  togglePlay: () => void;
  loop: boolean;
  setLoop: (loop: boolean) => void;
  stop: () => void;
  playhead: number;
  onRobot: boolean;
  setOnRobot: (on: boolean) => void;
  ghost: GhostSource;
  setGhost: (g: GhostSource) => void;
  canKeyPose: boolean;
  keyPose: () => void;
  savePosture: () => void;
  close: () => void;
  error: string | null;
  /** The record controls (./RecordControls). */
  record: ReactNode;
}

const GHOSTS: GhostSource[] = ["program", "W", "A", "B", "C", "D", "E", "off"];

export function ClipToolbar(p: ClipToolbarProps) {
  return (
    <div className="clip-toolbar">
      <span className="clip-title" title={p.dirty ? "unsaved changes" : "saved"}>
        <span data-testid="clip-title-name">{p.name}</span>
        {p.dirty && <span className="clip-dirty" data-testid="clip-dirty" aria-label="unsaved changes">●</span>}
      </span>
      <button type="button" data-testid="clip-undo" disabled={!p.canUndo} onClick={p.undo}
              title={`Undo ${p.undoLabel} (Ctrl+Z)`}>↶</button>
      <button type="button" data-testid="clip-redo" disabled={!p.canRedo} onClick={p.redo}
              title={`Redo ${p.redoLabel} (Ctrl+Shift+Z)`}>↷</button>
      <button type="button" data-testid="clip-save" disabled={p.saving} onClick={p.save} title="Save to the robot's library (Ctrl+S)">
        {p.saving ? "Saving…" : "Save"}
      </button>
      <span className="clip-sep" />
      <button type="button" data-testid="clip-play" onClick={p.togglePlay} title="Play / pause (Space)" aria-pressed={p.playing}>
        {p.playing ? "❚❚" : "▶"}
      </button>
      <button type="button" data-testid="clip-stop" onClick={p.stop} title="Stop and go to the start">■</button>
      <label className={`clip-toggle ${p.loop ? "on" : ""}`} title="Loop playback">
        <input type="checkbox" data-testid="clip-loop" checked={p.loop} onChange={(e) => p.setLoop(e.target.checked)} /> Loop
      </label>
      <span className="clip-time" data-testid="clip-time">{p.playhead.toFixed(2)} s</span>
      <label className={`clip-toggle ${p.onRobot ? "on robot" : ""}`}
             title="Play the working copy on the robot, through the program's clip player and safety net">
        <input type="checkbox" data-testid="clip-on-robot" checked={p.onRobot} onChange={(e) => p.setOnRobot(e.target.checked)} /> On robot
      </label>
      <label className="clip-ghost" title="The ghost curve: the clip through the program's motion filter or a preset's">
        Ghost
        <select data-testid="clip-ghost" value={p.ghost} onChange={(e) => p.setGhost(e.target.value as GhostSource)}>
          {GHOSTS.map((g) => <option key={g} value={g}>{g}</option>)}
        </select>
      </label>
      <span className="clip-sep" />
      <button type="button" data-testid="clip-key-pose" disabled={!p.canKeyPose} onClick={p.keyPose}
              title="Key the moved pose DoFs at the playhead">Key pose</button>
      <button type="button" data-testid="clip-save-posture" onClick={p.savePosture} title="Save the pose as a named posture">Save as posture</button>
      {p.record}
      <span className="clip-spacer" />
      {p.error && <span className="clip-error" data-testid="clip-error" role="alert" title={p.error}>{p.error}</span>}
      <button type="button" data-testid="clip-close" onClick={p.close} title="Close the clip">Close</button>
    </div>
  );
}
