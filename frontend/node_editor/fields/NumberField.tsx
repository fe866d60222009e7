// One number, three ways to set it: a slider over the soft range, a text box that takes free typing
// (nothing leaves it before Enter or blur, so "-0.2" never passes through "-" or "0" on the robot),
// and a label that scrubs the value when dragged sideways. Arrow keys step; Escape goes back to the
// value the field had when it was entered. The rules themselves are in ./numberField.
import { useEffect, useId, useRef, useState, type KeyboardEvent, type MouseEvent, type PointerEvent, type ReactNode } from "react";
import {
  commitText, formatNumber, SCRUB_THRESHOLD_PX, scrubValue, sliderPosition, stepValue, type NumberSpec,
} from "./numberField";
import "./numberField.css";

/** `live`: a step of a drag still going on; `commit`: a finished change (the end of a drag included). */
export type NumberPhase = "live" | "commit";

interface Props {
  /** The slider's test id; the text box's is `${testId}-text`, the label's `${testId}-label`. */
  testId: string;
  label: string;
  /** The accessible name of the slider (the text box's is "<label> value"). */
  ariaLabel?: string;
  /** null: unset (a nullable parameter left to its default). */
  value: number | null;
  spec: NumberSpec;
  onChange: (value: number, phase: NumberPhase) => void;
  /** Show a slider over the soft range (when the spec has one). */
  slider?: boolean;
  disabled?: boolean;
  /** Beside the label (e.g. what drives the parameter). */
  aside?: ReactNode;
  /** At the end of the row (e.g. a "use the default" button). */
  children?: ReactNode;
  labelClass?: string;
}

/** How long a refusal or a clamp stays written under the field (ms). */
const HINT_MS = 4000;

export function NumberField({ testId, label, ariaLabel, value, spec, onChange, slider = true, disabled, aside, children, labelClass = "field-name" }: Props) {
  const id = useId();
  const text = useRef<HTMLInputElement>(null);
  const [draft, setDraft] = useState<string | null>(null);
  const [hint, setHint] = useState<{ text: string; bad: boolean } | null>(null);
  const [held, setHeld] = useState<number | null>(null);  // the slider's own value while the pointer holds it
  const before = useRef<number | null>(null);  // the value when the text box was entered (Escape's target)
  const hasSlider = slider && spec.softMin !== undefined && spec.softMax !== undefined;
  const current = held ?? value;

  useEffect(() => {
    if (!hint) return;
    const t = window.setTimeout(() => setHint(null), HINT_MS);
    return () => window.clearTimeout(t);
  }, [hint]);

  const commitDraft = () => {
    if (draft === null) return;
    setDraft(null);
    const c = commitText(draft, spec);
    if (!c.ok) { setHint({ text: `${c.reason}: kept ${value === null ? "the default" : formatNumber(value)}`, bad: true }); return; }
    setHint(c.note ? { text: c.note, bad: false } : null);
    if (c.value !== value) onChange(c.value, "commit");
  };

  const onKey = (e: KeyboardEvent<HTMLInputElement>) => {
    if (e.key === "Enter") { commitDraft(); e.currentTarget.select(); return; }
    if (e.key === "Escape") {
      e.stopPropagation();
      setDraft(null);
      setHint(null);
      if (before.current !== null && before.current !== value) onChange(before.current, "commit");
      return;
    }
    if (e.key !== "ArrowUp" && e.key !== "ArrowDown") return;
    e.preventDefault();
    const typed = draft === null ? null : commitText(draft, spec);
    const from = typed?.ok ? typed.value : value ?? spec.softMin ?? 0;
    const next = stepValue(from, spec, e.key === "ArrowUp" ? 1 : -1, e);
    setDraft(null);
    if (next !== value) onChange(next, "commit");
  };

  const scrub = useScrub(current ?? spec.softMin ?? 0, spec, disabled, onChange, () => { text.current?.focus(); text.current?.select(); });
  const sliderDrag = useSliderDrag(setHeld, onChange);

  return (
    <>
      <label htmlFor={id} className={`${labelClass} nf-label ${disabled ? "" : "scrub"}`} data-testid={`${testId}-label`}
             title="drag sideways to change (Shift: fine, Ctrl: coarse); click to type" {...scrub}>{label}</label>
      {aside}
      <div className={`row nf-row ${value === null ? "unset" : ""}`}>
        {hasSlider && (
          <input type="range" aria-label={ariaLabel ?? label} data-testid={testId} disabled={disabled}
                 min={spec.softMin} max={spec.softMax} step={spec.integer ? 1 : spec.step}
                 value={sliderPosition(current ?? (spec.softMin! + spec.softMax!) / 2, spec)}
                 onPointerDown={() => sliderDrag.start(current ?? value)}
                 onChange={(e) => sliderDrag.change(Number(e.target.value), held !== null)} />
        )}
        <input ref={text} id={id} type="text" inputMode="decimal" className={`nf-text ${hint?.bad ? "bad" : ""}`}
               aria-label={`${label} value`} data-testid={`${testId}-text`} disabled={disabled} spellCheck={false}
               autoComplete="off" value={draft ?? (current === null ? "" : formatNumber(current))}
               placeholder={current === null ? "default" : undefined}
               onFocus={(e) => { before.current = value; e.currentTarget.select(); }}
               onChange={(e) => setDraft(e.target.value)} onBlur={commitDraft} onKeyDown={onKey} />
        {children}
      </div>
      {hint && <span className={`nf-hint ${hint.bad ? "bad" : ""}`} role="status" data-testid={`${testId}-hint`}>{hint.text}</span>}
    </>
  );
}

