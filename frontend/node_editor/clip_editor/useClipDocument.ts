// The open clip as React state: loads it (or starts a new one), keeps its undo history and selection
// (./clipDocState), knows whether it is dirty, and saves it (PUT /api/clips/{name}), turning a refusal
// into the views' ClipErrors.
import { useCallback, useEffect, useMemo, useReducer, useState } from "react";
import type { OpenClip } from "../store/clipState";
import { clipApi } from "./clipApi";
import { clipDocReducer, documentToSave, initClipDoc, isDirty } from "./clipDocState";
import { refusalOf, type ClipRefusal } from "./clipErrors";
import { newClip } from "./model/edits";
import { useLatest } from "./useLatest";
import { DEFAULT_FPS, type Clip, type Edited, type KeyRef } from "./model/types";

export interface ClipDocument {
  name: string;
  doc: Clip;
  selection: KeyRef[];
  /** The clip is loaded (false while the server's copy is on its way, or when it could not be read). */
  ready: boolean;
  dirty: boolean;
  canUndo: boolean;
  canRedo: boolean;
  undoLabel: string;
  redoLabel: string;
  onChange: (next: Edited, commit: { label: string } | null) => void;
  setSelection: (sel: KeyRef[]) => void;
  undo: () => void;
  redo: () => void;
  /** Save to the library; false when refused (the refusal is in `refusal`). */
  save: () => Promise<boolean>;
  saving: boolean;
  /** The last refusal of a load or save (cleared by the next successful save). */
  refusal: ClipRefusal | null;
  /** Replace the document by one the server made (a recording) without asking. */
  reload: () => void;
}

const EMPTY: Clip = { tracks: {} };

export function useClipDocument(open: OpenClip | null, robot: string | null, onSaved?: () => void): ClipDocument {
  const [state, dispatch] = useReducer(clipDocReducer, undefined, () => initClipDoc("", EMPTY, true));
  const [saving, setSaving] = useState(false);
  const [refusal, setRefusal] = useState<ClipRefusal | null>(null);
  const [reloads, setReloads] = useState(0);
  // which open (and reload) of a clip the document holds: ready when it is the current one
  const key = open ? `${open.seq}/${reloads}` : null;
  const [loadedKey, setLoadedKey] = useState<string | null>(null);
  const ready = key !== null && loadedKey === key;
  const present = state.history.present;

  useEffect(() => {
    if (!open || key === null) return;
    let stale = false;
    const load = open.fresh ? Promise.resolve(newClip(open.name, robot, DEFAULT_FPS)) : clipApi.get(open.name);
    load.then((doc) => {
      if (stale) return;
      dispatch({ type: "loaded", name: open.name, doc, fresh: open.fresh });
      setRefusal(null);
      setLoadedKey(key);
    }).catch((e: unknown) => {
      if (stale) return;
      dispatch({ type: "loaded", name: open.name, doc: EMPTY });
      setRefusal(refusalOf(e));
    });
    return () => { stale = true; };
    // a new open (its key) reads the clip again; the robot's name only names a new clip
  }, [key]);  // eslint-disable-line react-hooks/exhaustive-deps -- see above

  const onChange = useCallback((next: Edited, commit: { label: string } | null) => dispatch({ type: "changed", next, commit }), []);
  const setSelection = useCallback((selection: KeyRef[]) => dispatch({ type: "selected", selection }), []);
  const undo = useCallback(() => dispatch({ type: "undo" }), []);
  const redo = useCallback(() => dispatch({ type: "redo" }), []);
  const reload = useCallback(() => setReloads((n) => n + 1), []);

  const docRef = useLatest(present.doc);
  const save = useCallback(async () => {
    const doc = docRef.current;
    if (!Object.keys(doc.tracks).length) {
      setRefusal({ message: "a clip needs at least one track: key a pose first", errors: { "": "no tracks" } });
      return false;
    }
    const body = documentToSave(doc, state.name, robot, DEFAULT_FPS);
    setSaving(true);
    try {
      await clipApi.save(state.name, body);
      // what was sent is what the server has: the working copy is clean unless edited since
      dispatch({ type: "saved", sent: doc, doc: body });
      setRefusal(null);
      onSaved?.();
      return true;
    } catch (e) {
      setRefusal(refusalOf(e, Object.keys(doc.tracks)));
      return false;
    } finally {
      setSaving(false);
    }
  }, [state.name, robot, onSaved, docRef]);

  const dirty = useMemo(() => isDirty(state), [state]);
  const h = state.history;
  return {
    name: state.name, doc: present.doc, selection: present.selection, ready, dirty,
    canUndo: h.past.length > 0, canRedo: h.future.length > 0,
    undoLabel: present.label, redoLabel: h.future[0]?.label ?? "",
    onChange, setSelection, undo, redo, save, saving, refusal, reload,
  };
}
