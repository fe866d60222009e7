// The curve panel (uPlot): for the chosen DoFs or joints, what the program asked (before the engine's
// safety net, dashed) and what the robot got (after it, solid; joints in joint space), each correction
// of the net marked where it happens in the colour of the limit it enforced (velocity orange,
// acceleration pink, jerk red, position purple), the position limits on the y axis. The legend counts
// the delivered frames in view. A joint read at its motors (servos, a physics preview) also shows what
// they measured (dotted), and the legend its peak tracking error and saturation in view. Pause keeps the
// last minute; the slider then scrubs through it.
// The series are the robot's first continuous DoF until the user (or the top bar's safety indicator,
// ../live/liveUi `showCurves`) picks others.
import { useContext, useEffect, useMemo, useRef, useState } from "react";
import uPlot from "uplot";
import "uplot/dist/uPlot.min.css";
import { SamplesContext } from "../context";
import { useEditor } from "../store/EditorStore";
import { snapshot, type Samples } from "../telemetry";
import { CLASS_COLOURS, CLASS_NAMES } from "../trajectory";
import { ticks } from "../live/logic";
import { drawOverlay, type Overlay } from "../live/curveDraw";
import { legendText, netCounts, seriesOf, viewWindow, yRange, type SeriesInfo } from "../live/net";
import { setCurves, useLiveUi } from "../live/liveUi";
import { measuredKeys, trackingInView, trackingText } from "../live/measured";

const AXIS_FONT_PX = 7;  // about one character of the axis font
/** The plot's height, and its width before its box is measured. */
const PLOT_HEIGHT = 150;
const FALLBACK_WIDTH = 600;
/** The value axis: at least this wide, or its longest label and this much room beside it. */
const Y_AXIS_MIN_WIDTH = 44;
const Y_AXIS_LABEL_ROOM = 20;
/** The seconds in view. */
const VIEW_SECONDS = 8;
/** Each series' colour, in the order they were picked (apart from the limits' colours). */
export const SERIES_COLOURS = ["#e8e8e8", "#5fb4ff", "#ffd166", "#7ee0c3", "#f4a261", "#b8c0ff"];

export function CurvePanel() {
  const live = useContext(SamplesContext);
  const { robot } = useEditor().state;
  const { curves, curvesShown } = useLiveUi();
  const all = useMemo(() => seriesOf(robot), [robot]);
  const keys = curves ?? (all[0] ? [all[0].key] : []);
  const series = keys.map((k) => all.find((s) => s.key === k)).filter((s): s is SeriesInfo => !!s);
  const [paused, setPaused] = useState<Samples | null>(null);
  const [back, setBack] = useState(0);  // scrubbed: seconds before the newest paused sample
  const panel = useRef<HTMLDivElement>(null);
  const [shown, setShown] = useState(curvesShown);
  if (shown !== curvesShown) {  // the top bar asked to show series: live again (state adjusted in render)
    setShown(curvesShown);
    setPaused(null);
    setBack(0);
  }
  useEffect(() => { if (curvesShown) panel.current?.scrollIntoView({ block: "nearest" }); }, [curvesShown]);
  const samples = paused ?? live;
  const [from, to] = viewWindow(samples.t, VIEW_SECONDS, paused ? back : 0);
  const span = samples.t.length ? samples.t[samples.t.length - 1] - samples.t[0] : 0;
  const counts = netCounts(samples, keys, from, to);
  const tracking = trackingInView(samples, series, from, to);
  const read = useMemo(() => measuredKeys(live), [live]);
  const pause = () => { setPaused(paused ? null : snapshot(live)); setBack(0); };
  return (
    <div className="curves" data-testid="curve-panel" data-span={span.toFixed(2)} ref={panel}>
      <CurveHead all={all} series={series} onSeries={setCurves} paused={!!paused} onPause={pause} read={read}
                 measured={tracking.length > 0} />
      <div className="curve-legend" data-testid="curve-legend">
        <span data-testid="curve-frames">{counts.frames} frames</span>
        <span className="net-count" data-testid="net-legend" style={{ color: counts.corrected ? "#ffb36b" : undefined }}>
          {legendText(counts)}
        </span>
        <span className="delivered">delivered:</span>
        {CLASS_NAMES.map((n, i) => (
          <span key={n} className="cls" style={{ color: CLASS_COLOURS[i] }}>● {n} {counts.delivered[i]}</span>
        ))}
        {tracking.length > 0 && (
          <span className="measured" data-testid="curve-measured"
                style={{ color: tracking.some((t) => t.saturated) ? "#ffb36b" : undefined }}>
            {tracking.map(trackingText).join(" · ")}
          </span>
        )}
      </div>
      {paused && (
        <label className="scrub">
          {(-back).toFixed(1)} s
          <input type="range" aria-label="scrub" data-testid="curve-scrub" min={0} max={Math.max(0, span - VIEW_SECONDS)}
                 step={0.1} value={Math.max(0, span - VIEW_SECONDS) - back}
                 onChange={(e) => setBack(Math.max(0, span - VIEW_SECONDS) - Number(e.target.value))} />
        </label>
      )}
      <CurvePlot samples={samples} from={from} to={to} series={series} measured={tracking.map((t) => t.key)} />
    </div>
  );
}

