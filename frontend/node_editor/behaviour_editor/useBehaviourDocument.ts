// The open behaviour as React state: loads it (or starts a new one), keeps its undo history
// (./behaviourDocState), knows whether it is dirty, and saves it (PUT /api/behaviours/{name}), keeping
// a refusal's issues for the bars and the error list.
import { useCallback, useEffect, useMemo, useReducer, useState } from "react";
import { useLatest } from "../clip_editor/useLatest";
import type { OpenClip } from "../store/clipState";
import { behaviourApi, issuesOf } from "./behaviourApi";
import { behaviourDocReducer, documentToSave, initBehaviourDoc, isDirty, newBehaviour } from "./behaviourDocState";
import type { BehaviourDoc, Issue } from "./model/types";

/** A refused load or save: its issues, and the document they are about (stale once edited). */
export interface Refusal { message: string; errors: Issue[]; doc: BehaviourDoc | null }

export interface BehaviourDocument {
  name: string;
  doc: BehaviourDoc;
  ready: boolean;
  dirty: boolean;
  /** not in the library yet: the first save asks for a name */
  fresh: boolean;
  canUndo: boolean;
  canRedo: boolean;
  undoLabel: string;
  redoLabel: string;
  /** `merge`: part of the previous edit (no new undo step) */
  edit: (doc: BehaviourDoc, label: string, merge?: boolean) => void;
  undo: () => void;
  redo: () => void;
  /** Save as `name` (default: its own); false when refused (see `refusal`). */
  save: (name?: string) => Promise<boolean>;
  saving: boolean;
  /** the last refusal of a load or save (cleared by a good save) */
  refusal: Refusal | null;
  warnings: Issue[];
}

const EMPTY: BehaviourDoc = { tracks: [] };

export function useBehaviourDocument(open: OpenClip | null, robot: string | null, onSaved: (name: string) => void): BehaviourDocument {
  const [state, dispatch] = useReducer(behaviourDocReducer, undefined, () => initBehaviourDoc("", EMPTY, true));
  const [saving, setSaving] = useState(false);
  const [refusal, setRefusal] = useState<Refusal | null>(null);
  const [warnings, setWarnings] = useState<Issue[]>([]);
  const [loadedSeq, setLoadedSeq] = useState<number | null>(null);
  const ready = !!open && loadedSeq === open.seq;

  // a new open (its seq) reads the behaviour again; a save's new name (same seq) does not
  const seq = open?.seq ?? null;
  const latestOpen = useLatest({ open, robot });
  useEffect(() => {
    const o = latestOpen.current.open;
    if (!o || seq === null) return;
    let stale = false;
    const load = o.fresh ? Promise.resolve(newBehaviour(latestOpen.current.robot)) : behaviourApi.get(o.name);
    load.then((doc) => {
      if (stale) return;
      dispatch({ type: "loaded", name: o.name, doc, fresh: o.fresh });
      setRefusal(null);
      setWarnings([]);
      setLoadedSeq(seq);
    }).catch((e: unknown) => {
      if (stale) return;
      dispatch({ type: "loaded", name: o.name, doc: EMPTY });
      setRefusal({ ...issuesOf(e), doc: null });
    });
    return () => { stale = true; };
  }, [seq, latestOpen]);

  const edit = useCallback((doc: BehaviourDoc, label: string, merge?: boolean) => dispatch({ type: "edited", doc, label, merge }), []);
  const undo = useCallback(() => dispatch({ type: "undo" }), []);
  const redo = useCallback(() => dispatch({ type: "redo" }), []);

  const now = useLatest({ doc: state.history.present.doc, name: state.name, robot, onSaved });
  const save = useCallback(async (asName?: string) => {
    const { doc, name: own, robot: r, onSaved: saved } = now.current;
    const name = asName ?? own;
    const body = documentToSave(doc, name, r);
    setSaving(true);
    try {
      const res = await behaviourApi.save(name, body);
      dispatch({ type: "saved", name, sent: doc, doc: body });
      setRefusal(null);
      setWarnings(res.warnings ?? []);
      saved(name);
      return true;
    } catch (e) {
      setRefusal({ ...issuesOf(e), doc });
      return false;
    } finally {
      setSaving(false);
    }
  }, [now]);

  const dirty = useMemo(() => isDirty(state), [state]);
  const h = state.history;
  return {
    name: state.name, doc: h.present.doc, ready, dirty, fresh: !state.onServer,
    canUndo: h.past.length > 0, canRedo: h.future.length > 0, undoLabel: h.present.label, redoLabel: h.future[0]?.label ?? "",
    edit, undo, redo, save, saving, refusal, warnings,
  };
}
