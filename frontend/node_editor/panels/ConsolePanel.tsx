// The command console: what was sent and what the control socket answered. Its top edge is a splitter
// (drag to resize; the height is remembered), and it follows new lines unless the user scrolled up.
import { useLayoutEffect, useRef, useState } from "react";
import { useEditor } from "../store/EditorStore";

const SHOWN_LINES = 200;
const HEIGHT_KEY = "nutty.console.height";
export const CONSOLE_MIN = 60, CONSOLE_MAX = 600, CONSOLE_DEFAULT = 96;
const AT_BOTTOM_PX = 6;

function savedHeight(): number {
  const h = Number(window.localStorage?.getItem(HEIGHT_KEY));
  return Number.isFinite(h) && h >= CONSOLE_MIN && h <= CONSOLE_MAX ? h : CONSOLE_DEFAULT;
}

export function ConsolePanel() {
  const { consoleLines } = useEditor().state;
  const [height, setHeight] = useState(savedHeight);
  const box = useRef<HTMLPreElement>(null);
  const follow = useRef(true);  // at the bottom: new lines scroll into view

  useLayoutEffect(() => {
    const el = box.current;
    if (el && follow.current) el.scrollTop = el.scrollHeight;
  }, [consoleLines, height]);

  const startResize = (e: React.PointerEvent) => {
    e.preventDefault();
    const y0 = e.clientY, h0 = height;
    let h = h0;
    const move = (ev: PointerEvent) => {
      h = Math.min(CONSOLE_MAX, Math.max(CONSOLE_MIN, h0 + (y0 - ev.clientY)));
      setHeight(h);
    };
    const up = () => {
      window.removeEventListener("pointermove", move);
      window.removeEventListener("pointerup", up);
      window.localStorage?.setItem(HEIGHT_KEY, String(Math.round(h)));
    };
    window.addEventListener("pointermove", move);
    window.addEventListener("pointerup", up);
  };

  return (
    <div className="console-wrap">
      <div className="console-splitter" data-testid="console-splitter" role="separator" aria-orientation="horizontal"
           aria-label="resize the console" title="drag to resize the console" onPointerDown={startResize} />
      <pre className="console" data-testid="console" ref={box} style={{ height }}
           onScroll={(e) => {
             const el = e.currentTarget;
             follow.current = el.scrollHeight - el.scrollTop - el.clientHeight <= AT_BOTTOM_PX;
           }}>{consoleLines.slice(-SHOWN_LINES).join("\n")}</pre>
    </div>
  );
}