function CurveHead({ all, series, onSeries, paused, onPause, read, measured }: {
  all: SeriesInfo[]; series: SeriesInfo[]; onSeries: (keys: string[]) => void; paused: boolean; onPause: () => void;
  /** the joints read at their motors (marked, so they can be found) */
  read: Set<string>;
  /** whether a measured line is in view (the legend then explains it) */
  measured: boolean;
}) {
  const keys = series.map((s) => s.key);
  const option = (s: SeriesInfo) => <option key={s.key} value={s.key}>{s.label}{read.has(s.key) ? " ●measured" : ""}</option>;
  const options = (
    <>
      <optgroup label="DoFs">{all.filter((s) => s.key.startsWith("dof:")).map(option)}</optgroup>
      <optgroup label="joints">{all.filter((s) => s.key.startsWith("joint:")).map(option)}</optgroup>
    </>
  );
  return (
    <div className="curve-head">
      <select value={keys[0] ?? ""} onChange={(e) => onSeries([e.target.value])} aria-label="DoF to plot">{options}</select>
      <select value="" onChange={(e) => e.target.value && !keys.includes(e.target.value) && onSeries([...keys, e.target.value])}
              aria-label="add a DoF or joint to the plot">
        <option value="">+ add…</option>
        {options}
      </select>
      {series.map((s, i) => (
        <span key={s.key} className="chip" data-testid={`curve-series-${s.key}`} data-series={s.key}>
          <i style={{ borderTopColor: SERIES_COLOURS[i % SERIES_COLOURS.length] }} />{s.label}
          {series.length > 1 && (
            <button aria-label={`remove ${s.label}`} onClick={() => onSeries(keys.filter((k) => k !== s.key))}>×</button>
          )}
        </span>
      ))}
      <span className="legend">
        <i className="dash" /> asked <i className="solid" /> delivered{measured && <> <i className="dot" /> measured</>}
      </span>
      <button className="pause" data-testid="curve-pause" onClick={onPause}
              title={paused ? "follow the robot again" : "hold the last minute, to scrub through it"}>
        {paused ? "▶ Live" : "❚❚ Pause"}
      </button>
    </div>
  );
}

function plotOptions(width: number, series: SeriesInfo[], overlay: { current: Overlay }, range: { current: [number, number] },
  box: HTMLDivElement): uPlot.Options {
  return {
    width, height: PLOT_HEIGHT,
    legend: { show: false },
    scales: { x: { time: false }, y: { range: () => range.current } },
    axes: [
      { stroke: "#9aa4b2", grid: { stroke: "#2a2f38" }, ticks: { stroke: "#2a2f38" } },
      {
        stroke: "#9aa4b2", grid: { stroke: "#2a2f38" }, ticks: { stroke: "#2a2f38" },
        // negative values with a visible minus (U+2212), and an axis wide enough for the longest label
        // (uPlot right-aligns them against the plot: a label wider than the axis loses its sign)
        values: (_u, splits) => {
          const labels = ticks(splits);
          box.setAttribute("data-y-ticks", labels.join(" "));
          return labels;
        },
        size: (_u, values) => Math.max(Y_AXIS_MIN_WIDTH, ...(values ?? []).map((v) => String(v).length * AXIS_FONT_PX + Y_AXIS_LABEL_ROOM)),
      },
    ],
    series: [
      {},
      ...series.flatMap((s, i) => {
        const colour = SERIES_COLOURS[i % SERIES_COLOURS.length];
        return [
          { label: `${s.label} asked`, stroke: colour, width: 1, dash: [4, 3], points: { show: false } },
          { label: `${s.label} delivered`, stroke: colour, width: 2, points: { show: false } },
        ];
      }),
      // after all the asked/delivered pairs: curveDraw finds those pairs by index
      ...series.map((s, i) => (
        { label: `${s.label} measured`, stroke: SERIES_COLOURS[i % SERIES_COLOURS.length], width: 1.5, dash: [1, 3], cap: "round" as const, points: { show: false } }
      )),
    ],
    hooks: { draw: [drawOverlay(overlay)] },
  };
}

function CurvePlot({ samples, from, to, series, measured }: {
  samples: Samples; from: number; to: number; series: SeriesInfo[];
  /** the series with a measured line in view */
  measured: string[];
}) {
  const box = useRef<HTMLDivElement>(null);
  const plot = useRef<uPlot | null>(null);
  const overlay = useRef<Overlay>({ series: [], colours: [], net: [] });
  const range = useRef<[number, number]>([-1, 1]);
  const shape = series.map((s) => s.key).join(",");

  useEffect(() => {
    if (!box.current) return;
    const el = box.current;
    plot.current = new uPlot(plotOptions(el.clientWidth || FALLBACK_WIDTH, series, overlay, range, el),
      [[], ...series.flatMap(() => [[], []]), ...series.map(() => [])], el);
    const ro = new ResizeObserver(() => plot.current?.setSize({ width: el.clientWidth, height: PLOT_HEIGHT }));
    ro.observe(el);
    return () => { ro.disconnect(); plot.current?.destroy(); plot.current = null; };
  }, [shape]);  // eslint-disable-line react-hooks/exhaustive-deps -- `shape` names `series`: a new plot only when the series change

  useEffect(() => {
    const data = series.flatMap((s) => [
      (samples.requested[s.key] ?? []).slice(from, to), (samples.final[s.key] ?? []).slice(from, to),
    ]);
    overlay.current = { series, colours: series.map((_, i) => SERIES_COLOURS[i % SERIES_COLOURS.length]), net: samples.net.slice(from, to) };
    // nulls for a series never read: uPlot wants every series as long as the x values
    const read = series.map((s) => samples.measured[s.key]?.slice(from, to) ?? new Array<null>(to - from).fill(null));
    range.current = yRange([...data, ...read], series.flatMap((s) => [s.lo, s.hi]));
    plot.current?.setData([samples.t.slice(from, to), ...data, ...read] as uPlot.AlignedData);
  }, [samples, from, to, series]);

  return (
    <div ref={box} className="plot" data-testid="curve-plot" data-series={series.map((s) => s.key).join(" ")}
         data-measured={measured.join(" ")} />
  );
}
