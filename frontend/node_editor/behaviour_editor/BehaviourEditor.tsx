// The behaviour editor: the open behaviour's working copy and history (./useBehaviourDocument), its
// server plan (./usePlan), the timeline (./views/Timeline) with the clip editor's ruler and playhead, the
// selected item's inspector, the parameters, the error list, the browser preview and playing on the
// robot. Shown in the graph's area while a behaviour is open.
import { useCallback, useEffect, useMemo, useRef, useState } from "react";
import { UnsavedDialog } from "../clip_editor/ClipDialogs";
import { useLatest } from "../clip_editor/useLatest";
import type { TimeView } from "../clip_editor/views/timeView";
import { useEditor } from "../store/EditorStore";
import { behaviourApi } from "./behaviourApi";
import { NameDialog } from "./BehaviourDialogs";
import { BehaviourToolbar } from "./BehaviourToolbar";
import { ErrorList, errorsByItem } from "./ErrorList";
import { CommitInput } from "./fieldInputs";
import { ItemInspector } from "./ItemInspector";
import { addItem, addTrack, moveItemToTrack, removeItem } from "./model/edits";
import { findItem } from "./model/refs";
import { retime } from "./model/retime";
import type { BehaviourDoc, Issue, ItemKind, Plan, SnapTarget } from "./model/types";
import { ParamsPanel } from "./ParamsPanel";
import { trackForKind } from "./placement";
import { previewParams } from "./paramValues";
import { useBehaviourDocument } from "./useBehaviourDocument";
import { useBehaviourKeys } from "./useBehaviourKeys";
import { useBehaviourPreview } from "./useBehaviourPreview";
import { usePlan } from "./usePlan";
import { useRobotNames } from "./useRobotNames";
import { useRobotPlay } from "./useRobotPlay";
import { Timeline } from "./views/Timeline";
import "./behaviourEditor.css";

declare global {
  interface Window {
    /** The browser tests' view of the open behaviour: its working copy and the last plan. */
    __nuttyBehaviourEditor?: { doc(): BehaviourDoc; plan(): Plan };
  }
}

const sameIssue = (a: Issue, b: Issue) => a.item === b.item && a.field === b.field && a.message === b.message;

