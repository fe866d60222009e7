// Pointer and wheel plumbing the ruler, dopesheet and graph editor share: measuring a view's width,
// non-passive wheel zoom/pan of the time view, following a drag outside the element, and the snap
// options a modifier-key combination asks for.
import { useEffect, useLayoutEffect, useRef, useState } from "react";
import type { RefObject } from "react";
import type { TimeView } from "./timeView";
import { panBy, secondsPerPx, xToTime, zoomAbout } from "./timeView";

/** The element's content width (px), following resizes. */
export function useElementWidth(ref: RefObject<HTMLElement | null>, fallback = 600): number {
  const [width, setWidth] = useState(fallback);
  useLayoutEffect(() => {
    const el = ref.current;
    if (!el) return;
    const measure = () => setWidth(Math.max(1, el.clientWidth || fallback));
    measure();
    if (typeof ResizeObserver === "undefined") return;
    const ro = new ResizeObserver(measure);
    ro.observe(el);
    return () => ro.disconnect();
  }, [ref, fallback]);
  return width;
}

/** The element's content size (px), following resizes. */
export function useElementSize(ref: RefObject<HTMLElement | null>, fallback = { width: 600, height: 240 }): { width: number; height: number } {
  const [size, setSize] = useState(fallback);
  const { width: fw, height: fh } = fallback;
  useLayoutEffect(() => {
    const el = ref.current;
    if (!el) return;
    const measure = () => {
      const next = { width: Math.max(1, el.clientWidth || fw), height: Math.max(1, el.clientHeight || fh) };
      setSize((s) => (s.width === next.width && s.height === next.height ? s : next));
    };
    measure();
    if (typeof ResizeObserver === "undefined") return;
    const ro = new ResizeObserver(measure);
    ro.observe(el);
    return () => ro.disconnect();
  }, [ref, fw, fh]);
  return size;
}

/** A wheel listener that may preventDefault (React's own is passive); the handler may change freely. */
export function useWheel(ref: RefObject<HTMLElement | SVGElement | null>, handler: (e: WheelEvent) => void): void {
  const latest = useRef(handler);
  useLayoutEffect(() => {
    latest.current = handler;
  });
  useEffect(() => {
    const el = ref.current;
    if (!el) return;
    const on = (e: Event) => latest.current(e as WheelEvent);
    el.addEventListener("wheel", on, { passive: false });
    return () => el.removeEventListener("wheel", on);
  }, [ref]);
}

/** The time view after a wheel event at `x` px into a time area `width` px wide: Shift pans, otherwise
 * zoom about the pointer. */
export function wheelTimeView(view: TimeView, width: number, x: number, e: WheelEvent): TimeView {
  const delta = e.deltaMode === 1 ? e.deltaY * 16 : e.deltaY;
  if (e.shiftKey) {
    const d = Math.abs(e.deltaX) > Math.abs(delta) ? e.deltaX : delta;
    return panBy(view, d * secondsPerPx(view, width));
  }
  return zoomAbout(view, xToTime(view, width, x), Math.exp(delta * 0.0015));
}

/** Follow a pointer from pointerdown until it is released, wherever it goes. `move` gets the pointer
 * event; `up` learns whether the pointer moved more than 3 px (a drag) or not (a click). */
export function trackPointer(
  down: { clientX: number; clientY: number },
  move: (e: PointerEvent) => void,
  up: (e: PointerEvent, moved: boolean) => void,
): void {
  let moved = false;
  const onMove = (e: PointerEvent) => {
    if (!moved && Math.hypot(e.clientX - down.clientX, e.clientY - down.clientY) > 3) moved = true;
    if (moved) move(e);
  };
  const onUp = (e: PointerEvent) => {
    window.removeEventListener("pointermove", onMove);
    window.removeEventListener("pointerup", onUp);
    window.removeEventListener("pointercancel", onUp);
    up(e, moved);
  };
  window.addEventListener("pointermove", onMove);
  window.addEventListener("pointerup", onUp);
  window.addEventListener("pointercancel", onUp);
}

export type SnapMode = "frames" | "keys" | "none";

/** Snapping for a key move: frames by default, Ctrl/Cmd snaps to other keys and the playhead (within
 * 8 px), Alt none. */
export function snapOptions(
  mods: { altKey: boolean; ctrlKey: boolean; metaKey: boolean },
  fps: number,
  spp: number,
  playhead?: number,
): { fps: number; snap: SnapMode; tolerance: number; extraTimes: number[] } {
  const snap: SnapMode = mods.altKey ? "none" : mods.ctrlKey || mods.metaKey ? "keys" : "frames";
  return { fps, snap, tolerance: 8 * spp, extraTimes: playhead == null ? [] : [playhead] };
}

/** True when a key press belongs to a text field or select (the views' shortcuts leave it alone). */
export function typingInto(target: EventTarget | null): boolean {
  if (!(target instanceof HTMLElement)) return false;
  return target.isContentEditable || ["INPUT", "SELECT", "TEXTAREA"].includes(target.tagName);
}
