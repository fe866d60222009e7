// The time ruler above the clip editor's views (and later the behaviour timeline): second labels, frame
// ticks once zoomed in, the clip's end shaded, and the playhead, which a click or drag scrubs (snapped
// to frames unless Alt). Wheel zooms about the pointer, Shift+wheel or a middle-drag pans.
import { memo, useRef } from "react";
import type { PointerEvent as ReactPointerEvent } from "react";
import { trackPointer, useElementWidth, useWheel, wheelTimeView } from "./interaction";
import type { TimeView } from "./timeView";
import { GUTTER, panBy, rulerTicks, secondsPerPx, snapFrame, timeToX, xToTime } from "./timeView";
import "./views.css";

export interface RulerProps {
  view: TimeView;
  setView: (view: TimeView) => void;
  fps: number;
  /** the clip's end (s): later times are shaded */
  duration: number;
  playhead: number;
  setPlayhead: (t: number) => void;
  /** total width (px) incl. the gutter; measured from the element when omitted */
  width?: number;
  /** blank column (px) left of the time area, to line up with the views below (default GUTTER) */
  gutter?: number;
}

const HEIGHT = 26;

function RulerImpl({ view, setView, fps, duration, playhead, setPlayhead, width, gutter = GUTTER }: RulerProps) {
  const box = useRef<HTMLDivElement>(null);
  const measured = useElementWidth(box);
  const total = width ?? measured;
  const w = Math.max(1, total - gutter);
  const ticks = rulerTicks(view, w, fps);
  const x = (t: number) => gutter + timeToX(view, w, t);

  useWheel(box, (e) => {
    const rect = box.current?.getBoundingClientRect();
    if (!rect) return;
    e.preventDefault();
    setView(wheelTimeView(view, w, e.clientX - rect.left - gutter, e));
  });

  const onPointerDown = (e: ReactPointerEvent) => {
    const rect = box.current?.getBoundingClientRect();
    if (!rect) return;
    e.preventDefault();
    if (e.button === 1) {
      const start = view;
      const spp = secondsPerPx(view, w);
      trackPointer(e, (m) => setView(panBy(start, -(m.clientX - e.clientX) * spp)), () => {});
      return;
    }
    if (e.button !== 0 || e.clientX - rect.left < gutter) return;
    const at = (clientX: number, alt: boolean) => {
      const t = Math.max(0, xToTime(view, w, clientX - rect.left - gutter));
      setPlayhead(alt ? t : snapFrame(t, fps));
    };
    at(e.clientX, e.altKey);
    trackPointer(e, (m) => at(m.clientX, m.altKey), () => {});
  };

  const endX = Math.max(gutter, x(duration));
  const px = x(playhead);
  const frame = Math.round(playhead * fps);
  return (
    <div ref={box} className="clip-ruler" data-testid="clip-ruler" onPointerDown={onPointerDown}
         data-t0={view.t0} data-t1={view.t1} data-gutter={gutter}
         style={width != null ? { width } : undefined}>
      <svg width={total} height={HEIGHT}>
        <text className="ruler-now" x={6} y={17}>{playhead.toFixed(3)} s · f {frame}</text>
        <svg x={gutter} width={w} height={HEIGHT} overflow="hidden">
          {endX - gutter < w && <rect className="clip-end-shade" x={endX - gutter} y={0} width={w - (endX - gutter)} height={HEIGHT} />}
          {ticks.minor.map((t) => {
            const tx = timeToX(view, w, t);
            return <line key={`m${t}`} className="tick-minor" x1={tx} x2={tx} y1={HEIGHT - (ticks.frames ? 5 : 4)} y2={HEIGHT} />;
          })}
          {ticks.major.map((k) => {
            const tx = timeToX(view, w, k.t);
            return (
              <g key={k.t}>
                <line className="tick-major" x1={tx} x2={tx} y1={HEIGHT - 10} y2={HEIGHT} />
                <text className="tick-label" x={tx + 3} y={11}>{k.label}</text>
              </g>
            );
          })}
        </svg>
        {px >= gutter && px <= total && (
          <g className="playhead" data-testid="clip-playhead" data-t={playhead}>
            <line x1={px} x2={px} y1={0} y2={HEIGHT} />
            <path d={`M${px - 5} 0 H${px + 5} V6 L${px} 11 L${px - 5} 6 Z`} />
          </g>
        )}
        {(px < gutter || px > total) && <g data-testid="clip-playhead" data-t={playhead} />}
      </svg>
    </div>
  );
}

export const Ruler = memo(RulerImpl);
export default Ruler;
