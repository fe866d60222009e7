// The clip editor: the open clip's document, history and server conversations (./useClipDocument,
// ./useServerSync), and its views (ruler, dopesheet and graph editor sharing one time view and
// playhead, ../clip_editor/views) beside the pose panel. Shown in the graph's area while a clip is open.
import { useCallback, useEffect, useMemo, useRef, useState } from "react";
import { api } from "../api";
import { useEditor } from "../store/EditorStore";
import { clipApi, type PoseValues, type RecordResult } from "./clipApi";
import { PostureDialog, UnsavedDialog } from "./ClipDialogs";
import { ClipToolbar } from "./ClipToolbar";
import { dofInfos, groupRows } from "./model/dofs";
import { clipEnd, keyPose } from "./model/edits";
import { DEFAULT_FPS, type Clip, type DofInfo } from "./model/types";
import { PosePanel } from "./PosePanel";
import { poseAt, previewLabel, sampleTrack } from "./poseValues";
import { RecordControls } from "./RecordControls";
import { useClipDocument } from "./useClipDocument";
import { useClipKeys } from "./useClipKeys";
import { useLatest } from "./useLatest";
import { useTimelineSplit } from "./TimelineSplit";
import { usePlayback } from "./usePlayback";
import { usePrevizGrab } from "./usePoseInputs";
import { useHelperFigures, useOnRobot, usePoseStream, type GhostSource } from "./useServerSync";
import { Dopesheet } from "./views/Dopesheet";
import { GraphEditor } from "./views/GraphEditor";
import { Ruler } from "./views/Ruler";
import { frameAll, type TimeView } from "./views/timeView";
import "./clipEditor.css";

declare global {
  interface Window {
    /** The browser tests' view of the open clip: its working document and what the engine plays. */
    __nuttyClipEditor?: { doc(): Clip; sample(dof: string, times: number[]): number[] };
  }
}

/** The pose a key of a relative clip stores: continuous DoFs as offsets from rest. */
function storedPose(pose: PoseValues, doc: Clip, dofs: ReadonlyMap<string, DofInfo>): PoseValues {
  if (!doc.relative) return pose;
  return Object.fromEntries(Object.entries(pose).map(([d, v]) => {
    const info = dofs.get(d);
    return [d, info?.type === "continuous" && typeof v === "number" ? v - info.rest : v];
  }));
}

