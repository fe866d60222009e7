// "Save as": a name for the program in the robot's library, checked as the server checks it while it
// is typed; Enter saves, Escape cancels; a name the library already has asks before replacing that file.
import { useEffect, useRef, useState, type KeyboardEvent } from "react";
import { useActions, useEditor } from "../store/EditorStore";
import { libraryName, nameProblem } from "./libraryName";
import { closeSaveAs, useSaveAsRequest, type SaveAsTarget } from "./saveAsRequest";
import "./saveAs.css";

export function SaveAsDialog() {
  const request = useSaveAsRequest();
  return request === null ? null : <NameStep key={request.name} suggested={request.name} target={request.target} />;
}

function NameStep({ suggested, target }: { suggested: string; target?: SaveAsTarget }) {
  const { library: programs } = useEditor().state;
  const { save: saveProgram } = useActions();
  const what = target?.what ?? "program";
  const library = target?.existing ?? programs;
  const save = target?.save ?? saveProgram;
  const [name, setName] = useState(suggested);
  const [replacing, setReplacing] = useState<string | null>(null);  // the existing file to confirm replacing
  const [tried, setTried] = useState(false);  // the problem shows once the name is changed or a save is tried
  const input = useRef<HTMLInputElement>(null);
  const confirm = useRef<HTMLButtonElement>(null);
  const problem = nameProblem(name);
  useEffect(() => { if (replacing) confirm.current?.focus(); else input.current?.select(); }, [replacing]);

  const submit = () => {
    setTried(true);
    if (problem) return;
    const file = libraryName(name);
    if (library.includes(file)) { setReplacing(file); return; }
    finish(file);
  };
  const finish = (file: string) => {
    closeSaveAs();
    save(file);
  };
  const onKey = (e: KeyboardEvent) => {
    if (e.key === "Escape") {
      e.stopPropagation();
      if (replacing) setReplacing(null); else closeSaveAs();
    } else if (e.key === "Enter" && !replacing) {
      e.preventDefault();
      submit();
    }
  };
  return (
    <div className="modal-backdrop" onMouseDown={closeSaveAs}>
      <div className="modal save-as" role="dialog" aria-modal="true" aria-label={`save ${what} as`} data-testid="save-as-dialog"
           onMouseDown={(e) => e.stopPropagation()} onKeyDown={onKey}>
        <h3>{target ? `Save ${what} to the library` : "Save as"}</h3>
        {replacing ? (
          <p data-testid="save-as-overwrite">The robot's library already has a {what} '<b>{replacing}</b>'. Replace it with this one?</p>
        ) : (
          <>
            <label className="field">
              <span>Name</span>
              <input ref={input} aria-label="file name" data-testid="save-as-name" value={name} autoFocus spellCheck={false}
                     onChange={(e) => { setName(e.target.value); setTried(true); }} />
            </label>
            <p className={`save-as-hint ${tried && problem ? "bad" : "muted"}`} data-testid="save-as-problem" role="status">
              {tried && problem ? problem : library.includes(libraryName(name)) ? `a ${what} of this name exists: saving asks before replacing it`
                : "letters, digits, _ - and ."}
            </p>
          </>
        )}
        <div className="modal-buttons">
          {replacing ? (
            <>
              <button type="button" onClick={() => setReplacing(null)}>Back</button>
              <button type="button" ref={confirm} className="primary" data-testid="save-as-replace" onClick={() => finish(replacing)}>Replace</button>
            </>
          ) : (
            <>
              <button type="button" onClick={closeSaveAs}>Cancel</button>
              <button type="button" className="primary" data-testid="save-as-save" disabled={tried && !!problem} onClick={submit}>Save</button>
            </>
          )}
        </div>
      </div>
    </div>
  );
}
