// The curve panel (uPlot): a DoF over the last seconds, stage 1 (the ghost) vs the final output,
// with the trajectory-helper's colouring of the final curve: green ok, orange velocity, pink
// acceleration, red jerk violation of the robot's limits.
// The DoF shown is the robot's first continuous one until the user picks another.
import { useContext, useEffect, useMemo, useRef, useState } from "react";
import uPlot from "uplot";
import "uplot/dist/uPlot.min.css";
import type { DofInfo } from "../api";
import { SamplesContext } from "../context";
import { useEditor } from "../store/EditorStore";
import { TELEMETRY_HZ, type Samples } from "../telemetry";
import { classify, CLASS_COLOURS, CLASS_NAMES } from "../trajectory";
import { ticks } from "../live/logic";

const AXIS_FONT_PX = 7;  // about one character of the axis font
/** The plot's height, and its width before its box is measured. */
const PLOT_HEIGHT = 150;
const FALLBACK_WIDTH = 600;
/** The value axis: at least this wide, or its longest label and this much room beside it. */
const Y_AXIS_MIN_WIDTH = 44;
const Y_AXIS_LABEL_ROOM = 20;

export function CurvePanel() {
  const samples = useContext(SamplesContext);
  const { robot } = useEditor().state;
  const [picked, setPicked] = useState<string | null>(null);
  const dofs = robot?.dofs.filter((d) => d.type === "continuous").map((d) => d.name) ?? [];
  const dof = picked ?? dofs[0] ?? "";
  return <CurvePlot samples={samples} dof={dof} info={robot?.dofs.find((d) => d.name === dof)} rate={TELEMETRY_HZ}
                    onDof={setPicked} dofs={dofs} />;
}

function CurvePlot({ samples, dof, info, rate, onDof, dofs }: {
  samples: Samples; dof: string; info: DofInfo | undefined; rate: number; onDof: (d: string) => void; dofs: string[];
}) {
  const box = useRef<HTMLDivElement>(null);
  const plot = useRef<uPlot | null>(null);
  // each sample's class: the server's per-frame classes (exact at the engine's rate), or finite
  // differences of the decimated samples from a server that does not send them
  const classes = useMemo(() => {
    const final = samples.final[dof] ?? [];
    if (samples.classes.length === final.length && samples.classes.length) return samples.classes.map((c) => c[dof] ?? 0);
    return info ? classify(final, rate, info.velocity ?? Infinity, info.acceleration ?? Infinity, info.jerk ?? Infinity) : [];
  }, [samples, dof, info, rate]);
  const drawn = useRef<number[]>([]);  // the classes the plot's draw hook colours the final curve with

  useEffect(() => {
    if (!box.current) return;
    const opts: uPlot.Options = {
      width: box.current.clientWidth || FALLBACK_WIDTH,
      height: PLOT_HEIGHT,
      legend: { show: false },
      scales: { x: { time: false } },
      axes: [
        { stroke: "#9aa4b2", grid: { stroke: "#2a2f38" }, ticks: { stroke: "#2a2f38" } },
        {
          stroke: "#9aa4b2", grid: { stroke: "#2a2f38" }, ticks: { stroke: "#2a2f38" },
          // negative values with a visible minus (U+2212), and an axis wide enough for the longest label
          // (uPlot right-aligns them against the plot: a label wider than the axis loses its sign)
          values: (_u, splits) => {
            const labels = ticks(splits);
            box.current?.setAttribute("data-y-ticks", labels.join(" "));
            return labels;
          },
          size: (_u, values) => Math.max(Y_AXIS_MIN_WIDTH, ...(values ?? []).map((v) => String(v).length * AXIS_FONT_PX + Y_AXIS_LABEL_ROOM)),
        },
      ],
      series: [
        {},
        { label: "stage 1", stroke: "#6f8fb8", width: 1, dash: [4, 3], points: { show: false } },
        { label: "final", stroke: "#e8e8e8", width: 1.5, points: { show: false } },
      ],
      hooks: {
        draw: [
          (u) => {
            const ctx = u.ctx;
            const xs = u.data[0] as number[];
            const ys = u.data[2] as (number | null)[];
            const cls = drawn.current;
            ctx.save();
            for (let i = 1; i < xs.length; i++) {
              const c = cls[i] ?? 0;
              if (ys[i] == null || ys[i - 1] == null) continue;
              ctx.strokeStyle = CLASS_COLOURS[c];
              ctx.lineWidth = c ? 3 : 2;
              ctx.beginPath();
              ctx.moveTo(u.valToPos(xs[i - 1], "x", true), u.valToPos(ys[i - 1] as number, "y", true));
              ctx.lineTo(u.valToPos(xs[i], "x", true), u.valToPos(ys[i] as number, "y", true));
              ctx.stroke();
            }
            ctx.restore();
          },
        ],
      },
    };
    plot.current = new uPlot(opts, [[], [], []], box.current);
    const ro = new ResizeObserver(() => plot.current?.setSize({ width: box.current!.clientWidth, height: PLOT_HEIGHT }));
    ro.observe(box.current);
    return () => { ro.disconnect(); plot.current?.destroy(); };
  }, []);

  useEffect(() => {
    drawn.current = classes;
    plot.current?.setData([samples.t, samples.stage1[dof] ?? [], samples.final[dof] ?? []]);
  }, [samples, dof, classes]);

  const counts = [0, 0, 0, 0];
  for (const c of classes) counts[c]++;
  return (
    <div className="curves" data-testid="curve-panel">
      <div className="curve-head">
        <select value={dof} onChange={(e) => onDof(e.target.value)} aria-label="DoF to plot">
          {dofs.map((d) => <option key={d} value={d}>{d}</option>)}
        </select>
        <span className="legend"><i className="dash" /> stage 1 (ghost) <i className="solid" /> final</span>
        {CLASS_NAMES.map((n, i) => (
          <span key={n} className="cls" style={{ color: CLASS_COLOURS[i] }}>● {n} {counts[i]}</span>
        ))}
      </div>
      <div ref={box} className="plot" />
    </div>
  );
}
