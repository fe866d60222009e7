// The top bar: the program's name and status, live or draft, the safety net's corrections, files,
// undo/redo (zoom and Fit are on the canvas).
import { CommandButtons } from "./CommandButtons";
import { SafetyIndicator } from "./live/SafetyIndicator";
import { SaveAsDialog } from "./saveAs/SaveAsDialog";
import { useActions, useEditor } from "./store/EditorStore";
import { statusText } from "./store/state";

export function Toolbar() {
  const { state, dispatch } = useEditor();
  const { newProgram, open, openRunning, save, saveAs, importJson, exportJson, goLive, detach } = useActions();
  const { meta, dirty, report, syncing, library, history, live, runningName } = state;
  return (
    <header className="topbar">
      <span className="logo">Nutty</span>
      <input className="prog-name" aria-label="program name" value={meta?.name ?? ""}
             onChange={(e) => dispatch({ type: "renamed", name: e.target.value })} />
      {/* the dot keeps its place when clean, the status sits after the buttons: a changing status or an
          edit never moves a button from under the pointer */}
      <span className="dirty" title="unsaved changes" style={{ visibility: dirty ? "visible" : "hidden" }}>●</span>
      {live ? (
        <>
          <span className="mode live" data-testid="mode" title="edits reach the robot as you make them">● live</span>
          <button onClick={detach} title="keep editing without moving the robot">Edit as draft</button>
        </>
      ) : (
        <>
          <span className="mode draft" data-testid="mode"
                title="edits are validated but do not reach the robot until Go live">
            draft{runningName ? ` · robot runs '${runningName}'` : ""}
          </span>
          <button className="go-live" data-testid="go-live" onClick={() => goLive()} disabled={!report?.valid}
                  title="swap this program into the robot (Ctrl+Enter); it moves there smoothly, within its limits">Go live</button>
          <button onClick={openRunning} title="discard the draft and show what the robot runs">Back to running</button>
        </>
      )}
      <span className={`status ${report?.valid ? "ok" : "bad"}`} data-testid="status">{statusText(report, syncing, live)}</span>
      <SafetyIndicator />
      <span className="spacer" />
      <button onClick={newProgram}>New</button>
      <select aria-label="open program" value="" onChange={(e) => e.target.value && open(e.target.value)}>
        <option value="">Open…</option>
        {library.map((p) => <option key={p} value={p}>{p}</option>)}
      </select>
      <button onClick={() => save()} data-testid="save">Save</button>
      <button onClick={saveAs} data-testid="save-as">Save as</button>
      <SaveAsDialog />
      <label className="button">Import<input type="file" accept=".json" hidden onChange={(e) => e.target.files?.[0] && importJson(e.target.files[0])} /></label>
      <button onClick={exportJson}>Export</button>
      <button onClick={() => dispatch({ type: "undo" })} disabled={!history.past.length} data-testid="undo" title="Ctrl+Z">Undo</button>
      <button onClick={() => dispatch({ type: "redo" })} disabled={!history.future.length} data-testid="redo" title="Ctrl+Shift+Z">Redo</button>
      <CommandButtons />
    </header>
  );
}
