// Pressing a key in the dopesheet or the graph editor: it joins the selection (Shift adds), a drag moves
// every selected key as transient edits committed as one undo step on release, and a click without a
// drag narrows the selection to that key (Shift+click takes it out).
import type { PointerEvent as ReactPointerEvent } from "react";
import type { Clip, Edited, KeyRef } from "../model/types";
import { keyId } from "../model/types";
import { trackPointer } from "./interaction";
import type { OnChange } from "./keyOps";

export interface KeyDrag {
  doc: Clip;
  selection: KeyRef[];
  /** ids (keyId) of the selected keys */
  selected: Set<string>;
  setSelection: (sel: KeyRef[]) => void;
  onChange: OnChange;
  /** The document after the pointer moved from the press to `m`, the keys `sel` moving from `start`. */
  move: (start: Clip, sel: KeyRef[], down: ReactPointerEvent, m: PointerEvent) => Edited;
}

/** Handles a primary-button press on key `ref` (others are left to the caller's background). */
export function pressKey(e: ReactPointerEvent, ref: KeyRef, d: KeyDrag): void {
  if (e.button !== 0) return;
  e.stopPropagation();
  e.preventDefault();
  const id = keyId(ref);
  const was = d.selected.has(id);
  const additive = e.shiftKey;
  let sel = d.selection;
  if (!was) {
    sel = additive ? [...d.selection, ref] : [ref];
    d.setSelection(sel);
  }
  const start = d.doc;
  let last: Edited | null = null;
  trackPointer(
    e,
    (m) => {
      last = d.move(start, sel, e, m);
      d.onChange(last, null);
    },
    (_u, moved) => {
      if (moved) {
        if (last) d.onChange(last, { label: "Move keys" });
      } else if (was && additive) d.setSelection(d.selection.filter((r) => keyId(r) !== id));
      else if (was && d.selection.length > 1) d.setSelection([ref]);
    },
  );
}
