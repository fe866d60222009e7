// The behaviour's errors (the plan's, or a refused save's): one row per error with its item and
// message; clicking a row selects that item on the timeline and in the inspector.
import type { Issue } from "./model/types";

/** Errors grouped by item id (for the timeline's bars); "#i" ids and item-less errors are left out. */
export function errorsByItem(errors: readonly Issue[]): Map<string, Issue[]> {
  const out = new Map<string, Issue[]>();
  for (const e of errors) {
    if (!e.item || e.item.startsWith("#")) continue;
    out.set(e.item, [...(out.get(e.item) ?? []), e]);
  }
  return out;
}

export function ErrorList({ errors, select }: { errors: readonly Issue[]; select: (id: string) => void }) {
  if (!errors.length) return null;
  return (
    <ul className="bh-errors" data-testid="behaviour-errors">
      {errors.map((e, i) => (
        <li key={i} data-testid="behaviour-error" className={e.item ? "clickable" : ""}
            onClick={() => { if (e.item && !e.item.startsWith("#")) select(e.item); }}>
          <span className="bh-error-item">{e.item ?? (e.track !== undefined ? `track ${e.track + 1}` : "behaviour")}</span>
          {e.field && <span className="bh-error-field">{e.field}</span>}
          <span>{e.message}</span>
        </li>
      ))}
    </ul>
  );
}
