// Playing the working copy on the robot: POST /api/commands play_behaviour, then its events from a
// /ws/control socket of our own (the server fans every event out to every control client): the
// playhead follows the behaviour's time, items are active between their `item` started and ended
// events, and the terminal event ends it. Stop cancels the command (DELETE /api/commands/{id}).
import { useCallback, useEffect, useRef, useState } from "react";
import { wsUrl, type ControlMessage } from "../api";
import { useLatest } from "../clip_editor/useLatest";
import { behaviourApi, issuesOf } from "./behaviourApi";
import type { BehaviourDoc } from "./model/types";

export interface RobotPlay {
  playing: boolean;
  /** what the robot is doing, for the status line (null: nothing to say) */
  status: string | null;
  /** ids of the items under way on the robot */
  active: ReadonlySet<string>;
  toggle: () => void;
}

const TERMINAL = new Set(["completed", "cancelled", "failed"]);
const ENDED = new Set(["completed", "cancelled", "failed", "ended", "stopped", "skipped"]);

/** The active set after one item event (pure). */
export function activeAfter(active: ReadonlySet<string>, item: string, state: string): Set<string> {
  const next = new Set(active);
  if (state === "started") next.add(item);
  else if (ENDED.has(state)) next.delete(item);
  return next;
}

/** `onEnded` gets the last word (completed, cancelled, failed, not played) for the editor's status. */
export function useRobotPlay(name: string, doc: BehaviourDoc, params: Record<string, unknown>, setPlayhead: (t: number) => void,
  onEnded: (status: string) => void): RobotPlay {
  const [playing, setPlaying] = useState(false);
  const [status, setStatus] = useState<string | null>(null);
  const [active, setActive] = useState<ReadonlySet<string>>(new Set());
  const now = useLatest({ name, doc, params, setPlayhead, onEnded });
  const session = useRef<{ ws: WebSocket; id: string | null; frame: number } | null>(null);

  const finish = useCallback(() => {
    const s = session.current;
    if (!s) return;
    session.current = null;
    cancelAnimationFrame(s.frame);
    s.ws.close();
    setPlaying(false);
    setActive(new Set());
  }, []);

  const start = useCallback(() => {
    const { name: n, doc: d, params: p } = now.current;
    const ws = new WebSocket(wsUrl("/ws/control"));
    const s = { ws, id: null as string | null, frame: 0 };
    session.current = s;
    const early: ControlMessage[] = [];  // events that arrive before the ack names our id
    let startedAt = 0;
    let offset = 0;  // the behaviour's time at startedAt (from an event's `t` when it has one)
    const runClock = () => {
      const tick = () => {
        now.current.setPlayhead(offset + (performance.now() - startedAt) / 1000);
        s.frame = requestAnimationFrame(tick);
      };
      cancelAnimationFrame(s.frame);
      s.frame = requestAnimationFrame(tick);
    };
    const handle = (m: ControlMessage) => {
      if (m.type !== "event" || m.id !== s.id || session.current !== s) return;
      const t = typeof m.t === "number" ? m.t : null;
      if (m.event === "started") {
        startedAt = performance.now();
        offset = 0;
        setStatus(`Playing on the robot: ${n} started`);
        runClock();
      } else if (m.event === "item" && typeof m.item === "string") {
        const state = typeof m.state === "string" ? m.state : "";
        setActive((a) => activeAfter(a, m.item as string, state));
        setStatus(`Playing on the robot: ${m.item as string} ${state}`);
        if (t !== null) { startedAt = performance.now(); offset = t; }
      } else if (TERMINAL.has(m.event)) {
        const why = typeof m.message === "string" ? `: ${m.message}` : typeof m.error === "string" ? `: ${m.error}` : "";
        finish();
        now.current.onEnded(`On the robot: ${n} ${m.event}${why}`);
      }
    };
    ws.onmessage = (ev) => {
      const m = JSON.parse(String(ev.data)) as ControlMessage;
      if (s.id === null) early.push(m);
      else handle(m);
    };
    setPlaying(true);
    setActive(new Set());
    setStatus(`Sending ${n} to the robot…`);
    // the socket first, so that no event of the command is missed
    const opened = new Promise<void>((resolve) => { ws.onopen = () => resolve(); ws.onerror = () => resolve(); });
    opened.then(() => behaviourApi.play(n, d, p)).then((ack) => {
      if (session.current !== s) { void behaviourApi.cancel(ack.id).catch(() => undefined); return; }
      s.id = ack.id;
      for (const m of early.splice(0)) handle(m);
    }).catch((e: unknown) => {
      if (session.current !== s) return;
      finish();
      now.current.onEnded(`Not played on the robot: ${issuesOf(e).message}`);
    });
  }, [now, finish]);

  const stop = useCallback(() => {
    const id = session.current?.id;
    if (id) behaviourApi.cancel(id).catch((e: unknown) => setStatus(`Stop refused: ${issuesOf(e).message}`));
    finish();
    now.current.onEnded("Stopped on the robot");
  }, [finish, now]);

  // closing the editor, or opening another behaviour in it, while the robot plays stops it (the
  // timeline and the status would otherwise follow a behaviour no longer shown)
  useEffect(() => () => {
    const id = session.current?.id;
    if (id) void behaviourApi.cancel(id).catch(() => undefined);
    finish();
  }, [name, finish]);

  const toggle = useCallback(() => (session.current ? stop() : start()), [start, stop]);
  return { playing, status, active, toggle };
}