/** The slider's drag: its values go out as `live` while the pointer holds it and the last one as a
 * `commit` when it lets go; a change without the pointer (keys, a test's fill) is a commit at once. */
function useSliderDrag(setHeld: (v: number | null) => void, onChange: (v: number, phase: NumberPhase) => void) {
  const last = useRef<number | null>(null);
  const holding = useRef(false);
  const send = useRef(onChange);  // the drag's end sends through the newest handler (the newest params)
  send.current = onChange;
  return {
    start(from: number | null) {
      holding.current = true;
      last.current = null;
      setHeld(from);
      // the pointer may be let go anywhere on the page
      const end = () => {
        window.removeEventListener("pointerup", end);
        window.removeEventListener("pointercancel", end);
        holding.current = false;
        setHeld(null);
        if (last.current !== null) send.current(last.current, "commit");
      };
      window.addEventListener("pointerup", end);
      window.addEventListener("pointercancel", end);
    },
    change(v: number, heldNow: boolean) {
      if (holding.current || heldNow) {
        last.current = v;
        setHeld(v);
        onChange(v, "live");
      } else onChange(v, "commit");
    },
  };
}

/** Pointer handlers that make the label a scrubber (pointer captured, so the drag may leave it); a press
 * that does not move is a click, which `onClick` turns into typing. */
function useScrub(value: number, spec: NumberSpec, disabled: boolean | undefined,
  onChange: (v: number, phase: NumberPhase) => void, onClick: () => void) {
  const drag = useRef<{ x: number; start: number; last: number; moved: boolean } | null>(null);
  return {
    onPointerDown(e: PointerEvent<HTMLLabelElement>) {
      if (disabled || e.button !== 0) return;
      e.preventDefault();  // no text selection while scrubbing
      e.currentTarget.setPointerCapture(e.pointerId);
      drag.current = { x: e.clientX, start: value, last: value, moved: false };
    },
    onPointerMove(e: PointerEvent<HTMLLabelElement>) {
      const d = drag.current;
      if (!d) return;
      const dx = e.clientX - d.x;
      if (!d.moved && Math.abs(dx) < SCRUB_THRESHOLD_PX) return;
      d.moved = true;
      const v = scrubValue(d.start, dx, spec, e);
      if (v !== d.last) { d.last = v; onChange(v, "live"); }
    },
    onPointerUp() {
      const d = drag.current;
      drag.current = null;
      if (!d) return;
      if (!d.moved) onClick();
      else if (d.last !== d.start) onChange(d.last, "commit");
    },
    onPointerCancel() {
      const d = drag.current;
      drag.current = null;
      if (d?.moved && d.last !== d.start) onChange(d.last, "commit");
    },
    // the label's own click would focus the text box on a drag's end too: the pointer handlers decide
    onClick(e: MouseEvent) { e.preventDefault(); },
  };
}
