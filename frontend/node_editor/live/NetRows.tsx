// The engine's safety net on the block that stands for it: the program's safety limiter, or its output
// when it has none (the net runs after the output). Per DoF, the ticks the net corrected since the
// engine started (and per joint the joint stage corrected), and the largest correction of the last
// RECENT_SECONDS; a row plots its DoF or joint in the curve panel. A draft is not running: it shows
// nothing (its LiveContext carries no net).
import { useContext } from "react";
import { LiveContext, SamplesContext } from "../context";
import { useEditor } from "../store/EditorStore";
import { dofKey, jointKey } from "../telemetry";
import { showCurves } from "./liveUi";
import { amountText, LIMIT_COLOURS, LIMIT_NAMES, recentCorrections, seriesOf } from "./net";

const ROWS = 6;

/** Whether block `id` of `type` stands for the net: a safety limiter, or the output of a graph without one. */
function useStandsForNet(type: string): boolean {
  const nodes = useEditor().state.history.present.nodes;
  return type === "safety_limiter" || (type === "output" && !nodes.some((n) => n.data.type === "safety_limiter"));
}

function NetRowsOf({ id }: { id: string }) {
  const { net } = useContext(LiveContext);
  const samples = useContext(SamplesContext);
  const { robot } = useEditor().state;
  if (!net) return null;
  const recent = new Map([...recentCorrections(samples), ...recentCorrections(samples, undefined, "joint:")].map((r) => [r.key, r]));
  const angular = new Map(seriesOf(robot).map((s) => [s.key, s.angular]));
  // per DoF, and per joint the joint stage corrected (a joint's correction is carried onto its own DoF)
  const counts = [
    ...Object.entries(net.channels).map(([name, n]) => ({ label: name, key: dofKey(name), n })),
    ...Object.entries(net.joints).map(([name, n]) => ({ label: `${name} (joint)`, key: jointKey(name), n })),
  ].sort((a, b) => b.n - a.n);
  return (
    <div className="net-rows" data-testid={`net-${id}`}
         title="The engine's safety net runs after the program: ticks it corrected per DoF since the engine started, and the largest correction of the last seconds">
      <div className="net-head">safety net · {net.ticks} ticks corrected</div>
      {counts.slice(0, ROWS).map(({ label, key, n }) => {
        const r = recent.get(key);
        return (
          <div key={key} role="button" className={`net-row nodrag ${r ? "now" : ""}`} data-testid={`net-${id}-${label}`}
               onClick={() => showCurves([key])} title={r ? `${LIMIT_NAMES[r.limit]} limit; click to plot it` : "click to plot it"}>
            <span className="net-dof">{label}</span>
            <span className="net-n">{n}</span>
            <span className="net-amount" style={{ color: r ? LIMIT_COLOURS[r.limit] : undefined }}>
              {r ? amountText(r.amount, angular.get(key) ?? true) : ""}
            </span>
          </div>
        );
      })}
      {counts.length > ROWS && <div className="net-more">+{counts.length - ROWS} more</div>}
    </div>
  );
}

/** Zoomed out: a badge with the number of DoFs the net corrected, the counts in its tooltip. */
function NetBadge({ id }: { id: string }) {
  const { net } = useContext(LiveContext);
  if (!net || !net.ticks) return null;
  const counts = Object.entries(net.channels).sort((a, b) => b[1] - a[1]);
  if (!counts.length) return null;
  return (
    <span className="net-badge" data-testid={`net-${id}`} onClick={() => showCurves(counts.map(([name]) => dofKey(name)))}
          title={`safety net · ${net.ticks} ticks corrected\n` + counts.map(([name, n]) => `${name} ${n}`).join("\n")}>
      net {counts.length}
    </span>
  );
}

/** The net's per-DoF corrections on the block that stands for it (`compact`: a badge). */
export function NetRows({ id, type, compact = false }: { id: string; type: string; compact?: boolean }) {
  if (type !== "safety_limiter" && type !== "output") return null;
  return <NetRowsFor id={id} type={type} compact={compact} />;
}

function NetRowsFor({ id, type, compact }: { id: string; type: string; compact: boolean }) {
  if (!useStandsForNet(type)) return null;
  return compact ? <NetBadge id={id} /> : <NetRowsOf id={id} />;
}