export function BehaviourEditor({ active }: { active: boolean }) {
  const { state, dispatch } = useEditor();
  const { behaviour: open, behaviourRequest, robot } = state;
  const onSaved = useCallback((name: string) => dispatch({ type: "behaviourSaved", name }), [dispatch]);
  const bd = useBehaviourDocument(open, robot?.name ?? null, onSaved);
  const { doc, ready } = bd;
  const { names, defaults } = useRobotNames();

  const [paramTexts, setParamTexts] = useState<Record<string, string>>({});
  const decls = useMemo(() => doc.params ?? {}, [doc.params]);
  const { params, errors: paramErrors } = useMemo(() => previewParams(decls, paramTexts), [decls, paramTexts]);
  const { plan, error: planError } = usePlan(doc, params, active && ready);

  const [selected, setSelected] = useState<string | null>(null);
  const [playhead, setPlayheadRaw] = useState(0);
  const setPlayhead = useCallback((t: number) => setPlayheadRaw(Math.max(0, t)), []);
  const [view, setView] = useState<TimeView>({ t0: -0.2, t1: 4 });
  const [naming, setNaming] = useState<null | "save" | "grant">(null);
  const [notice, setNotice] = useState<string | null>(null);
  const [taken, setTaken] = useState<string[]>([]);

  const robotPlay = useRobotPlay(bd.name, doc, params, setPlayhead, setNotice);
  const preview = useBehaviourPreview({ name: bd.name, doc, params, playhead, setPlayhead, enabled: active && ready && !robotPlay.playing });

  // a behaviour (re)loaded: from the start, nothing selected, framed once its first plan is in
  const [framedSeq, setFramedSeq] = useState<number | null>(null);
  const [resetSeq, setResetSeq] = useState<number | null>(null);
  if (ready && open && resetSeq !== open.seq) {
    setResetSeq(open.seq);
    setPlayheadRaw(0);
    setSelected(null);
    setParamTexts({});
    setNotice(null);
  }
  if (ready && open && framedSeq !== open.seq && plan.items.length) {
    setFramedSeq(open.seq);
    setView({ t0: -0.2, t1: Math.max(3, plan.duration * 1.15 + 0.3) });
  }

  const edit = useCallback((next: BehaviourDoc, label: string, merge?: boolean) => { bd.edit(next, label, merge); setNotice(null); }, [bd]);
  const docRef = useLatest({ doc, plan, selected, playhead, defaults });
  // a drag that retimes and changes lane calls onRetime then onMoveTrack before the next render: the
  // move applies to the retimed document, as part of the same undo step
  const dragged = useRef<{ id: string; doc: BehaviourDoc } | null>(null);
  const onRetime = useCallback((id: string, start: number, snap: SnapTarget | null) => {
    const { doc: d, plan: p } = docRef.current;
    const next = retime(d, p, id, start, snap);
    dragged.current = { id, doc: next };
    queueMicrotask(() => { dragged.current = null; });
    edit(next, "retime");
  }, [docRef, edit]);
  const onMoveTrack = useCallback((id: string, track: number) => {
    const after = dragged.current?.id === id ? dragged.current.doc : null;
    dragged.current = null;
    edit(moveItemToTrack(after ?? docRef.current.doc, id, track), after ? "retime" : "move to track", !!after && after !== docRef.current.doc);
  }, [docRef, edit]);
  const doAddTrack = useCallback(() => edit(addTrack(docRef.current.doc, "track"), "add track"), [docRef, edit]);
  const doAddItem = useCallback((kind: ItemKind) => {
    const { doc: d, selected: sel, playhead: t, defaults: defs } = docRef.current;
    let base = d;
    if (!(base.tracks ?? []).length) base = addTrack(base, "body");
    const track = trackForKind(base, kind, sel ? findItem(base, sel)?.track ?? null : null);
    const next = addItem(base, track, kind, t, defs);
    const tracks = next.tracks ?? [];
    const added = tracks[track]?.items?.at(-1)?.id ?? null;
    edit(next, `add ${kind}`);
    setSelected(added);
  }, [docRef, edit]);
  const deleteItem = useCallback(() => {
    const { doc: d, plan: p, selected: sel } = docRef.current;
    if (!sel) return;
    edit(removeItem(d, sel, p), "delete item");
    setSelected(null);
  }, [docRef, edit]);

  const save = useCallback(() => {
    if (bd.fresh) {
      behaviourApi.list().then((l) => setTaken(l.map((b) => b.name))).catch(() => undefined);
      setNaming("save");
      return;
    }
    setNotice(null);
    void bd.save().then((ok) => setNotice(ok ? "Saved" : null));
  }, [bd]);
  const saveAs = useCallback((name: string) => {
    const then = naming;
    setNaming(null);
    setNotice(null);
    void bd.save(name).then((ok) => {
      setNotice(ok ? `Saved as ${name}` : null);
      if (ok && then === "grant") dispatch({ type: "behaviourRequestGranted" });
    });
  }, [bd, naming, dispatch]);

  useBehaviourKeys(active, { undo: bd.undo, redo: bd.redo, save, togglePreview: preview.toggle, deleteItem });

  // the browser tests' hook
  useEffect(() => {
    window.__nuttyBehaviourEditor = { doc: () => docRef.current.doc, plan: () => docRef.current.plan };
    return () => { delete window.__nuttyBehaviourEditor; };
  }, [docRef]);

  // leaving the page with unsaved changes asks first
  useEffect(() => {
    if (!bd.dirty) return;
    const warn = (e: BeforeUnloadEvent) => { e.preventDefault(); e.returnValue = ""; };
    window.addEventListener("beforeunload", warn);
    return () => window.removeEventListener("beforeunload", warn);
  }, [bd.dirty]);

  // another behaviour or closing: granted at once when nothing is lost, else asked
  const dirty = bd.dirty;
  useEffect(() => {
    if (behaviourRequest && !dirty) dispatch({ type: "behaviourRequestGranted" });
  }, [behaviourRequest, dirty, dispatch]);

  // the plan's errors, and a refused save's while the document is the one refused
  const refused = bd.refusal && (bd.refusal.doc === doc || bd.refusal.doc === null) ? bd.refusal : null;
  const errors = useMemo(() => {
    const extra = (refused?.errors ?? []).filter((e) => !plan.errors.some((p) => sameIssue(p, e)));
    return [...plan.errors, ...extra];
  }, [plan.errors, refused]);
  const byItem = useMemo(() => errorsByItem(errors), [errors]);
  const select = useCallback((id: string | null) => setSelected(id), []);
  const scrub = useCallback((t: number) => { setPlayhead(t); preview.scrubbed(); }, [setPlayhead, preview]);

  const duration = preview.duration ?? plan.duration;
  const status = preview.preparing ? "Preparing the preview…"
    : preview.previewing ? `Previewing ${playhead.toFixed(1)} / ${duration.toFixed(1)} s${preview.muted ? " (sound off: the Pre-Viz's sound switch)" : ""}`
    : robotPlay.playing ? robotPlay.status ?? ""
    : refused ? `Not saved: ${refused.message}${refused.errors.length ? ` (${refused.errors.length} error${refused.errors.length > 1 ? "s" : ""})` : ""}`
    : preview.error ? `Preview: ${preview.error}`
    : planError ? `Plan: ${planError}`
    : notice ?? (errors.length ? `${errors.length} error${errors.length > 1 ? "s" : ""}` : `valid · ${plan.duration.toFixed(2)} s`);
  const statusError = !!refused || (!preview.previewing && !robotPlay.playing && (errors.length > 0 || !!preview.error || !!planError) && !notice);

  // items under way on the robot glow (the timeline's bars by their test id)
  const activeCss = [...robotPlay.active].map((id) => `[data-testid="behaviour-item-${CSS.escape(id)}"]`).join(",");

  return (
    <div className="bh-editor" data-testid="behaviour-editor" data-behaviour={bd.name}>
      <BehaviourToolbar name={bd.name} dirty={bd.dirty} canUndo={bd.canUndo} canRedo={bd.canRedo} undoLabel={bd.undoLabel}
                        redoLabel={bd.redoLabel} undo={bd.undo} redo={bd.redo} save={save} saving={bd.saving}
                        addTrack={doAddTrack} addItem={doAddItem} canDelete={!!selected} deleteItem={deleteItem}
                        previewing={preview.previewing || preview.preparing} togglePreview={preview.toggle}
                        onRobot={robotPlay.playing} toggleRobot={() => { preview.stop(); robotPlay.toggle(); }}
                        close={() => dispatch({ type: "behaviourCloseRequested" })} status={status} statusError={statusError} />
      {activeCss && <style>{`${activeCss} { filter: brightness(1.35) drop-shadow(0 0 4px var(--accent, #4af)); }`}</style>}
      <div className="bh-body">
        <div className="bh-main">
          <div className="bh-timeline-box">
            <Timeline doc={doc} plan={plan} view={view} setView={setView} playhead={playhead} setPlayhead={scrub}
                      selected={selected} select={select} onRetime={onRetime} onMoveTrack={onMoveTrack} errorsByItem={byItem} fps={30} />
          </div>
          <ErrorList errors={errors} select={setSelected} />
        </div>
        <aside className="bh-side">
          {selected
            ? <ItemInspector doc={doc} plan={plan} id={selected} edit={edit} names={names} errors={byItem.get(selected) ?? []} onRenamed={setSelected} />
            : <div className="bh-inspector muted">Select an item on the timeline, or add one (+ Item).</div>}
          <div className="bh-description">
            <label>Description (for AIs)
              <CommitInput testId="behaviour-description" long value={doc.description ?? ""}
                           onCommit={(t) => edit({ ...doc, description: t }, "description")} />
            </label>
          </div>
          <ParamsPanel doc={doc} edit={edit} values={paramTexts} errors={paramErrors}
                       setValue={(n, t) => setParamTexts((v) => ({ ...v, [n]: t }))} />
        </aside>
      </div>
      {behaviourRequest && dirty && !naming && (
        <UnsavedDialog name={bd.name} what={behaviourRequest.kind === "close" ? "Close it" : `Open “${behaviourRequest.name}”`}
                       onSave={() => {
                         if (bd.fresh) { setNaming("grant"); return; }
                         void bd.save().then((ok) => ok && dispatch({ type: "behaviourRequestGranted" }));
                       }}
                       onDiscard={() => dispatch({ type: "behaviourRequestGranted" })}
                       onCancel={() => dispatch({ type: "behaviourRequestDropped" })} />
      )}
      {naming && <NameDialog taken={taken} onSave={saveAs} onCancel={() => setNaming(null)} />}
    </div>
  );
}
