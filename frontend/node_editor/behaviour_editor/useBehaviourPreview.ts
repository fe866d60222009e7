// The browser's preview of the working copy: POST /api/behaviours/render, then the playhead runs in
// real time from where it stands, the frame under it goes to the Pre-Viz (~15 Hz, under the preview
// lease), and each sound / recorded speech / spoken text plays at its event's time (sounds preloaded,
// then scheduled a little ahead on the audio clock, so they start on time whatever the frame rate).
// Stopped, a render of the working copy is kept so scrubbing shows that frame's pose too.
import { useCallback, useEffect, useRef, useState } from "react";
import { isMuted, loadSound, playBuffer, speak, stopAll, unlock } from "../audio/soundPlayer";
import { clipApi } from "../clip_editor/clipApi";
import { useLatest } from "../clip_editor/useLatest";
import { usePoseStream } from "../clip_editor/useServerSync";
import { behaviourApi, issuesOf, type Rendered, type RenderEvent } from "./behaviourApi";
import type { BehaviourDoc } from "./model/types";
import { audioUrl, audioUrls, eventsBetween, frameAt, soundingAt, spokenText } from "./previewSchedule";

/** Poses go to the Pre-Viz at this rate (Hz): the playhead's time is quantised to it. */
export const PREVIEW_POSE_HZ = 15;
/** Audio is scheduled this far (s) ahead of the playhead on the audio clock, so an animation frame
 * that comes late does not make a sound late. */
const LOOKAHEAD = 0.15;
/** The kept render follows edits this long (ms) after they pause. */
const RENDER_DEBOUNCE_MS = 300;

export interface Preview {
  previewing: boolean;
  /** rendering and preloading audio before the playhead starts */
  preparing: boolean;
  /** the editor's audio is switched off (the Pre-Viz's sound switch): the preview is silent */
  muted: boolean;
  duration: number | null;
  error: string | null;
  toggle: () => void;
  stop: () => void;
  /** the user moved the playhead while stopped: show that frame on the Pre-Viz */
  scrubbed: () => void;
}

export function useBehaviourPreview(opts: {
  name: string; doc: BehaviourDoc; params: Record<string, unknown>; playhead: number; setPlayhead: (t: number) => void;
  /** the editor shows and nothing else (the robot playing) owns the Pre-Viz */
  enabled: boolean;
}): Preview {
  const { name, doc, params, playhead, setPlayhead, enabled } = opts;
  const [rendered, setRendered] = useState<Rendered | null>(null);
  const [previewing, setPreviewing] = useState(false);
  const [preparing, setPreparing] = useState(false);
  const [showPose, setShowPose] = useState(false);
  const [error, setError] = useState<string | null>(null);
  const [muted, setMutedShown] = useState(false);
  const paramsKey = JSON.stringify(params);
  const now = useLatest({ playhead, setPlayhead, rendered });
  const run = useRef(0);  // counts starts and stops: a late render or preload of an old start is dropped

  // the kept render of the working copy (for scrubbing, and the duration)
  useEffect(() => {
    if (!enabled) return;
    let current = true;
    const timer = window.setTimeout(() => {
      behaviourApi.render(doc, JSON.parse(paramsKey) as Record<string, unknown>, 30)
        .then((r) => { if (current) { setRendered(r); setError(null); } })
        .catch((e: unknown) => { if (current) { setRendered(null); setError(issuesOf(e).message); } });
    }, RENDER_DEBOUNCE_MS);
    return () => { current = false; window.clearTimeout(timer); };
  }, [doc, paramsKey, enabled]);

  const stop = useCallback(() => {
    run.current += 1;
    setPreviewing(false);
    setPreparing(false);
    setShowPose(false);
    stopAll();
  }, []);

  const start = useCallback(() => {
    const mine = ++run.current;
    // from the click: browsers start audio only after a gesture
    void unlock().catch(() => undefined);
    setPreparing(true);
    setError(null);
    setMutedShown(isMuted());
    behaviourApi.render(doc, params, 30).then(async (r) => {
      await Promise.allSettled(audioUrls(r).map((u) => loadSound(u)));
      if (run.current !== mine) return;
      setRendered(r);
      setPreparing(false);
      setPreviewing(true);
      setShowPose(true);
    }).catch((e: unknown) => {
      if (run.current !== mine) return;
      setPreparing(false);
      setError(issuesOf(e).message);
    });
  }, [doc, params]);

  // the playhead's run while previewing (paused while the editor is hidden or the robot plays)
  const running = previewing && enabled;
  useEffect(() => {
    const r = now.current.rendered;
    if (!running || !r) return;
    const mine = run.current;
    const from = now.current.playhead >= r.duration ? 0 : now.current.playhead;
    const started = performance.now();
    const stops: (() => void)[] = [];
    // `offset`: s into the event now (negative: it is due that long from now)
    const fire = (e: RenderEvent, offset: number) => {
      const url = audioUrl(e);
      if (url) {
        loadSound(url).then((buffer) => {
          if (run.current === mine) stops.push(playBuffer(buffer, String(e.payload.sound ?? url), offset, e.t));
        }).catch(() => undefined);
        return;
      }
      const text = spokenText(e);
      if (!text) return;
      if (offset >= 0) {
        stops.push(speak(text, e.t));
        return;
      }
      const timer = window.setTimeout(() => { if (run.current === mine) stops.push(speak(text, e.t)); }, -offset * 1000);
      stops.push(() => window.clearTimeout(timer));
    };
    for (const { event, offset } of soundingAt(r.events, from)) fire(event, offset);
    let prev = from;
    let frame = 0;
    const tick = (time: number) => {
      const t = Math.min(r.duration, from + Math.max(0, time - started) / 1000);
      const end = t >= r.duration;
      const horizon = end ? Infinity : t + LOOKAHEAD;
      for (const e of eventsBetween(r.events, prev, horizon)) fire(e, t - e.t);
      prev = horizon;
      now.current.setPlayhead(t);
      if (end) { setPreviewing(false); setShowPose(false); return; }
      frame = requestAnimationFrame(tick);
    };
    frame = requestAnimationFrame(tick);
    return () => {
      cancelAnimationFrame(frame);
      // the sounds started so far end with the run (a stop, an edit's new start)
      for (const s of stops) s();
    };
  }, [running, now]);

  // the Pre-Viz shows the frame under the playhead while previewing or scrubbing; cleared after
  const label = `behaviour ${name}`;  // the Pre-Viz says "Preview: … (the robot is not moved)"
  // a plain function: usePoseStream keeps the newest one
  const pose = () => {
    if (!rendered) return null;
    const values = frameAt(rendered, Math.floor(playhead * PREVIEW_POSE_HZ) / PREVIEW_POSE_HZ);
    return values ? { values, label } : null;
  };
  usePoseStream(enabled && showPose && !!rendered, pose, clipApi.preview);

  useEffect(() => () => stopAll(), []);

  const toggle = useCallback(() => (running || preparing ? stop() : start()), [running, preparing, start, stop]);
  const scrubbed = useCallback(() => { if (!running) setShowPose(true); }, [running]);
  return { previewing: running, preparing, muted, duration: rendered?.duration ?? null, error, toggle, stop, scrubbed };
}
