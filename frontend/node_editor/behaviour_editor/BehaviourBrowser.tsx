// The behaviour library (GET /api/behaviours) in the graph's area: one row per behaviour with its
// description, duration and a red count of its errors; search; open one, or start a new one (named when
// first saved). Opening goes through the store's request, so a dirty open behaviour asks first.
import { useEffect, useMemo, useState } from "react";
import { useEditor } from "../store/EditorStore";
import { behaviourApi, issuesOf, type BehaviourSummary } from "./behaviourApi";
import "./behaviourEditor.css";

/** The name a new behaviour has until its first save asks for one. */
export const UNTITLED = "untitled";

export function BehaviourBrowser() {
  const { state, dispatch } = useEditor();
  const [list, setList] = useState<BehaviourSummary[] | null>(null);
  const [query, setQuery] = useState("");
  const [hint, setHint] = useState<string | null>(null);

  useEffect(() => {
    behaviourApi.list().then(setList).catch((e: unknown) => setHint(issuesOf(e).message));
  }, [state.behaviour?.name]);

  const shown = useMemo(() => {
    const q = query.trim().toLowerCase();
    const all = list ?? [];
    return q ? all.filter((b) => b.name.toLowerCase().includes(q) || b.description.toLowerCase().includes(q)) : all;
  }, [list, query]);

  return (
    <div className="bh-browser" data-testid="behaviour-browser">
      <div className="bh-browser-head">
        <input type="search" data-testid="behaviour-search" placeholder="Search behaviours" value={query} onChange={(e) => setQuery(e.target.value)} />
        <button type="button" data-testid="behaviour-new" onClick={() => dispatch({ type: "behaviourRequested", name: UNTITLED, fresh: true })}>
          New behaviour
        </button>
      </div>
      {hint && <div className="bh-error-text" role="status">{hint}</div>}
      <ul className="bh-list">
        {shown.map((b) => (
          <li key={b.name}>
            <button type="button" data-testid={`behaviour-row-${b.name}`} className={state.behaviour?.name === b.name ? "current" : ""}
                    onClick={() => dispatch({ type: "behaviourRequested", name: b.name })}>
              <span className="bh-row-name">{b.name}</span>
              <span className="bh-row-desc">{b.description}</span>
              <span className="bh-row-params">{Object.keys(b.params).join(", ")}</span>
              <span className="bh-row-duration">{b.duration === null ? "—" : `${b.duration.toFixed(1)} s`}</span>
              {b.errors.length > 0
                ? <span className="bh-row-errors" data-testid={`behaviour-row-errors-${b.name}`} title={b.errors.map((e) => e.message).join("\n")}>{b.errors.length}</span>
                : <span />}
            </button>
          </li>
        ))}
        {list && !shown.length && <li className="muted">{list.length ? "no behaviour matches" : "the library has no behaviours yet"}</li>}
      </ul>
    </div>
  );
}
