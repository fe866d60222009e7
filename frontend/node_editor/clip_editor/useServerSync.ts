// The clip editor's conversations with the running server, each as a hook: the Pre-Viz preview pose
// (PUT /api/previz/preview), the trajectory helper and ghost (POST /api/analyze and /api/filter), and
// playing the working copy on the robot (play_clip / stop_clip commands).
import { useEffect, useRef, useState } from "react";
import type { FilteredTracks, TrackAnalysis } from "../api";
import { clipApi, playClipCommand, type GhostPreset, type PoseValues } from "./clipApi";
import { refusalOf } from "./clipErrors";
import type { Clip } from "./model/types";
import { samePose } from "./poseValues";
import { useLatest } from "./useLatest";

/** Preview and puppet messages go out at most this often (ms): 30/s. */
export const SEND_INTERVAL_MS = 34;
/** An unchanged preview is sent again this often (ms): the server forgets one 3 s after its last PUT. */
export const KEEPALIVE_MS = 1000;

/** Sends `pose()` while `enabled`, at most every SEND_INTERVAL_MS when it changes and every
 * `keepAliveMs` when it does not; `send(null)` once when disabled or unmounted (when anything was sent). */
export function usePoseStream(enabled: boolean, pose: () => { values: PoseValues; label?: string } | null,
  send: (values: PoseValues | null, label?: string) => Promise<unknown>, keepAliveMs: number | null = KEEPALIVE_MS,
  onError?: (e: unknown) => void) {
  const latest = useLatest({ pose, send, onError });
  useEffect(() => {
    if (!enabled) return;
    let last: PoseValues | null = null;
    let lastAt = 0;
    let busy = false;
    let sentAny = false;
    const timer = window.setInterval(() => {
      const p = latest.current.pose();
      if (!p || busy) return;
      const now = performance.now();
      const changed = !samePose(p.values, last);
      if (!changed && (keepAliveMs === null || now - lastAt < keepAliveMs)) return;
      last = p.values;
      lastAt = now;
      busy = true;
      sentAny = true;
      latest.current.send(p.values, p.label).catch((e: unknown) => latest.current.onError?.(e)).finally(() => { busy = false; });
    }, SEND_INTERVAL_MS);
    return () => {
      window.clearInterval(timer);
      // eslint-disable-next-line react-hooks/exhaustive-deps -- the newest sender is meant: it ends the stream
      if (sentAny) latest.current.send(null).catch(() => undefined);
    };
  }, [enabled, keepAliveMs, latest]);
}

export interface HelperFigures {
  helper: TrackAnalysis | null;
  ghost: FilteredTracks | null;
  error: string | null;
  /** Counts arrivals of figures (the root's data-helper-rev). */
  rev: number;
}

export type GhostSource = "program" | GhostPreset | "off";

/** The slow-down search runs this long (ms) after the last edit. */
export const FIT_AFTER_MS = 400;

/** The trajectory helper's verdict and the ghost for the newest document: one request pair in flight
 * at a time; a document edited meanwhile is sent as soon as the answer is in (the newest wins). */
export function useHelperFigures(doc: Clip, rate: number | null, ghost: GhostSource, enabled: boolean): HelperFigures {
  const [figures, setFigures] = useState<HelperFigures>({ helper: null, ghost: null, error: null, rev: 0 });
  const state = useRef<{ busy: boolean; pending: { doc: Clip; ghost: GhostSource; rate: number } | null }>({ busy: false, pending: null });
  const fit = useRef<{ doc: Clip; fields: Pick<TrackAnalysis, "fit_scale" | "max_scale" | "suggestion"> } | null>(null);

  useEffect(() => {
    if (!enabled || rate === null || !Object.keys(doc.tracks).length) return;
    const s = state.current;
    s.pending = { doc, ghost, rate };
    const run = () => {
      const job = s.pending;
      if (!job || s.busy) return;
      s.pending = null;
      s.busy = true;
      const analysis = clipApi.analyze(job.rate, job.doc, false);
      const filtered = job.ghost === "off" ? Promise.resolve(null)
        : clipApi.filter(job.rate, job.doc, job.ghost === "program" ? undefined : job.ghost);
      Promise.allSettled([analysis, filtered]).then(([a, f]) => {
        s.busy = false;
        const failed = [a, f].find((r): r is PromiseRejectedResult => r.status === "rejected");
        const fitted = fit.current;
        setFigures((prev) => ({
          // the fit found for this very document stays with its new colours
          helper: a.status === "fulfilled" ? (fitted?.doc === job.doc ? { ...a.value, ...fitted.fields } : a.value) : prev.helper,
          ghost: f.status === "fulfilled" ? f.value : null,
          error: failed ? refusalOf(failed.reason).message : null,
          rev: prev.rev + 1,
        }));
        run();
      });
    };
    run();
  }, [doc, rate, ghost, enabled]);

  // the slow-down that would fit (a search: ~100 ms on a long clip over its limits) once edits pause,
  // kept only while it still describes the document on screen
  useEffect(() => {
    if (!enabled || rate === null || !Object.keys(doc.tracks).length) return;
    let current = true;
    const timer = window.setTimeout(() => {
      clipApi.analyze(rate, doc, true).then((full) => {
        if (!current) return;
        const fields = { fit_scale: full.fit_scale, max_scale: full.max_scale, suggestion: full.suggestion };
        fit.current = { doc, fields };
        setFigures((prev) => ({ ...prev, helper: prev.helper && { ...prev.helper, ...fields }, rev: prev.rev + 1 }));
      }).catch(() => undefined);  // the colours stand without it; the next pause asks again
    }, FIT_AFTER_MS);
    return () => { current = false; window.clearTimeout(timer); };
  }, [doc, rate, enabled]);
  return figures;
}

/** Debounce (ms) of re-sending play_clip after an edit while "On robot". */
export const ON_ROBOT_DEBOUNCE_MS = 300;

/** While `on`, the robot plays the working copy from the playhead (again after each edit, debounced);
 * turning it off stops the clip. Returns the last command error (null when fine). */
export function useOnRobot(on: boolean, name: string, doc: Clip, playhead: number, loop: boolean): string | null {
  const [error, setError] = useState<string | null>(null);
  const now = useLatest({ playhead });
  const started = useRef(false);

  useEffect(() => {
    if (!on) return;
    const send = () => clipApi.command(playClipCommand(name, doc, now.current.playhead, loop))
      .then(() => setError(null)).catch((e: unknown) => setError(refusalOf(e).message));
    // the first play goes at once; an edit's re-play waits for the edits to pause
    if (!started.current) {
      started.current = true;
      void send();
      return;
    }
    const timer = window.setTimeout(() => void send(), ON_ROBOT_DEBOUNCE_MS);
    return () => window.clearTimeout(timer);
  }, [on, name, doc, loop, now]);

  useEffect(() => {
    if (on) return;
    if (started.current) {
      started.current = false;
      clipApi.command({ type: "stop_clip" }).catch((e: unknown) => setError(refusalOf(e).message));
    }
  }, [on]);

  // closing the editor while on the robot stops the clip too
  useEffect(() => () => {
    if (started.current) clipApi.command({ type: "stop_clip" }).catch(() => undefined);
  }, []);
  return on ? error : null;
}
