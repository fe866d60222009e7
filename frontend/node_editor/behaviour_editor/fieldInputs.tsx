// The inspector's small inputs: a text field that commits on Enter or leaving it (so one typed value is
// one undo step, not one per keystroke), and a select of names that keeps a value not in the list (a
// "{param}" or something the robot lacks) as its own option.
import { useState, type KeyboardEvent } from "react";

export function CommitInput({ value, onCommit, testId, placeholder, long, ariaLabel }: {
  value: string; onCommit: (text: string) => void; testId: string; placeholder?: string; long?: boolean; ariaLabel?: string;
}) {
  const [text, setText] = useState(value);
  const [shown, setShown] = useState(value);
  // a new value from outside (undo, another item) replaces what was typed
  if (shown !== value) { setShown(value); setText(value); }
  const commit = () => { if (text !== value) onCommit(text); };
  const onKey = (e: KeyboardEvent<HTMLInputElement | HTMLTextAreaElement>) => {
    if (e.key === "Enter" && !(long && e.shiftKey)) { e.preventDefault(); commit(); }
    if (e.key === "Escape") setText(value);
  };
  const props = {
    "data-testid": testId, value: text, placeholder, "aria-label": ariaLabel,
    onChange: (e: { target: { value: string } }) => setText(e.target.value), onBlur: commit, onKeyDown: onKey,
  };
  return long ? <textarea rows={2} {...props} /> : <input {...props} />;
}

export function NameSelect({ value, options, onChange, testId, optional }: {
  value: string; options: readonly string[]; onChange: (v: string) => void; testId: string; optional?: boolean;
}) {
  const all = value && !options.includes(value) ? [value, ...options] : options;
  return (
    <select data-testid={testId} value={value} onChange={(e) => onChange(e.target.value)}>
      {(optional || !value) && <option value="">{optional ? "(none)" : "choose…"}</option>}
      {all.map((o) => <option key={o} value={o}>{o}</option>)}
    </select>
  );
}