export function ClipEditor({ active }: { active: boolean }) {
  const { state, dispatch } = useEditor();
  const { clip: open, robot, clipRequest } = state;
  const infos = useMemo(() => (robot ? dofInfos(robot) : []), [robot]);
  const dofMap = useMemo(() => new Map(infos.map((d) => [d.name, d])), [infos]);
  const refreshClips = useCallback(() => {
    dispatch({ type: "clipSaved" });
    api.list("clips").then((names) => dispatch({ type: "clipsListed", names })).catch(() => undefined);
  }, [dispatch]);
  const cd = useClipDocument(open, robot?.name ?? null, refreshClips);
  const { doc, ready } = cd;
  const fps = doc.fps ?? DEFAULT_FPS;
  const end = clipEnd(doc);

  const [playhead, setPlayheadRaw] = useState(0);
  const setPlayhead = useCallback((t: number) => setPlayheadRaw(Math.max(0, t)), []);
  const [view, setView] = useState<TimeView>({ t0: -0.2, t1: 2.2 });
  const [selectedDofs, setSelectedDofs] = useState<string[]>([]);
  const [edited, setEdited] = useState<PoseValues>({});
  const [onRobot, setOnRobot] = useState(false);
  const [ghost, setGhost] = useState<GhostSource>("program");
  const [rate, setRate] = useState<number | null>(null);
  const [posture, setPosture] = useState<PoseValues | null>(null);
  const [notice, setNotice] = useState<string | null>(null);
  const playback = usePlayback(playhead, setPlayhead, end);
  const [share, SplitBar] = useTimelineSplit();
  const dopesheetBox = useRef<HTMLDivElement>(null);
  const graphBox = useRef<HTMLDivElement>(null);
  // the height the bar divides: from the dopesheet's top to the graph editor's bottom
  const splitArea = useCallback(() => {
    const top = dopesheetBox.current?.getBoundingClientRect();
    const bottom = graphBox.current?.getBoundingClientRect();
    return top && bottom ? new DOMRect(top.left, top.top, top.width, bottom.bottom - top.top) : null;
  }, []);

  // a clip (re)loaded: framed, from the start, nothing moved, not on the robot
  const docRef = useLatest(doc);
  useEffect(() => {
    if (!ready) return;
    setView(frameAll(docRef.current));
    setPlayheadRaw(0);
    setEdited({});
    setSelectedDofs([]);
    setOnRobot(false);
  }, [ready, open?.seq, docRef]);

  useEffect(() => {
    clipApi.status().then((s) => setRate(s.rate)).catch(() => setRate(null));
  }, []);

  const rows = useMemo(() => groupRows(infos, doc.tracks), [infos, doc.tracks]);
  const played = useMemo(() => poseAt(doc, dofMap, playhead), [doc, dofMap, playhead]);
  const graphDofs = useMemo(() => {
    const names = selectedDofs.length ? selectedDofs : [...new Set(cd.selection.map((k) => k.dof))];
    return names.map((n) => dofMap.get(n)).filter((d): d is DofInfo => !!d && d.type === "continuous");
  }, [selectedDofs, cd.selection, dofMap]);
  const offsets = useMemo(() => (doc.relative ? Object.fromEntries(infos.map((d) => [d.name, d.rest])) : {}), [doc.relative, infos]);

  // the Pre-Viz shows the pose at the playhead (with the moved DoFs) unless the robot plays the clip
  const name = cd.name;
  const previewPose = useCallback(() => {
    const values = { ...played, ...edited };
    return Object.keys(values).length ? { values, label: previewLabel(name, playhead) } : null;
  }, [played, edited, name, playhead]);
  usePoseStream(active && ready && !onRobot, previewPose, clipApi.preview);
  usePrevizGrab(active && ready, useCallback((grabbed: PoseValues) => setEdited((e) => ({ ...e, ...grabbed })), []));

  const figures = useHelperFigures(doc, rate, ghost, active && ready);
  const robotError = useOnRobot(onRobot, name, doc, playhead, playback.loop);
  // the robot plays from the playhead: the playhead runs with it, so the two stay together
  const { play } = playback;
  useEffect(() => { if (onRobot) play(); }, [onRobot, play]);

  const save = useCallback(() => void cd.save(), [cd]);
  useClipKeys(active, { undo: cd.undo, redo: cd.redo, save, togglePlay: playback.toggle });

  // the browser tests' hook
  useEffect(() => {
    window.__nuttyClipEditor = {
      doc: () => docRef.current,
      sample: (dof, times) => sampleTrack(docRef.current, dofMap.get(dof), dof, times),
    };
    return () => { delete window.__nuttyClipEditor; };
  }, [dofMap, docRef]);

  // leaving the page with unsaved changes asks first
  useEffect(() => {
    if (!cd.dirty) return;
    const warn = (e: BeforeUnloadEvent) => { e.preventDefault(); e.returnValue = ""; };
    window.addEventListener("beforeunload", warn);
    return () => window.removeEventListener("beforeunload", warn);
  }, [cd.dirty]);

  // another clip or closing: granted at once when nothing is lost, else asked (UnsavedDialog)
  const dirty = cd.dirty;
  useEffect(() => {
    if (clipRequest && !dirty) dispatch({ type: "clipRequestGranted" });
  }, [clipRequest, dirty, dispatch]);

  const doKeyPose = useCallback(() => {
    if (!Object.keys(edited).length) return;
    cd.onChange(keyPose(doc, storedPose(edited, doc, dofMap), playhead), { label: "key pose" });
    setEdited({});
  }, [cd, doc, edited, dofMap, playhead]);
  const postureValues = useCallback((): PoseValues => {
    const out: PoseValues = {};
    for (const d of infos) {
      const v = edited[d.name] ?? played[d.name] ?? (d.type === "continuous" ? d.rest : d.restValue);
      if (v !== undefined) out[d.name] = v;
    }
    return out;
  }, [infos, edited, played]);
  const onRecorded = useCallback((r: RecordResult) => {
    refreshClips();
    dispatch({ type: "clipRequested", name: r.saved });
  }, [dispatch, refreshClips]);
  const onEdit = useCallback((values: PoseValues) => setEdited((e) => ({ ...e, ...values })), []);
  const onClear = useCallback(() => setEdited({}), []);

  const recordDefaults = selectedDofs.length ? selectedDofs : Object.keys(edited);
  const error = cd.refusal?.message ?? robotError ?? figures.error ?? null;
  const errors = cd.refusal?.errors ?? {};

  return (
    <div className="clip-editor" data-testid="clip-editor" data-helper-rev={figures.rev} data-clip={name}>
      <ClipToolbar name={name} dirty={cd.dirty} canUndo={cd.canUndo} canRedo={cd.canRedo} undoLabel={cd.undoLabel}
                   redoLabel={cd.redoLabel} undo={cd.undo} redo={cd.redo} save={save} saving={cd.saving}
                   playing={playback.playing} togglePlay={playback.toggle} loop={playback.loop} setLoop={playback.setLoop}
                   stop={playback.stop} playhead={playhead} onRobot={onRobot} setOnRobot={setOnRobot} ghost={ghost} setGhost={setGhost}
                   canKeyPose={Object.keys(edited).length > 0} keyPose={doKeyPose} savePosture={() => setPosture(postureValues())}
                   close={() => dispatch({ type: "clipCloseRequested" })} error={error}
                   record={<RecordControls clipName={name} defaultDofs={recordDefaults} dofs={infos} onRecorded={onRecorded} />} />
      {notice && <div className="clip-notice" role="status" onClick={() => setNotice(null)}>{notice}</div>}
      <div className="clip-body">
        <div className="clip-timelines" style={{ gridTemplateRows: `auto minmax(60px, ${share}fr) 5px minmax(90px, ${1 - share}fr)` }}>
          <Ruler view={view} setView={setView} fps={fps} duration={end} playhead={playhead} setPlayhead={setPlayhead} />
          <div className="clip-dopesheet" ref={dopesheetBox}>
            <Dopesheet doc={doc} rows={rows} view={view} setView={setView} playhead={playhead} setPlayhead={setPlayhead}
                       selection={cd.selection} setSelection={cd.setSelection} onChange={cd.onChange} selectedDofs={selectedDofs}
                       setSelectedDofs={setSelectedDofs} fps={fps} errors={errors} />
          </div>
          <SplitBar area={splitArea} />
          <div className="clip-graph" ref={graphBox}>
            <GraphEditor doc={doc} dofs={graphDofs} view={view} setView={setView} playhead={playhead} setPlayhead={setPlayhead}
                         selection={cd.selection} setSelection={cd.setSelection} onChange={cd.onChange} offsets={offsets}
                         helper={figures.helper} ghost={figures.ghost} errors={errors} fps={fps} />
          </div>
        </div>
        <PosePanel rows={rows} played={played} edited={edited} onEdit={onEdit} onClear={onClear} />
      </div>
      {clipRequest && dirty && (
        <UnsavedDialog name={name} what={clipRequest.kind === "close" ? "Close it" : `Open “${clipRequest.name}”`}
                       onSave={() => void cd.save().then((ok) => ok && dispatch({ type: "clipRequestGranted" }))}
                       onDiscard={() => dispatch({ type: "clipRequestGranted" })}
                       onCancel={() => dispatch({ type: "clipRequestDropped" })} />
      )}
      {posture && <PostureDialog values={posture} onDone={(saved) => { setPosture(null); if (saved) setNotice(`saved posture “${saved}”`); }} />}
    </div>
  );
}
