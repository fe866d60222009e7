// Playback of the clip in the editor: the playhead runs in real time from where it stands (one
// requestAnimationFrame per frame), wraps when looping, and stops at the clip's end otherwise.
import { useCallback, useEffect, useState } from "react";
import { useLatest } from "./useLatest";

export interface Playback {
  playing: boolean;
  loop: boolean;
  setLoop: (loop: boolean) => void;
  toggle: () => void;
  /** Play from the playhead (nothing when already playing). */
  play: () => void;
  /** Stop and go back to the start. */
  stop: () => void;
}

/** The playhead `elapsed` seconds after `from`, in a clip of `end` seconds; `done` when it ran out. */
export function advance(from: number, elapsed: number, end: number, loop: boolean): { t: number; done: boolean } {
  const t = from + elapsed;
  if (end <= 0) return { t: 0, done: true };
  if (t < end) return { t, done: false };
  if (loop) return { t: t % end, done: false };
  return { t: end, done: true };
}

export function usePlayback(playhead: number, setPlayhead: (t: number) => void, end: number): Playback {
  const [playing, setPlaying] = useState(false);
  const [loop, setLoop] = useState(false);
  const now = useLatest({ playhead, end, loop, setPlayhead });

  useEffect(() => {
    if (!playing) return;
    // from the playhead as it stood when play was pressed (at the end without looping: from the start)
    const from = now.current.playhead >= now.current.end && !now.current.loop ? 0 : now.current.playhead;
    const started = performance.now();
    let frame = 0;
    const tick = (time: number) => {
      const { end: e, loop: l, setPlayhead: set } = now.current;
      const { t, done } = advance(from, Math.max(0, time - started) / 1000, e, l);
      set(t);
      if (done) { setPlaying(false); return; }
      frame = requestAnimationFrame(tick);
    };
    frame = requestAnimationFrame(tick);
    return () => cancelAnimationFrame(frame);
    // a loop toggled while playing applies from the next frame (read through `now`)
  }, [playing, now]);

  const toggle = useCallback(() => setPlaying((p) => !p), []);
  const play = useCallback(() => setPlaying(true), []);
  const stop = useCallback(() => {
    setPlaying(false);
    now.current.setPlayhead(0);
  }, [now]);
  return { playing, loop, setLoop, toggle, play, stop };
}
