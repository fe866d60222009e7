// The clip library (GET /api/clips) in the graph's area: search, open a clip, or start a new one by
// name. Opening goes through the store's request, so a dirty open clip asks first.
import { useEffect, useMemo, useState } from "react";
import { api } from "../api";
import { useEditor } from "../store/EditorStore";
import "./clipEditor.css";

/** Whether `name` can name a clip in the library (the server checks too: this only spares a round trip). */
export const validClipName = (name: string): boolean => /^[A-Za-z0-9_][A-Za-z0-9_.-]{0,79}$/.test(name);

export function ClipBrowser() {
  const { state, dispatch } = useEditor();
  const [query, setQuery] = useState("");
  const [naming, setNaming] = useState(false);
  const [name, setName] = useState("");
  const [hint, setHint] = useState<string | null>(null);
  const clips = state.clips;

  useEffect(() => {
    api.list("clips").then((names) => dispatch({ type: "clipsListed", names })).catch((e: unknown) => setHint(String(e)));
  }, [dispatch]);

  const shown = useMemo(() => {
    const q = query.trim().toLowerCase();
    return q ? clips.filter((c) => c.toLowerCase().includes(q)) : clips;
  }, [clips, query]);

  const create = () => {
    const n = name.trim();
    if (!validClipName(n)) { setHint("a clip's name: letters, digits, _ . - (no spaces)"); return; }
    if (clips.includes(n)) { setHint(`“${n}” exists: open it from the list, or choose another name`); return; }
    setHint(null);
    setNaming(false);
    setName("");
    dispatch({ type: "clipRequested", name: n, fresh: true });
  };

  return (
    <div className="clip-browser" data-testid="clip-browser">
      <div className="clip-browser-head">
        <input type="search" data-testid="clip-search" placeholder="Search clips" value={query} onChange={(e) => setQuery(e.target.value)} />
        <button type="button" data-testid="clip-new" onClick={() => { setNaming(true); setHint(null); }}>New clip</button>
      </div>
      {naming && (
        <div className="clip-browser-new">
          <input data-testid="clip-name" placeholder="name of the new clip" value={name} autoFocus
                 onChange={(e) => setName(e.target.value)}
                 onKeyDown={(e) => { if (e.key === "Enter") create(); if (e.key === "Escape") setNaming(false); }} />
          <button type="button" data-testid="clip-create" onClick={create}>Create</button>
          <button type="button" onClick={() => setNaming(false)}>Cancel</button>
        </div>
      )}
      {hint && <div className="clip-error-text" role="status">{hint}</div>}
      <ul className="clip-list">
        {shown.map((c) => (
          <li key={c}>
            <button type="button" data-testid={`clip-open-${c}`} className={state.clip?.name === c ? "current" : ""}
                    onClick={() => dispatch({ type: "clipRequested", name: c })}>{c}</button>
          </li>
        ))}
        {!shown.length && <li className="muted">{clips.length ? "no clip matches" : "the library has no clips yet"}</li>}
      </ul>
    </div>
  );
}
