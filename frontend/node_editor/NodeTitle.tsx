// A block's title: its name (the node id) first, its type smaller after it; F2 (GraphView) turns the name
// into a text field in place: Enter renames (the store refuses a bad or taken id), Escape keeps it.
import { createContext, useContext, useState } from "react";

export interface Renaming {
  /** The node whose name is being edited, or null. */
  id: string | null;
  commit: (id: string, to: string) => void;
  cancel: () => void;
}

export const RenameContext = createContext<Renaming>({ id: null, commit: () => {}, cancel: () => {} });

function NameField({ id }: { id: string }) {
  const { commit, cancel } = useContext(RenameContext);
  const [text, setText] = useState(id);
  return (
    <input className="nodrag rename-field" aria-label={`rename ${id}`} data-testid={`rename-${id}`} value={text} autoFocus
           size={Math.max(6, text.length + 1)} onFocus={(e) => e.target.select()} onChange={(e) => setText(e.target.value)}
           onBlur={cancel} onMouseDown={(e) => e.stopPropagation()}
           onKeyDown={(e) => {
             e.stopPropagation();  // Delete, Backspace and the canvas's keys edit the name, not the graph
             if (e.key === "Enter") commit(id, text.trim());
             else if (e.key === "Escape") cancel();
           }} />
  );
}

/** The name (and, smaller, the type) of node `id`; `kind` is its type's title. */
export function NodeTitle({ id, kind, prefix = "" }: { id: string; kind: string; prefix?: string }) {
  const { id: renaming } = useContext(RenameContext);
  if (renaming === id) return <span className="block-title-box"><NameField id={id} /></span>;
  return (
    <span className="block-title-box" title={`${id} · ${kind} (F2 renames)`}>
      <span className="block-title" data-testid={`title-${id}`}>{prefix}{id}</span>
      <span className="block-type">{kind}</span>
    </span>
  );
}
