// The bar between the dopesheet and the graph editor: drag it to give either more room (the share is
// remembered between visits); a double-click goes back to the default.
import { useCallback, useEffect, useState, type PointerEvent as ReactPointerEvent } from "react";

const STORAGE_KEY = "nutty.clipSplit/1";
/** The dopesheet's share of the two views' height by default, and the range a drag may set. */
export const DEFAULT_SHARE = 0.43;
const MIN_SHARE = 0.15;
const MAX_SHARE = 0.85;

export const clampShare = (x: number): number => Math.min(MAX_SHARE, Math.max(MIN_SHARE, x));

function loadShare(): number {
  try {
    const v = Number(window.localStorage.getItem(STORAGE_KEY));
    return v > 0 ? clampShare(v) : DEFAULT_SHARE;
  } catch {
    return DEFAULT_SHARE;  // no storage: the default
  }
}

/** The dopesheet's share (0..1) of the height the two views split, and the bar that sets it. */
export function useTimelineSplit(): [number, (props: { area: () => DOMRect | null }) => React.JSX.Element] {
  const [share, setShare] = useState(loadShare);
  useEffect(() => {
    try { window.localStorage.setItem(STORAGE_KEY, String(share)); } catch { /* no storage: not remembered */ }
  }, [share]);
  const Bar = useCallback(({ area }: { area: () => DOMRect | null }) => {
    const start = (e: ReactPointerEvent) => {
      const box = area();
      if (!box) return;
      e.preventDefault();
      const move = (ev: PointerEvent) => setShare(clampShare((ev.clientY - box.top) / Math.max(1, box.height)));
      const up = () => { window.removeEventListener("pointermove", move); window.removeEventListener("pointerup", up); };
      window.addEventListener("pointermove", move);
      window.addEventListener("pointerup", up);
    };
    return <div className="timeline-split" data-testid="timeline-split" role="separator" aria-orientation="horizontal"
                title="drag to share the height between the dopesheet and the graph editor (double-click: reset)"
                onPointerDown={start} onDoubleClick={() => setShare(DEFAULT_SHARE)} />;
  }, []);
  return [share, Bar];
}
