// What the curve panel draws on top of uPlot's lines: each series' position limits (dashed lines, the
// forbidden side shaded) and the safety net's corrections (a stroke from what was asked to what was
// delivered, and a dot on the delivered curve, in the colour of the limit it enforced).
import type uPlot from "uplot";
import { LIMIT_COLOURS, type SeriesInfo } from "./net";

/** What the draw hook reads (kept in a ref, refreshed with the data). */
export interface Overlay {
  series: SeriesInfo[];
  colours: string[];
  /** per sample of the window, series key -> [limit code, amount] */
  net: Record<string, [number, number]>[];
}

const FORBIDDEN = "rgba(169, 112, 255, 0.10)";
const MARK_RADIUS = 2.2;
/** Each series' limit labels start this much (px) right of the previous series' ones. */
const LABEL_PITCH = 150;

function drawLimits(u: uPlot, o: Overlay) {
  const ctx = u.ctx;
  const { left, top, width, height } = u.bbox;
  o.series.forEach((s, i) => {
    for (const [v, side] of [[s.lo, -1], [s.hi, 1]] as const) {
      if (v == null || !Number.isFinite(v)) continue;
      const y = u.valToPos(v, "y", true);
      if (y < top - 1 || y > top + height + 1) continue;
      ctx.fillStyle = FORBIDDEN;  // beyond the limit: where the robot may never go
      if (side > 0) ctx.fillRect(left, top, width, Math.max(0, y - top));
      else ctx.fillRect(left, y, width, Math.max(0, top + height - y));
      ctx.strokeStyle = o.colours[i];
      ctx.setLineDash([6, 4]);
      ctx.lineWidth = 1;
      ctx.beginPath();
      ctx.moveTo(left, y);
      ctx.lineTo(left + width, y);
      ctx.stroke();
      ctx.setLineDash([]);
      ctx.fillStyle = o.colours[i];
      ctx.font = `${10 * devicePixelRatio}px sans-serif`;
      ctx.textAlign = "left";
      ctx.textBaseline = "alphabetic";
      ctx.fillText(`${s.name} ${side > 0 ? "max" : "min"} ${v.toFixed(2)}`, left + (4 + LABEL_PITCH * i) * devicePixelRatio,
        y + (side > 0 ? 11 : -4) * devicePixelRatio);
    }
  });
}

function drawMarks(u: uPlot, o: Overlay) {
  const ctx = u.ctx;
  const xs = u.data[0] as number[];
  o.series.forEach((s, i) => {
    const asked = u.data[1 + 2 * i] as (number | null)[];
    const got = u.data[2 + 2 * i] as (number | null)[];
    for (let k = 0; k < xs.length; k++) {
      const mark = o.net[k]?.[s.key];
      const y = got[k];
      if (!mark || y == null) continue;
      const colour = LIMIT_COLOURS[mark[0]] ?? LIMIT_COLOURS[3];
      const x = u.valToPos(xs[k], "x", true);
      const yd = u.valToPos(y, "y", true);
      const r = asked[k];
      ctx.strokeStyle = colour;
      ctx.lineWidth = 1.5 * devicePixelRatio;
      const yr = r != null && Number.isFinite(r) ? u.valToPos(r, "y", true) : yd;
      if (Math.abs(yr - yd) >= devicePixelRatio) {  // what was asked, when it is a pixel or more away
        ctx.beginPath();
        ctx.moveTo(x, yr);
        ctx.lineTo(x, yd);
        ctx.stroke();
      }
      ctx.fillStyle = colour;
      ctx.beginPath();
      ctx.arc(x, yd, MARK_RADIUS * devicePixelRatio, 0, 2 * Math.PI);
      ctx.fill();
    }
  });
}

/** uPlot's draw hook for the overlay in `ref`. */
export function drawOverlay(ref: { current: Overlay }) {
  return (u: uPlot) => {
    u.ctx.save();
    drawLimits(u, ref.current);
    drawMarks(u, ref.current);
    u.ctx.restore();
  };
}
