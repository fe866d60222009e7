// Ways to pose the robot besides the pose panel's sliders, each feeding the same edited pose: DoFs
// grabbed in the Pre-Viz (polled from GET /api/previz/preview) and a gamepad's stick (the browser
// Gamepad API, polled per animation frame).
import { useEffect, useState } from "react";
import { clipApi, type PoseValues } from "./clipApi";
import type { DofInfo } from "./model/types";
import { sliderRange } from "./poseValues";
import { useLatest } from "./useLatest";

/** How often (ms) the Pre-Viz is asked whether DoFs were grabbed there. */
export const GRAB_POLL_MS = 250;

/** Calls `onGrab(grabbed)` each time the Pre-Viz's grab revision changes (not for the one found
 * when the polling starts: that grab belongs to an earlier session). */
export function usePrevizGrab(enabled: boolean, onGrab: (grabbed: PoseValues) => void): void {
  const cb = useLatest(onGrab);
  useEffect(() => {
    if (!enabled) return;
    let seen: number | null = null;
    let busy = false;
    const timer = window.setInterval(() => {
      if (busy) return;
      busy = true;
      clipApi.previewState().then((s) => {
        if (seen !== null && s.revision !== seen && s.grabbed && Object.keys(s.grabbed).length) cb.current(s.grabbed);
        seen = s.revision;
      }).catch(() => undefined).finally(() => { busy = false; });  // no Pre-Viz (or an older server): no grabs
    }, GRAB_POLL_MS);
    return () => window.clearInterval(timer);
  }, [enabled, cb]);
}

/** A stick deflection below this is the stick at rest. */
export const DEADZONE = 0.08;

/** A stick axis (-1..1) as a value of `dof` about `base`: full deflection reaches the DoF's limit on
 * that side. */
export function axisValue(axis: number, base: number, dof: Pick<DofInfo, "min" | "max" | "rest">): number {
  const [min, max] = sliderRange(dof);
  const a = Math.abs(axis) < DEADZONE ? 0 : Math.max(-1, Math.min(1, axis));
  const v = a >= 0 ? base + a * (max - base) : base + a * (base - min);
  return Math.min(max, Math.max(min, v));
}

/** Whether a gamepad is connected; while `enabled` and one is, its first two axes drive `dofs`
 * (x, y) about `base(dof)` through `onPose`, only when the stick moved. */
export function useGamepad(enabled: boolean, dofs: [DofInfo | null, DofInfo | null], base: (dof: string) => number,
  onPose: (values: Record<string, number>) => void): boolean {
  const [connected, setConnected] = useState(false);
  const latest = useLatest({ dofs, base, onPose });

  useEffect(() => {
    const pads = () => (typeof navigator.getGamepads === "function" ? navigator.getGamepads() : []);
    const check = () => setConnected(pads().some((p) => p?.connected));
    check();
    window.addEventListener("gamepadconnected", check);
    window.addEventListener("gamepaddisconnected", check);
    return () => {
      window.removeEventListener("gamepadconnected", check);
      window.removeEventListener("gamepaddisconnected", check);
    };
  }, []);

  useEffect(() => {
    if (!enabled || !connected) return;
    let frame = 0;
    let last: [number, number] = [0, 0];
    const poll = () => {
      const pad = Array.from(navigator.getGamepads()).find((p) => p?.connected);
      if (pad && pad.axes.length >= 2) {
        const axes: [number, number] = [pad.axes[0], -pad.axes[1]];  // stick up is negative in the API
        if (Math.abs(axes[0] - last[0]) > 1e-3 || Math.abs(axes[1] - last[1]) > 1e-3) {
          last = axes;
          const { dofs: [x, y], base: b, onPose: send } = latest.current;
          const values: Record<string, number> = {};
          if (x) values[x.name] = axisValue(axes[0], b(x.name), x);
          if (y) values[y.name] = axisValue(axes[1], b(y.name), y);
          if (Object.keys(values).length) send(values);
        }
      }
      frame = requestAnimationFrame(poll);
    };
    frame = requestAnimationFrame(poll);
    return () => cancelAnimationFrame(frame);
  }, [enabled, connected, latest]);
  return connected;
}
