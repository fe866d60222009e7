// Zoom and layout buttons on the canvas: zoom in/out, fit (readable), 100 %, auto-layout; they also hand
// the zoom to the styles (--zoom), which size collapsed titles from it.
import { Panel, useReactFlow, useStore } from "@xyflow/react";
import { useEffect } from "react";
import { MAX_FIT_ZOOM, READABLE_ZOOM } from "./viewport";

/** How long the buttons' zooms animate (ms). */
const ZOOM_MS = 150;

export function CanvasControls({ fit, autoLayout }: { fit: () => void; autoLayout: () => void }) {
  const flow = useReactFlow();
  const zoom = useStore((s) => Math.round(s.transform[2] * 100));
  // collapsed titles are sized from the zoom in CSS (styles.css: --zoom), and drop their type line below
  // the zoom where it is too small to read (.tiny)
  useEffect(() => {
    const graph = document.querySelector<HTMLElement>(".graph");
    graph?.style.setProperty("--zoom", String(zoom / 100));
    graph?.classList.toggle("tiny", zoom / 100 < READABLE_ZOOM);
  }, [zoom]);
  return (
    <Panel position="bottom-left" className="canvas-controls" data-testid="canvas-controls">
      <button onClick={() => flow.zoomIn({ duration: ZOOM_MS })} title="Zoom in (wheel)" aria-label="zoom in">+</button>
      <button onClick={() => flow.zoomOut({ duration: ZOOM_MS })} title="Zoom out (wheel)" aria-label="zoom out">−</button>
      <span className="zoom-level" data-testid="zoom-level">{zoom}%</span>
      <button onClick={fit} title="Fit the selection or the graph, readable (F)" aria-label="fit view">Fit</button>
      <button onClick={() => {
        const { x, y, zoom: z } = flow.getViewport();
        const r = document.querySelector(".graph .react-flow")!.getBoundingClientRect();
        // keep the centre of the view where it is
        const cx = (r.width / 2 - x) / z, cy = (r.height / 2 - y) / z;
        flow.setViewport({ x: r.width / 2 - cx, y: r.height / 2 - cy, zoom: Math.min(1, MAX_FIT_ZOOM) }, { duration: ZOOM_MS });
      }} title="Zoom to 100 %" aria-label="zoom 100%">1:1</button>
      <span className="sep" />
      <button onClick={autoLayout} title="Lay the graph out by stage, left to right (one undo step)" data-testid="auto-layout">Auto-layout</button>
    </Panel>
  );
}
